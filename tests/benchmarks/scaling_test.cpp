// accel_bench's scaling over the rounds in which the machine gave the cores: which rounds
// count decides whether a thread-scaling figure measures the kernel or the host.
#include <gtest/gtest.h>

#include "benchmarks/scaling.h"

TEST(Median, IsTheMiddleTimingNotAnAverage) {
    EXPECT_EQ(bench::median({}), 0.0);
    EXPECT_EQ(bench::median({3.0, 1.0, 2.0}), 2.0);
    EXPECT_EQ(bench::median({4.0, 1.0, 3.0, 2.0}), 3.0);  // upper middle: a measured value
}

TEST(FullRoundScaling, CountsOnlyRoundsWhereBothTracesHadTheCores) {
    // Round 0: both on two cores. Round 1: the 2-thread trace shared a core (probe 1.1).
    // Round 2: the 1-thread trace shared its core: it ran slow, and its 2.5x must not count.
    // Round 3: both fine again.
    const std::vector<double> two = {19.0, 12.0, 20.0, 18.0}, two_probe = {1.95, 1.10, 1.90, 1.85};
    const std::vector<double> one = {10.0, 10.0, 8.0, 10.0}, one_probe = {1.90, 1.92, 1.15, 2.00};
    const auto s = bench::scaling_over_full_rounds(two, two_probe, one, one_probe, 2);
    EXPECT_EQ(s.rounds, 2);
    EXPECT_DOUBLE_EQ(s.scaling, 1.9);  // rounds 0 and 3: 1.9 and 1.8, upper median
}

TEST(FullRoundScaling, UnprobedOneThreadTracesLeaveItToTheNThreadProbe) {
    const auto s = bench::scaling_over_full_rounds({19.0, 12.0, 20.0}, {1.95, 1.10, 1.90}, {10.0, 10.0, 10.0}, {}, 2);
    EXPECT_EQ(s.rounds, 2);
    EXPECT_DOUBLE_EQ(s.scaling, 2.0);
}

TEST(FullRoundScaling, NoRoundWithTheCoresGivesNoFigure) {
    const auto s = bench::scaling_over_full_rounds({12.0, 13.0}, {1.1, 1.2}, {10.0, 10.0}, {2.0, 2.0}, 2);
    EXPECT_EQ(s.rounds, 0);
    EXPECT_EQ(s.scaling, 0.0);
    // Four threads need a probe of 3.6: 1.95 (two cores) is not enough.
    EXPECT_EQ(bench::scaling_over_full_rounds({30.0}, {1.95}, {10.0}, {3.9}, 4).rounds, 0);
    // Fewer 1-thread rounds than N-thread ones (a cell cut short): only the pairs count.
    EXPECT_EQ(bench::scaling_over_full_rounds({20.0, 20.0}, {2.0, 2.0}, {10.0}, {2.0}, 2).rounds, 1);
}

TEST(EfficiencyOverCpusAlone, SetsEachRoundAgainstBothCpusInThatRound) {
    // Round 0: equal CPUs, 19 of 20. Round 1: CPU 1 ran at 70 % alone, and two threads
    // reached its sum (17 of 17): no code could reach 2x CPU 0 there. Round 2: two threads
    // fell short of equal CPUs (15 of 20).
    const std::vector<double> two = {19.0, 17.0, 15.0};
    const std::vector<std::vector<double>> alone = {{10.0, 10.0, 10.0}, {10.0, 7.0, 10.0}};
    EXPECT_DOUBLE_EQ(bench::efficiency_over_cpus_alone(two, alone), 0.95);  // of 0.95, 1.0, 0.75
    // Two rounds: 15 of 20 and 15 of 17; the upper median is the second.
    EXPECT_DOUBLE_EQ(bench::efficiency_over_cpus_alone({15.0, 15.0}, alone), 15.0 / 17.0);
}

TEST(EfficiencyOverCpusAlone, NeedsEveryCpuInTheRound) {
    EXPECT_EQ(bench::efficiency_over_cpus_alone({19.0}, {}), 0.0);
    EXPECT_EQ(bench::efficiency_over_cpus_alone({19.0, 19.0}, {{10.0, 10.0}, {}}), 0.0);
    // A CPU with fewer rounds: only the rounds every CPU has count.
    EXPECT_DOUBLE_EQ(bench::efficiency_over_cpus_alone({19.0, 10.0}, {{10.0, 10.0}, {10.0}}), 0.95);
}

TEST(AtFullIssue, ACpuBelowTheFractionOfItsBestFails) {
    std::vector<double> best{20.0, 20.0};
    EXPECT_TRUE(bench::at_full_issue({19.0, 18.5}, best, 0.9));
    // CPU 1 at 0.75 of its best: the state in which a sibling hardware thread is active.
    EXPECT_FALSE(bench::at_full_issue({19.5, 15.0}, best, 0.9));
    EXPECT_EQ(best, (std::vector<double>{20.0, 20.0}));
}

TEST(AtFullIssue, ANewBestRaisesTheBarForLaterReadings) {
    std::vector<double> best;  // grows to the CPUs read
    EXPECT_TRUE(bench::at_full_issue({15.0}, best, 0.9));  // the first reading is the best so far
    EXPECT_TRUE(bench::at_full_issue({21.0}, best, 0.9));
    EXPECT_EQ(best, std::vector<double>{21.0});
    // 15 passed when it was the best; against 21 it is a slow core.
    EXPECT_FALSE(bench::at_full_issue({15.0}, best, 0.9));
}

TEST(TimedRound, ARoundEndingOnFullCoresIsKeptAtOnce) {
    int waits = 0, traces = 0, checks = 0;
    std::vector<double> discarded;
    const double rate = bench::timed_round([&] { ++waits; }, [&] { return 10.0 + ++traces; },
                                           [&] { return ++checks > 0; }, 2, discarded);
    EXPECT_EQ(rate, 11.0);
    EXPECT_EQ(waits, 1);
    EXPECT_EQ(traces, 1);
    EXPECT_EQ(checks, 1);
    EXPECT_TRUE(discarded.empty());
}

TEST(TimedRound, ARoundEndingOnANarrowCoreIsTimedAgainAfterAnotherWait) {
    int waits = 0, traces = 0, checks = 0;
    std::vector<double> discarded;
    // The first trace ends with a CPU below full issue, the second on full cores.
    const double rate = bench::timed_round([&] { ++waits; }, [&] { return 10.0 * ++traces; },
                                           [&] { return ++checks == 2; }, 2, discarded);
    EXPECT_EQ(rate, 20.0);
    EXPECT_EQ(waits, 2);
    EXPECT_EQ(traces, 2);
    EXPECT_EQ(discarded, std::vector<double>{10.0});
}

TEST(TimedRound, TheLastAttemptIsKeptWhateverItReads) {
    int traces = 0;
    std::vector<double> discarded;
    const double rate = bench::timed_round([] {}, [&] { return double(++traces); }, [] { return false; }, 2, discarded);
    EXPECT_EQ(rate, 3.0);  // one round and two more attempts, never more
    EXPECT_EQ(discarded, (std::vector<double>{1.0, 2.0}));
    // No retimes allowed: the first trace is the round's, read as it may.
    discarded.clear();
    traces = 0;
    EXPECT_EQ(bench::timed_round([] {}, [&] { return double(++traces); }, [] { return false; }, 0, discarded), 1.0);
    EXPECT_TRUE(discarded.empty());
}
