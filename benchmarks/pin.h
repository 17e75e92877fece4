// Pins the threads of a timed TBB arena, one CPU each, for the duration of the arena's
// work. Measured on the 2-vCPU CI machine (RESULTS.md, session 5): an unpinned
// single-threaded trace is now and then moved between the vCPUs, and every move costs
// a refill of the tree from the other core's caches; our kernel's cells then read 15-40 %
// slow in some processes and not in others, Embree's 2-5 %. Pinned, both backends run
// at their fast, repeatable speed, so the ratio compares kernels, not the scheduler.
#pragma once

#include <sched.h>

#include <tbb/task_arena.h>
#include <tbb/task_scheduler_observer.h>

#include <vector>

namespace bench {

class PinArena : public tbb::task_scheduler_observer {
public:
    /// `on`: false leaves the threads to the scheduler (--no-pin).
    PinArena(tbb::task_arena& arena, bool on) : tbb::task_scheduler_observer(arena), on_(on) {
        if (!on_) return;
        CPU_ZERO(&all_);
        if (sched_getaffinity(0, sizeof(all_), &all_) != 0) return;
        for (int c = 0; c < CPU_SETSIZE; ++c)
            if (CPU_ISSET(c, &all_)) cpus_.push_back(c);
        if (!cpus_.empty()) observe(true);
    }
    ~PinArena() override { observe(false); }

    void on_scheduler_entry(bool) override {
        const int slot = tbb::this_task_arena::current_thread_index();
        cpu_set_t one;
        CPU_ZERO(&one);
        CPU_SET(cpus_[size_t(slot < 0 ? 0 : slot) % cpus_.size()], &one);
        sched_setaffinity(0, sizeof(one), &one);
    }
    void on_scheduler_exit(bool) override { sched_setaffinity(0, sizeof(all_), &all_); }

private:
    bool on_;
    cpu_set_t all_{};
    std::vector<int> cpus_;
};

}  // namespace bench
