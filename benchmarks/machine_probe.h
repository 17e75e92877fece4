// The machine's own N-thread scaling, measured beside each timed N-thread cell.
//
// Why (benchmarks/RESULTS.md, "Thread scaling"): on the 2-vCPU CI machine a loop of register-only
// multiply-adds, with no memory traffic and nothing shared, scales 1.0x to 2.6x from one
// thread to two, varying from one second to the next. The host now and then runs both
// vCPUs on the two hardware threads of one core (or takes one away), and no kernel can
// scale then: the better a kernel fills a core's pipes, the less a second hardware thread
// adds. A thread-scaling figure without the machine's own figure beside it cannot tell a
// kernel that does not scale from a machine that gave one core. So every N-thread trace
// is bracketed by this probe, and accel_bench reports the probe and the scaling over the
// rounds in which the machine gave N cores.
#pragma once

#include <sched.h>
#include <xmmintrin.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "benchmarks/pin.h"
#include "benchmarks/scaling.h"

namespace bench {

class MachineProbe {
public:
    /// `pin`: thread i runs on the process's i-th CPU (as PinArena pins the timed threads).
    explicit MachineProbe(bool pin) : pin_(pin) {
        cpus_ = process_cpus(all_);
        // About 2 ms of work per thread: short beside a trace, long beside thread start-up.
        long n = 1 << 14;
        double t = 0;
        for (int k = 0; k < 3; ++k) t = k == 0 ? seconds(n) : std::min(t, seconds(n));
        iterations_ = std::max<long>(1 << 12, long(double(n) * 2e-3 / std::max(t, 1e-9)));
        // About 1 ms of the issue loop per CPU, and a first best rate from a few readings
        // (the best only rises: a CPU never issues faster than its core allows).
        const double ti = elapsed([] { issue_loop(1 << 12); });
        issue_steps_ = std::max<long>(1 << 10, long(double(1 << 12) * 1e-3 / std::max(ti, 1e-9)));
        for (int k = 0; k < 3; ++k) full_issue(int(cpus_.empty() ? 1 : cpus_.size()), 0.0);
    }

    /// The speed-up of `threads` threads running the same work at once over one thread
    /// alone: `threads` on N free cores, ~1 when they share one core's pipes.
    double scaling(int threads) const {
        const double alone = timed_on(0);
        std::vector<double> each(size_t(threads), 0.0);
        std::atomic<int> ready{0};
        std::vector<std::thread> pool;
        for (int i = 1; i < threads; ++i)
            pool.emplace_back([&, i] { each[size_t(i)] = run_synchronised(i, ready, threads); });
        each[0] = run_synchronised(0, ready, threads);
        for (auto& th : pool) th.join();
        unpin();
        double sum = 0;
        for (double t : each) sum += alone / std::max(t, 1e-9);
        return sum;
    }

    /// Instructions per second (in billions) one CPU issues on a register-only loop that
    /// asks for more per cycle than a core dispatches: four integer and four vector add
    /// chains, each step independent of the others' (~5.5 per cycle alone on the Zen 4
    /// CI machine). Unlike scaling(), which divides two readings, this one is absolute, so
    /// it sees what slows a CPU whatever the process does: another tenant's thread on the
    /// core's other hardware thread. Measured (accel/DECISIONS.md, "sibling thread's cost"): in the sets of a co-runner
    /// experiment where our kernel traced below 0.85 of its speed, this loop, timed just
    /// after it, was slow too in 40 of 61; a loop asking 2 per cycle never was, nor Embree.
    double issue_rate(int slot) const {
        pin_to(slot);
        const double t = elapsed([this] { issue_loop(issue_steps_); });
        unpin();
        return double(issue_steps_) * kIssueOps * 1e-9 / std::max(t, 1e-9);
    }

    /// True when each of the first `threads` CPUs issues at >= `fraction` of the best rate
    /// it has shown to this probe (at_full_issue); the readings go in `now` if given.
    bool full_issue(int threads, double fraction, std::vector<double>* now = nullptr) const {
        std::vector<double> r;
        for (int i = 0; i < threads; ++i) r.push_back(issue_rate(i));
        if (now) *now = r;
        return at_full_issue(r, best_issue_, fraction);
    }

private:
    static constexpr int kIssueOps = 64;  ///< instructions per issue_loop step
    /// `steps` x 64 register-only instructions, eight independent chains of latency 1.
    static void issue_loop(long steps) {
#define PT_ISSUE8                                                                                    \
    "add $1, %%r8\n\t add $1, %%r9\n\t add $1, %%r10\n\t add $1, %%r11\n\t paddd %%xmm8, %%xmm0\n\t " \
    "paddd %%xmm8, %%xmm1\n\t paddd %%xmm8, %%xmm2\n\t paddd %%xmm8, %%xmm3\n\t"
        for (long k = 0; k < steps; ++k)
            __asm__ volatile(PT_ISSUE8 PT_ISSUE8 PT_ISSUE8 PT_ISSUE8 PT_ISSUE8 PT_ISSUE8 PT_ISSUE8 PT_ISSUE8 ::
                                 : "r8", "r9", "r10", "r11", "xmm0", "xmm1", "xmm2", "xmm3", "xmm8");
#undef PT_ISSUE8
    }

    /// Twelve independent 4-wide multiply-then-add chains (SSE2, so any x86-64): enough in
    /// flight to keep a core's multiply pipes full, so a second hardware thread on the
    /// same core halves each thread's speed. (The first version, eight scalar chains,
    /// was latency-bound: two threads on one core both ran at full speed, and it read
    /// 2.0 while an 8-chain AVX2 FMA loop read 1.0-1.3.) Memory is untouched.
    static float work(long n) {
        // Named accumulators, not an array: an array went through the stack (store to
        // load forwarding on every step), which made the loop latency-bound again.
        const __m128 m = _mm_set1_ps(0.999999f), c = _mm_set1_ps(1e-7f);
        __m128 a0 = _mm_set1_ps(1.000f), a1 = _mm_set1_ps(1.001f), a2 = _mm_set1_ps(1.002f),
               a3 = _mm_set1_ps(1.003f), a4 = _mm_set1_ps(1.004f), a5 = _mm_set1_ps(1.005f),
               a6 = _mm_set1_ps(1.006f), a7 = _mm_set1_ps(1.007f), a8 = _mm_set1_ps(1.008f),
               a9 = _mm_set1_ps(1.009f), a10 = _mm_set1_ps(1.010f), a11 = _mm_set1_ps(1.011f);
        const auto step = [m, c](__m128& a) { a = _mm_add_ps(_mm_mul_ps(a, m), c); };
        for (long k = 0; k < n; ++k) {
            step(a0), step(a1), step(a2), step(a3), step(a4), step(a5);
            step(a6), step(a7), step(a8), step(a9), step(a10), step(a11);
        }
        const __m128 s = _mm_add_ps(_mm_add_ps(_mm_add_ps(a0, a1), _mm_add_ps(a2, a3)),
                                    _mm_add_ps(_mm_add_ps(_mm_add_ps(a4, a5), _mm_add_ps(a6, a7)),
                                               _mm_add_ps(_mm_add_ps(a8, a9), _mm_add_ps(a10, a11))));
        return _mm_cvtss_f32(s);
    }
    template <class F>
    static double elapsed(F&& f) {
        const auto t0 = std::chrono::steady_clock::now();
        f();
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    }
    static double seconds(long n) {
        return elapsed([n] { sink_ = sink_ + work(n); });
    }
    void pin_to(int slot) const {
        if (pin_ && !cpus_.empty()) pin_this_thread(cpus_[size_t(slot) % cpus_.size()]);
    }
    void unpin() const {
        if (!pin_ || cpus_.empty()) return;
        sched_setaffinity(0, sizeof(all_), &all_);
    }
    double timed_on(int slot) const {
        pin_to(slot);
        return seconds(iterations_);
    }
    /// Every thread starts its timed work once all are pinned and ready, so thread
    /// start-up neither counts nor lets one thread run alone at the start.
    double run_synchronised(int slot, std::atomic<int>& ready, int threads) const {
        pin_to(slot);
        ready.fetch_add(1);
        const auto limit = std::chrono::steady_clock::now() + std::chrono::milliseconds(50);
        while (ready.load() < threads && std::chrono::steady_clock::now() < limit) {
        }
        return seconds(iterations_);
    }

    bool pin_;
    cpu_set_t all_{};  ///< the process's CPUs at construction, restored after each probe
    std::vector<int> cpus_;
    long iterations_ = 0;
    long issue_steps_ = 1 << 10;
    mutable std::vector<double> best_issue_;  ///< per CPU slot, the highest issue rate seen
    static inline volatile float sink_ = 0;
};

}  // namespace bench
