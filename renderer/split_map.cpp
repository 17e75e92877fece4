#include "renderer/split_map.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace renderer {

namespace {

/// Box filter of a w x h grid (radius r, clamped at the edges), one axis at a time, in
/// double, in a fixed order.
std::vector<double> box(const std::vector<double>& in, int w, int h, int r) {
    // Along x (step 1, n = w) for every row, then along y (step w, n = h) for every column.
    auto pass = [r](const std::vector<double>& src, int lines, size_t line_step, int n, size_t step) {
        std::vector<double> out(src.size());
        for (int l = 0; l < lines; ++l)
            for (int i = 0; i < n; ++i) {
                const int i0 = std::max(0, i - r), i1 = std::min(n - 1, i + r);
                double s = 0;
                for (int j = i0; j <= i1; ++j) s += src[size_t(l) * line_step + size_t(j) * step];
                out[size_t(l) * line_step + size_t(i) * step] = s / double(i1 - i0 + 1);
            }
        return out;
    };
    return pass(pass(in, h, size_t(w), w, 1), w, 1, h, size_t(w));
}

/// 2^round(log2 k) for k > sqrt(2), at most 2^7 and max_k; 1 below (and for NaN). The
/// bisection below asks it of every pixel that splits, 66 times, so k is compared with
/// the half powers 2^(e + 1/2) (sqrt(2) scaled by powers of two, exactly) instead of
/// taking log2 k and rounding: the same exponent except where log2's rounding meets a
/// half power ("the split map's rounding" in renderer/README.md).
int pow2_near(double k, int max_k) {
    constexpr double kSqrt2 = 1.4142135623730951;
    int e = 0;
    for (double half_power = kSqrt2; e < 7 && k > half_power; half_power *= 2) ++e;
    return std::min(1 << e, max_k);
}

}  // namespace

int SplitMap::first_samples(int spp) {
    if (spp < kMinSpp) return 0;
    return std::clamp(spp / 8, 4, 8);
}

SplitMap SplitMap::from_sums(const Accumulation& acc,
                             const std::vector<double>& half_sums, const Cell& cell,
                             int p0, int mean_k, int max_k) {
    SplitMap m(mean_k);
    max_k = std::clamp(max_k, 1, 128);
    const size_t n = size_t(std::max(0, cell.w)) * size_t(std::max(0, cell.h));
    if (mean_k <= 1 || n == 0 || p0 < 2 || half_sums.size() != 3 * n) return m;
    const int h1 = p0 / 2, h2 = p0 - h1;
    std::vector<double> mean[3], var[3];
    for (int c = 0; c < 3; ++c) mean[c].assign(n, 0.0), var[c].assign(n, 0.0);
    std::vector<bool> splits(n);
    double cell_mean = 0;
    for (int y = 0; y < cell.h; ++y)
        for (int x = 0; x < cell.w; ++x) {
            const PixelSums& q =
                acc.pixels[size_t(cell.y + y) * size_t(acc.width) + size_t(cell.x + x)];
            const size_t i = size_t(y) * size_t(cell.w) + size_t(x);
            // A pixel whose samples traced only camera rays (a miss, an emitter) never
            // splits.
            splits[i] = q.rays + q.shadow_rays > q.taken;
            if (q.n == 0) continue;
            for (int c = 0; c < 3; ++c) {
                mean[c][i] = std::max(0.0, q.rgb[c] / double(q.n));
                const double d = half_sums[3 * i + size_t(c)] / h1 -
                                 (q.rgb[c] - half_sums[3 * i + size_t(c)]) / h2;
                var[c][i] = std::isfinite(d) ? d * d : 0.0;
            }
            cell_mean += std::max(0.0, q.s1 / double(q.n));
        }
    std::vector<double> pm[3], pv[3];
    for (int c = 0; c < 3; ++c)
        pm[c] = box(mean[c], cell.w, cell.h, kRadius),
        pv[c] = box(var[c], cell.w, cell.h, kRadius);
    cell_mean /= double(n);
    const double floor = 0.03 * cell_mean;
    std::vector<double> w(n, 0.0);
    double wmin = std::numeric_limits<double>::infinity(), wmax = 0;
    size_t count = 0;
    for (size_t i = 0; i < n; ++i) {
        if (!splits[i]) continue;
        ++count;
        double r2 = 0;
        for (int c = 0; c < 3; ++c)
            r2 += pv[c][i] / ((pm[c][i] + floor) * (pm[c][i] + floor));
        w[i] = std::sqrt(r2 / 3);
        if (!std::isfinite(w[i])) w[i] = 0;
        if (w[i] > 0) wmin = std::min(wmin, w[i]), wmax = std::max(wmax, w[i]);
    }
    if (!(wmax > 0)) return m;
    const double budget = double(count) * double(mean_k);
    std::vector<double> split_w;
    split_w.reserve(count);
    for (size_t i = 0; i < n; ++i)
        if (splits[i]) split_w.push_back(w[i]);
    auto spent = [&](double scale) {
        double s = 0;
        for (const double wi : split_w) s += pow2_near(scale * wi, max_k);
        return s;
    };
    // The scale whose rounded counts spend the budget most nearly: bisection on a log
    // scale (what is spent grows with the scale), a fixed number of steps.
    double lo = std::log(0.5 / wmax), hi = std::log(2.0 * max_k / wmin);
    for (int it = 0; it < 64; ++it) {
        const double mid = 0.5 * (lo + hi);
        (spent(std::exp(mid)) < budget ? lo : hi) = mid;
    }
    const double scale =
        std::abs(spent(std::exp(lo)) - budget) <= std::abs(spent(std::exp(hi)) - budget)
            ? std::exp(lo)
            : std::exp(hi);
    m.cell_ = cell;
    m.k_.resize(n);
    size_t per_count[129] = {};
    for (size_t i = 0; i < n; ++i) {
        m.k_[i] = uint8_t(splits[i] ? pow2_near(scale * w[i], max_k) : mean_k);
        if (splits[i]) ++per_count[m.k_[i]];
    }
    for (int k = 1; k <= 128; ++k)
        if (per_count[k]) m.shares_.emplace_back(k, double(per_count[k]) / double(count));
    return m;
}

}  // namespace renderer
