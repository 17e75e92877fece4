// A backend could not get memory it asked for outside operator new (Embree reports
// RTC_ERROR_OUT_OF_MEMORY through its error callback; its own allocator never throws to
// us). Thrown as a std::bad_alloc so that callers end it like any other failed
// allocation, with the size of the request when the backend reported one.
#pragma once

#include <cstdint>
#include <new>
#include <string>
#include <utility>

namespace accel {

class OutOfMemory : public std::bad_alloc {
public:
    /// `message` empty: what() says "an allocation of N bytes failed".
    OutOfMemory(uint64_t bytes, std::string message)
        : bytes_(bytes),
          message_(message.empty() ? "an allocation of " + std::to_string(bytes) + " bytes failed"
                                   : std::move(message)) {}
    const char* what() const noexcept override { return message_.c_str(); }
    /// Whether what() is only the default text (callers may say it their way).
    bool plain() const { return message_.rfind("an allocation of ", 0) == 0; }
    /// The request that failed, 0 when unknown.
    uint64_t bytes() const { return bytes_; }

private:
    uint64_t bytes_;
    std::string message_;
};

/// Throws OutOfMemory for a failed request of `bytes`. Out of line, so that the inline
/// allocators of the BVH kernel headers gain no inline instances of their own.
[[noreturn]] void throw_out_of_memory(uint64_t bytes);

}  // namespace accel
