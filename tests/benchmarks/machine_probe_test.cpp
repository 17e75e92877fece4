// The machine probe accel_bench sets beside every N-thread trace. Its figure is timing
// and is not asserted; what it must not do is leave the calling thread pinned: the first
// version restored the thread's own (just pinned) mask, so every later PinArena saw one
// CPU and ran both "threads" of a 2-thread trace on it (accel_bench read 1.00x).
#include <gtest/gtest.h>

#include <sched.h>

#include <cmath>
#include <vector>

#include "benchmarks/machine_probe.h"

namespace {

bool same(const cpu_set_t& a, const cpu_set_t& b) { return CPU_EQUAL(&a, &b); }

cpu_set_t current() {
    cpu_set_t s;
    CPU_ZERO(&s);
    sched_getaffinity(0, sizeof(s), &s);
    return s;
}

}  // namespace

TEST(MachineProbe, LeavesTheCallersCpusAsTheyWere) {
    const cpu_set_t before = current();
    for (bool pin : {true, false}) {
        const bench::MachineProbe probe(pin);
        for (int threads : {1, 2, 3}) {
            const double s = probe.scaling(threads);
            EXPECT_TRUE(std::isfinite(s)) << threads << " threads, pin " << pin;
            EXPECT_GT(s, 0.0) << threads << " threads, pin " << pin;
            EXPECT_TRUE(same(current(), before)) << "affinity changed after " << threads << " threads, pin " << pin;
            EXPECT_EQ(bench::usable_cpus(), CPU_COUNT(&before));
            std::vector<double> issue;
            probe.full_issue(threads, 0.9, &issue);
            ASSERT_EQ(issue.size(), size_t(threads));
            for (double r : issue) EXPECT_GT(r, 0.0) << "issue rate, " << threads << " CPUs, pin " << pin;
            EXPECT_TRUE(same(current(), before)) << "affinity changed by full_issue, " << threads << " CPUs, pin " << pin;
        }
    }
}
