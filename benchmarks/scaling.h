// Thread scaling from interleaved rounds, kept to the rounds in which the machine gave
// the cores (machine_probe.h). accel_bench times each (threads, backend) cell once per
// round; round r of an N-thread cell is set against round r of the same backend's
// 1-thread cell, the two timed seconds apart at most.
#pragma once

#include <algorithm>
#include <vector>

namespace bench {

/// The upper median (the middle of an odd count): a timing, never an interpolation.
inline double median(std::vector<double> v) {
    if (v.empty()) return 0.0;
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
}

struct FullRoundScaling {
    int rounds = 0;        ///< rounds in which the machine gave the cores
    double scaling = 0.0;  ///< median N-thread / 1-thread rate over them; 0 if none
};

/// `rates_n`, `probe_n`: the N-thread cell's rate and probe reading per round; `rates_1`,
/// `probe_1`: the 1-thread cell's. A round counts when the probe read >= 0.9 N around both
/// traces: the N-thread one on N cores, and the 1-thread one on a core of its own, since a
/// lone thread whose core's other hardware thread is busy runs slower and inflates the
/// scaling set against it. An empty `probe_1` (a 1-thread trace not probed) leaves the
/// condition to `probe_n`.
inline FullRoundScaling scaling_over_full_rounds(const std::vector<double>& rates_n,
                                                 const std::vector<double>& probe_n,
                                                 const std::vector<double>& rates_1,
                                                 const std::vector<double>& probe_1, int threads) {
    const double need = 0.9 * threads;
    std::vector<double> ratios;
    const size_t n = std::min({rates_n.size(), probe_n.size(), rates_1.size()});
    for (size_t r = 0; r < n; ++r) {
        if (probe_n[r] < need || rates_1[r] <= 0) continue;
        if (r < probe_1.size() && probe_1[r] < need) continue;
        ratios.push_back(rates_n[r] / rates_1[r]);
    }
    return {int(ratios.size()), median(ratios)};
}

/// Parallel efficiency against the CPUs' own speeds: per round, the N-thread rate over the
/// sum of the rates one thread reached alone on each of the N CPUs in that round
/// (`alone[k][r]`: CPU k, round r; CPU 0's is the 1-thread cell), median over the rounds
/// that have all N; 0 if none. On a shared host one vCPU can run a kernel 30 % slower than
/// the other for seconds (measured: its core's other hardware thread busy with work the
/// register-only probe does not feel), and no code can then reach N times the first CPU;
/// against the sum it can still reach 1. N x this efficiency is the scaling on N equal CPUs.
inline double efficiency_over_cpus_alone(const std::vector<double>& rates_n,
                                         const std::vector<std::vector<double>>& alone) {
    std::vector<double> e;
    if (alone.empty()) return 0.0;
    for (size_t r = 0; r < rates_n.size(); ++r) {
        double sum = 0;
        const bool all = std::all_of(alone.begin(), alone.end(), [&](const std::vector<double>& cpu) {
            if (r >= cpu.size() || cpu[r] <= 0) return false;
            sum += cpu[r];
            return true;
        });
        if (all) e.push_back(rates_n[r] / sum);
    }
    return median(e);
}

/// Whether every CPU issues at full width now: `now[k]` is CPU k's issue rate this moment
/// (MachineProbe::issue_rate), `best[k]` the highest it has shown (raised here when `now`
/// beats it). A CPU whose core's other hardware thread is active issues ~25 % slower, and
/// so does every kernel that asks for more instructions per cycle than half a core gives
/// (our traversal, at ~3.5-4 per cycle, with it; Embree's, at about half that, not:
/// accel/DECISIONS.md, "sibling thread's cost"), while a
/// scaling probe, which divides two readings that both suffer, cannot see it.
inline bool at_full_issue(const std::vector<double>& now, std::vector<double>& best, double fraction) {
    if (best.size() < now.size()) best.resize(now.size(), 0.0);
    bool full = true;
    for (size_t k = 0; k < now.size(); ++k) {
        best[k] = std::max(best[k], now[k]);
        full = full && now[k] >= fraction * best[k];
    }
    return full;
}

/// One timed round of a study that waits for its cores: `wait()` waits (within its own
/// limit) for N cores of full width, `trace()` times the round and returns its rate,
/// `full_after()` reads whether every CPU still issued at full width right after it.
/// The wait before a trace cannot see a sibling hardware thread that starts during it
/// (the one miss left when only the wait before was checked began inside a trace), the reading
/// after can: a round that ends on a narrower core is timed again, at most `retimes`
/// times, the last attempt kept whatever it reads. The rates set aside go to `discarded`.
template <class Wait, class Trace, class Check>
double timed_round(Wait&& wait, Trace&& trace, Check&& full_after, int retimes, std::vector<double>& discarded) {
    for (int attempt = 0;; ++attempt) {
        wait();
        const double rate = trace();
        if (full_after() || attempt >= retimes) return rate;
        discarded.push_back(rate);
    }
}

}  // namespace bench
