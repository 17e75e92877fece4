// Pins the threads of a timed TBB arena, one CPU each, for the duration of the arena's
// work. Measured on the 2-vCPU CI machine (accel/DECISIONS.md, "pinned timing"): an unpinned
// single-threaded trace is now and then moved between the vCPUs, and every move costs
// a refill of the tree from the other core's caches; our kernel's cells then read 15-40 %
// slow in some processes and not in others, Embree's 2-5 %. Pinned, both backends run
// at their fast, repeatable speed, so the ratio compares kernels, not the scheduler.
//
// Pinning does not remove a second effect: for minutes at a time one
// vCPU can run the same code much slower than the other, as when the physical core's
// other hardware thread is busy with another tenant's work. Measured pinned, in
// alternating processes: our kernel alone on the second vCPU at 0.65-0.70 of the first
// (every ISA), Embree at 0.90-0.94; a loop of stores and reloads at 0.5. So accel_bench
// also times one thread alone on each further CPU and sets N threads against their sum.
#pragma once

#include <sched.h>

#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>

#include <algorithm>
#include <vector>

namespace bench {

/// The CPUs the process may use, in order (the ones PinArena pins to); `all` gets the set.
inline std::vector<int> process_cpus(cpu_set_t& all) {
    std::vector<int> cpus;
    CPU_ZERO(&all);
    if (sched_getaffinity(0, sizeof(all), &all) != 0) return cpus;
    for (int c = 0; c < CPU_SETSIZE; ++c)
        if (CPU_ISSET(c, &all)) cpus.push_back(c);
    return cpus;
}

/// How many CPUs the process may use (at least 1).
inline int usable_cpus() {
    cpu_set_t all;
    return std::max<int>(1, int(process_cpus(all).size()));
}

/// Runs the calling thread on `cpu` alone.
inline void pin_this_thread(int cpu) {
    cpu_set_t one;
    CPU_ZERO(&one);
    CPU_SET(cpu, &one);
    sched_setaffinity(0, sizeof(one), &one);
}

class PinArena : public tbb::task_scheduler_observer {
public:
    /// `on`: false leaves the threads to the scheduler (--no-pin). Thread i runs on the
    /// (first + i)-th CPU, counting round the process's CPUs: first > 0 times one
    /// thread on another CPU than the first.
    PinArena(tbb::task_arena& arena, bool on, int first = 0)
        : tbb::task_scheduler_observer(arena), on_(on), first_(first) {
        if (!on_) return;
        cpus_ = process_cpus(all_);
        if (!cpus_.empty()) observe(true);
    }
    ~PinArena() override { observe(false); }

    void on_scheduler_entry(bool) override {
        const int slot = tbb::this_task_arena::current_thread_index();
        pin_this_thread(cpus_[size_t(first_ + (slot < 0 ? 0 : slot)) % cpus_.size()]);
    }
    void on_scheduler_exit(bool) override { sched_setaffinity(0, sizeof(all_), &all_); }

private:
    bool on_;
    int first_;
    cpu_set_t all_{};
    std::vector<int> cpus_;
};

}  // namespace bench
