#include "tools/memory/memory.h"

#include <fmt/format.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <limits>
#include <typeinfo>

#include "accel/out_of_memory.h"

namespace {

std::atomic<uint64_t> g_failures{0};
std::atomic<uint64_t> g_last_failed{0};
// The stage is process-wide, not per thread: worker threads work for the stage the main
// thread is in, and their exceptions are reported by whichever thread catches them.
std::atomic<const char*> g_stage{"starting"};
std::atomic<bool> g_line_open{false};
const char* g_prog = "program";
void (*g_exit_hook)(int) = nullptr;
std::atomic<bool> g_exiting{false};
// Address space set aside at start and given back before the one-line exit, so that
// formatting the message (and MPI's abort) can allocate when nothing else could.
void* g_reserve = nullptr;

[[noreturn]] void fail_allocation(std::size_t n) {
    g_last_failed.store(n, std::memory_order_relaxed);
    g_failures.fetch_add(1, std::memory_order_relaxed);
    throw std::bad_alloc();
}

void* allocate(std::size_t n) {
    if (n == 0) n = 1;
    for (;;) {
        if (void* p = std::malloc(n)) return p;
        std::new_handler h = std::get_new_handler();
        if (!h) fail_allocation(n);
        h();
    }
}

void* allocate_aligned(std::size_t n, std::align_val_t al) {
    const std::size_t a = std::max(std::size_t(al), sizeof(void*));
    if (n == 0) n = 1;
    for (;;) {
        void* p = nullptr;
        if (::posix_memalign(&p, a, n) == 0) return p;
        std::new_handler h = std::get_new_handler();
        if (!h) fail_allocation(n);
        h();
    }
}

/// A bad_alloc that reaches std::terminate (thrown in a thread, or through a noexcept
/// function) ends as the one-line exit too; anything else keeps the default behaviour.
[[noreturn]] void on_terminate() {
    if (std::exception_ptr e = std::current_exception()) {
        try {
            std::rethrow_exception(e);
        } catch (const std::bad_alloc& b) {
            tools::memory::out_of_memory(b);
        } catch (...) {
        }
    }
    std::abort();
}

uint64_t status_field(const char* key) {
    std::ifstream in("/proc/self/status");
    std::string line;
    const size_t n = std::strlen(key);
    while (std::getline(in, line))
        if (line.compare(0, n, key) == 0) return std::strtoull(line.c_str() + n, nullptr, 10) * 1024;
    return 0;
}

}  // namespace

// The replacements every allocation of the program goes through (shared libraries
// included: they bind to the executable's definitions). The array and sized forms of
// the standard library call these.
void* operator new(std::size_t n) { return allocate(n); }
void* operator new[](std::size_t n) { return allocate(n); }
void* operator new(std::size_t n, std::align_val_t al) { return allocate_aligned(n, al); }
void* operator new[](std::size_t n, std::align_val_t al) { return allocate_aligned(n, al); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace tools::memory {

void install(const char* prog) {
    g_prog = prog;
    g_reserve = std::malloc(size_t(1) << 20);
    std::set_terminate(on_terminate);
}

void on_exit(void (*hook)(int status)) { g_exit_hook = hook; }

Stage::Stage(const char* name, bool line_open)
    : previous_(g_stage.exchange(name)),
      previous_open_(g_line_open.exchange(line_open)),
      uncaught_(std::uncaught_exceptions()) {}
Stage::~Stage() {
    if (std::uncaught_exceptions() > uncaught_) return;
    g_stage.store(previous_);
    g_line_open.store(previous_open_);
}

void set_stage(const char* name) {
    g_stage.store(name);
    g_line_open.store(false);
}

uint64_t failures() { return g_failures.load(); }
uint64_t last_failed_bytes() { return g_last_failed.load(); }

std::string size_text(uint64_t bytes) {
    const double b = double(bytes);
    if (b >= 1024.0 * 1024 * 1024) return fmt::format("{:.2f} GiB", b / (1024.0 * 1024 * 1024));
    if (b >= 1024.0 * 1024) return fmt::format("{:.1f} MiB", b / (1024.0 * 1024));
    if (b >= 1024.0) return fmt::format("{:.1f} KiB", b / 1024.0);
    return fmt::format("{} bytes", bytes);
}

std::string bytes_text(uint64_t bytes) {
    if (bytes < 1024) return fmt::format("{} bytes", bytes);
    return fmt::format("{} ({} bytes)", size_text(bytes), bytes);
}

void out_of_memory(uint64_t bytes, const std::string& what) {
    // A second thread failing at the same moment must not print a second line.
    if (g_exiting.exchange(true)) {
        for (;;) ::pause();
    }
    std::free(g_reserve);
    g_reserve = nullptr;
    if (bytes == 0) bytes = g_last_failed.load();
    const std::string detail = !what.empty() ? what
                               : bytes > 0   ? "an allocation of " + bytes_text(bytes) + " failed"
                                             : "an allocation failed";
    std::fflush(stdout);
    std::fprintf(stderr, "%s%s: error: out of memory while %s: %s\n", g_line_open.load() ? "\n" : "", g_prog,
                 g_stage.load(), detail.c_str());
    std::fflush(stderr);
    if (g_exit_hook) g_exit_hook(kExitOutOfMemory);
    // Other threads may still be running (a render's workers): no static destructors.
    std::_Exit(kExitOutOfMemory);
}

void refuse(const std::string& message) {
    std::free(g_reserve);
    g_reserve = nullptr;
    std::fflush(stdout);
    std::fprintf(stderr, "%s: error: out of memory: %s\n", g_prog, message.c_str());
    std::fflush(stderr);
    if (g_exit_hook) g_exit_hook(kExitOutOfMemory);
    std::_Exit(kExitOutOfMemory);
}

void out_of_memory(const std::bad_alloc& e) {
    std::free(g_reserve);  // the message below is formatted on the heap
    g_reserve = nullptr;
    if (const auto* oom = dynamic_cast<const accel::OutOfMemory*>(&e)) {
        if (oom->plain()) out_of_memory(oom->bytes());
        out_of_memory(oom->bytes(), oom->bytes() ? fmt::format("{} (an allocation of {})", oom->what(),
                                                               bytes_text(oom->bytes()))
                                                 : std::string(oom->what()));
    }
    out_of_memory(0);
}

uint64_t resident_bytes() { return status_field("VmRSS:"); }
uint64_t peak_resident_bytes() { return status_field("VmHWM:"); }

uint64_t memory_limit(bool address_space, std::string* why) {
    uint64_t limit = std::numeric_limits<uint64_t>::max();
    std::string name;
    {
        std::ifstream in("/proc/meminfo");
        std::string key;
        uint64_t kb = 0, mem = 0, swap = 0;
        std::string unit;
        while (in >> key >> kb) {
            std::getline(in, unit);
            if (key == "MemTotal:") mem = kb * 1024;
            if (key == "SwapTotal:") swap = kb * 1024;
        }
        if (mem > 0) {
            limit = mem + swap;
            name = "this machine's memory and swap";
        }
    }
    rlimit rl{};
    if (address_space && ::getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && uint64_t(rl.rlim_cur) < limit) {
        limit = uint64_t(rl.rlim_cur);
        name = "the address-space limit (ulimit -v)";
    }
    {
        std::ifstream in("/sys/fs/cgroup/memory.max");
        std::string v;
        if (in >> v && v != "max") {
            const uint64_t c = std::strtoull(v.c_str(), nullptr, 10);
            if (c > 0 && c < limit) {
                limit = c;
                name = "the cgroup's memory.max";
            }
        }
    }
    if (why) *why = name;
    return limit;
}

}  // namespace tools::memory
