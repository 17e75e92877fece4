// The split's map (renderer/split_map.h): branches go where the first samples showed
// relative noise, as many in all as the uniform split sends.
#include "renderer/split_map.h"

#include <gtest/gtest.h>

#include <cmath>

namespace {

using namespace renderer;

constexpr int kW = 40, kH = 20, kP0 = 8;

/// A state after kP0 samples per pixel of mean luminance `mean(x, y)` (grey), whose two
/// halves' means differ by +-`diff(x, y)`, and the halves' RGB sums.
struct FirstSamples {
    Accumulation acc;
    std::vector<double> half;
    template <class Mean, class Diff>
    FirstSamples(Mean mean, Diff diff) {
        acc.width = kW;
        acc.height = kH;
        acc.pixels.assign(size_t(kW) * kH, PixelSums{});
        half.assign(size_t(kW) * kH * 3, 0.0);
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x) {
                PixelSums& q = acc.pixels[size_t(y) * kW + size_t(x)];
                q.taken = q.n = kP0;
                q.rays = 10 * kP0;  // more than camera rays: the pixel splits
                const double m = mean(x, y), d = ((x + y) % 2 ? 1 : -1) * diff(x, y);
                q.s1 = kP0 * m;
                for (int c = 0; c < 3; ++c) {
                    q.rgb[c] = kP0 * m;
                    // Halves of kP0 / 2 samples with means m + d / 2 and m - d / 2.
                    half[3 * (size_t(y) * kW + size_t(x)) + size_t(c)] =
                        kP0 / 2 * (m + d / 2);
                }
            }
    }
    SplitMap map(int mean_k = 4) const {
        return SplitMap::from_sums(acc, half, Cell{0, 0, kW, kH}, kP0, mean_k,
                                   2 * mean_k);
    }
};

double mean_k(const SplitMap& m, int x0, int x1) {
    double s = 0;
    for (int y = 0; y < kH; ++y)
        for (int x = x0; x < x1; ++x) s += m.at(x, y);
    return s / double((x1 - x0) * kH);
}

TEST(SplitMap, FirstSamplesAreAnEighthFromFourToEight) {
    EXPECT_EQ(SplitMap::first_samples(4), 0);  // too few samples: the uniform split
    EXPECT_EQ(SplitMap::first_samples(7), 0);
    EXPECT_EQ(SplitMap::first_samples(8), 4);
    EXPECT_EQ(SplitMap::first_samples(16), 4);
    EXPECT_EQ(SplitMap::first_samples(64), 8);
    EXPECT_EQ(SplitMap::first_samples(4096), 8);
}

TEST(SplitMap, NoisierPixelsTakeMoreBranchesAndTheMeanStays) {
    // The left half four times as noisy, relative to the same mean, as the right.
    const FirstSamples f([](int, int) { return 0.5; },
                         [](int x, int) { return x < kW / 2 ? 0.2 : 0.05; });
    const SplitMap m = f.map();
    const double left = mean_k(m, 0, kW / 2 - SplitMap::kRadius),
                 right = mean_k(m, kW / 2 + SplitMap::kRadius, kW);
    EXPECT_GT(left, 2.5 * right) << left << " " << right;
    EXPECT_NEAR(mean_k(m, 0, kW), 4.0, 1.0);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            const int k = m.at(x, y);
            EXPECT_TRUE(k == 1 || k == 2 || k == 4 || k == 8) << k;
        }
    double total = 0;
    for (const auto& [k, share] : m.shares()) total += share;
    EXPECT_NEAR(total, 1.0, 1e-12);
    EXPECT_GE(m.shares().size(), 2u);
}

TEST(SplitMap, BrighterPixelsWithTheSameNoiseTakeFewer) {
    // Relative noise is what counts: the same absolute noise on a 4x brighter right half.
    const FirstSamples f([](int x, int) { return x < kW / 2 ? 0.25 : 1.0; },
                         [](int, int) { return 0.1; });
    const SplitMap m = f.map();
    EXPECT_GT(mean_k(m, 0, kW / 2 - SplitMap::kRadius),
              2.5 * mean_k(m, kW / 2 + SplitMap::kRadius, kW));
}

TEST(SplitMap, WithoutNoiseEveryPixelKeepsTheUniformSplit) {
    const FirstSamples f([](int, int) { return 0.5; }, [](int, int) { return 0.0; });
    const SplitMap m = f.map(4);
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) EXPECT_EQ(m.at(x, y), 4);
    EXPECT_TRUE(m.shares().empty());
}

TEST(SplitMap, PixelsThatDoNotSplitTakeNoShareOfTheBranches) {
    // The right half is a miss (camera rays only), however noisy its first samples: the
    // splitting left half keeps the mean of 4 for itself.
    FirstSamples f([](int, int) { return 0.5; },
                   [](int x, int) { return x < kW / 2 ? 0.1 : 5.0; });
    for (int y = 0; y < kH; ++y)
        for (int x = kW / 2; x < kW; ++x)
            f.acc.pixels[size_t(y) * kW + size_t(x)].rays = kP0;
    const SplitMap m = f.map();
    EXPECT_NEAR(mean_k(m, 0, kW / 2), 4.0, 1.0);
    double total = 0;
    for (const auto& [k, share] : m.shares()) total += share;
    EXPECT_NEAR(total, 1.0, 1e-12);
}

}  // namespace
