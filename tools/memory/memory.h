// Running out of memory as an error, not a crash, for every executable of the project
// (tools and benchmarks link tools/memory as an object library; the libraries do not).
//
// std::bad_alloc carries no size and no place. This module replaces the global operator
// new so that a failed request leaves its size behind, keeps the name of the stage the
// program is in (loading, building the BVH, the film, ...), and ends the program with one
// line on stderr and exit status 3, wherever the exception surfaces: in the tool's own
// catch, or in std::terminate (a worker thread, a noexcept function) through the handler
// install() sets. Exit status 3 means "out of memory", apart from 2 (bad input) and 1.
#pragma once

#include <cstdint>
#include <new>
#include <string>

namespace tools::memory {

inline constexpr int kExitOutOfMemory = 3;

/// Sets the program name for messages and the terminate handler that turns an uncaught
/// std::bad_alloc into the one-line exit. Call first thing in main.
void install(const char* prog);

/// Called once before the out-of-memory exit with its status (MPI stops every rank).
void on_exit(void (*hook)(int status));

/// The stage named by the out-of-memory line while this object lives ("loading the
/// scene", "building the BVH", ...); stages nest and the innermost is named. An exception
/// that leaves the stage keeps its name, so a catch further out still names where the
/// allocation failed. `line_open`:
/// the stage leaves a progress line unfinished ("Building BVH... "), so the error starts
/// a new one.
class Stage {
public:
    explicit Stage(const char* name, bool line_open = false);
    ~Stage();
    Stage(const Stage&) = delete;
    Stage& operator=(const Stage&) = delete;

private:
    const char* previous_;
    bool previous_open_;
    int uncaught_;
};

/// Names the stage from here on, for code that reports its steps through a callback
/// (renderer::RenderSettings::on_stage) rather than in scopes of its own.
void set_stage(const char* name);

/// How many allocations through operator new have failed so far. A library that turns
/// std::bad_alloc into its own error (a loader's "invalid file: std::bad_alloc") is
/// recognised by this count changing across the call.
uint64_t failures();

/// The size of the most recent failed request (0: none recorded).
uint64_t last_failed_bytes();

/// "PROG: error: out of memory while STAGE: ...", then exit status 3. `bytes` = 0 names
/// the last failed request; `what` replaces the default "an allocation of N failed".
[[noreturn]] void out_of_memory(uint64_t bytes = 0, const std::string& what = {});

/// A refusal before any work: "PROG: error: out of memory: MESSAGE", exit status 3.
[[noreturn]] void refuse(const std::string& message);

/// Ends the program through out_of_memory when `e` came from a failed allocation: a
/// std::bad_alloc (with the size of accel::OutOfMemory when it is one).
[[noreturn]] void out_of_memory(const std::bad_alloc& e);

/// "1.50 GiB (1610612736 bytes)".
std::string bytes_text(uint64_t bytes);
/// "1.50 GiB".
std::string size_text(uint64_t bytes);

/// This process's resident set now and its high-water mark (VmRSS, VmHWM; 0 if unknown).
uint64_t resident_bytes();
uint64_t peak_resident_bytes();

/// What this process may hold at most: the least of physical memory plus swap and the
/// cgroup's memory.max, and, with `address_space`, the address-space limit (ulimit -v;
/// only for comparisons with address space, which exceeds the resident set by thread
/// stacks and malloc arenas). `why` names which one it is.
uint64_t memory_limit(bool address_space, std::string* why = nullptr);

}  // namespace tools::memory
