// Bounce splitting sized per pixel: how many branches the camera hits of each pixel send,
// from the render's own first samples ("split by noise" in renderer/README.md).
//
// A pixel's squared relative error is sigma^2 / (K mean^2) for K branches per camera hit,
// at a cost that grows as K. For a fixed number of branches, the image's summed squared
// relative error is smallest when each pixel's K is proportional to sigma / mean (the
// Lagrange condition; Vorba and Křivánek 2016, "Adjoint-driven Russian roulette and
// splitting", and Rath et al. 2022, "EARS", size splitting the same way per vertex). The
// first samples of every pixel take the uniform split, in two halves: the difference of
// the halves' means measures the noise of a mean of stratified samples (a pixel's edge,
// its light samples and its branches are stratified across its samples, so one sample's
// variance would overstate them). Pooled over a window, it gives the later samples K in
// proportion to the relative noise, as many branches in all as the uniform split sends.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "renderer/render.h"

namespace renderer {

class SplitMap {
public:
    /// Half-width, in pixels, of the window over which the first samples are pooled.
    static constexpr int kRadius = 5;
    /// Renders of fewer samples per pixel keep the uniform split.
    static constexpr int kMinSpp = 8;

    /// `k` branches everywhere.
    explicit SplitMap(int k = 1) : uniform_(k) {}

    /// How many of a pixel's first samples take the uniform split and size the map, for
    /// a render of `spp` samples per pixel: spp / 8, from 4 to 8; 0 (no map) below
    /// kMinSpp.
    static int first_samples(int spp);

    /// From the per-pixel sums of the first p0 samples over `cell` of `acc`, and
    /// `half_sums`, the RGB sums of their first p0 / 2 (3 a pixel, row-major over the
    /// cell): per channel, d the difference of the two halves' means, each pixel's K
    /// proportional to the root mean square over channels of sqrt(pooled d^2) / (pooled
    /// mean + floor), the floor 3 % of the cell's mean luminance (so that black pixels do
    /// not take every branch), rounded to a power of two in [1, max_k] and scaled so that
    /// the pixels whose camera hits split (their samples traced more than camera rays)
    /// send mean_k branches on average, as near as the powers of two allow. mean_k
    /// everywhere when no pixel shows noise.
    static SplitMap from_sums(const Accumulation& acc,
                              const std::vector<double>& half_sums, const Cell& cell,
                              int p0, int mean_k, int max_k);

    int at(int x, int y) const {
        if (k_.empty()) return uniform_;
        return k_[size_t(y - cell_.y) * size_t(cell_.w) + size_t(x - cell_.x)];
    }
    /// Each branch count's share of the pixels whose camera hits split, ascending by
    /// count; empty for a uniform map.
    const std::vector<std::pair<int, double>>& shares() const { return shares_; }

private:
    int uniform_ = 1;
    Cell cell_{};
    std::vector<uint8_t> k_;
    std::vector<std::pair<int, double>> shares_;
};

}  // namespace renderer
