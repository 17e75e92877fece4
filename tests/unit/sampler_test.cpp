// The samplers of renderer/sampler.h: their 2D projections are stratified (Sobol and
// PMJ02 hold exactly one sample in every elementary interval of a power-of-two count),
// their numbers are pure functions of (seed, pixel, sample, dimension), and on a smooth
// analytic integrand their error falls faster than independent sampling's N^-1/2.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "renderer/rng.h"
#include "renderer/sampler.h"
#include "renderer/sampling.h"

using namespace renderer;

namespace {

const SamplerKind kLowDiscrepancy[] = {SamplerKind::Sobol, SamplerKind::ZSobol, SamplerKind::Pmj02};

/// Does every elementary interval 2^-k x 2^-(m-k) (k = 0..m) of [0,1)^2 hold exactly one
/// of the 2^m points? Returns the first shape that fails, or -1.
int first_bad_shape(const std::vector<Vec2f>& pts) {
    int m = 0;
    while ((size_t(1) << m) < pts.size()) ++m;
    for (int k = 0; k <= m; ++k) {
        std::vector<int> count(pts.size(), 0);
        for (const Vec2f& p : pts) {
            const size_t cx = size_t(p.x * float(1 << k)), cy = size_t(p.y * float(1 << (m - k)));
            ++count[cy * (size_t(1) << k) + cx];
        }
        for (int c : count)
            if (c != 1) return k;
    }
    return -1;
}

/// Dimensions handled as 2D: the pixel, the lens, a light point and BSDF directions.
const uint32_t k2dDims[] = {dims::kPixel, dims::kLens, dims::bounce(1) + dims::kLightPoint,
                            dims::bounce(1) + dims::kBsdfDir, dims::bounce(4) + dims::kBsdfDir,
                            dims::bounce(9) + dims::kLightPoint};
const uint32_t k1dDims[] = {dims::bounce(1) + dims::kLightChoice, dims::bounce(2) + dims::kBsdfLobe,
                            dims::bounce(3) + dims::kRoulette};

}  // namespace

TEST(Sampler, SobolAndPmj02FillEveryElementaryInterval) {
    for (SamplerKind kind : kLowDiscrepancy)
        for (uint32_t n : {16u, 64u, 256u}) {
            // ZSobol lays each pixel's samples out for the sample count; the others ignore it.
            const Sampler s(kind, 3, int(n), 64, 48);
            for (const auto& [x, y] : {std::pair{0, 0}, std::pair{17, 5}, std::pair{63, 47}})
                for (uint32_t d : k2dDims) {
                    std::vector<Vec2f> pts;
                    std::vector<float> xs;
                    for (uint32_t i = 0; i < n; ++i) pts.push_back(PixelSample(s, x, y, 64, i).get2d(d));
                    EXPECT_EQ(first_bad_shape(pts), -1)
                        << sampler_name(kind) << " n " << n << " dim " << d << " pixel " << x << "," << y;
                }
        }
}

TEST(Sampler, OneDimensionalDimensionsAreStratified) {
    for (SamplerKind kind : {SamplerKind::Stratified, SamplerKind::Sobol, SamplerKind::ZSobol, SamplerKind::Pmj02})
        for (uint32_t n : {16u, 64u, 256u}) {
            const Sampler s(kind, 5, int(n), 32, 32);
            for (uint32_t d : k1dDims) {
                std::vector<int> count(n, 0);
                for (uint32_t i = 0; i < n; ++i) ++count[size_t(PixelSample(s, 9, 4, 32, i).get1d(d) * float(n))];
                for (uint32_t c = 0; c < n; ++c)
                    ASSERT_EQ(count[c], 1) << sampler_name(kind) << " n " << n << " dim " << d << " stratum " << c;
            }
        }
}

TEST(Sampler, StratifiedFillsEveryStratumOfItsGrid) {
    for (int n : {16, 64, 256, 24}) {
        const Sampler s(SamplerKind::Stratified, 1, n, 8, 8);
        // The most square factorisation: 4x4, 8x8, 16x16, 4x6.
        const int sx = n == 24 ? 4 : int(std::lround(std::sqrt(double(n)))), sy = n / sx;
        for (uint32_t d : k2dDims) {
            std::vector<int> count(size_t(n), 0);
            for (int i = 0; i < n; ++i) {
                const Vec2f p = PixelSample(s, 3, 2, 8, uint32_t(i)).get2d(d);
                ++count[size_t(int(p.y * float(sy)) * sx + int(p.x * float(sx)))];
            }
            for (int c = 0; c < n; ++c) ASSERT_EQ(count[size_t(c)], 1) << "n " << n << " dim " << d;
        }
    }
}

// Every PMJ02 table, at every power-of-two prefix, is a (0,m,2)-net: the property the
// sampler relies on for each dimension.
TEST(Sampler, Pmj02TablesAreProgressiveNets) {
    for (uint64_t t : {0ull, 1ull, 2ull, 3ull}) {
        const std::vector<uint32_t> tab = generate_pmj02(kPmjSamples, 100 + t);
        ASSERT_EQ(tab.size(), 2u * kPmjSamples);
        for (uint32_t n = 1; n <= kPmjSamples; n *= 2) {
            std::vector<Vec2f> pts;
            // Exact: the cell test needs the fixed-point value, not a rounded float.
            for (uint32_t i = 0; i < n; ++i)
                pts.push_back({float(tab[2 * i] >> 8) * 0x1p-24f, float(tab[2 * i + 1] >> 8) * 0x1p-24f});
            EXPECT_EQ(first_bad_shape(pts), -1) << "table " << t << " prefix " << n;
        }
    }
}

// The numbers depend on (seed, pixel, sample, dimension) and on nothing drawn before.
TEST(Sampler, NumbersArePureFunctionsOfTheirCoordinates) {
    for (SamplerKind kind : {SamplerKind::Stratified, SamplerKind::Sobol, SamplerKind::ZSobol, SamplerKind::Pmj02}) {
        const Sampler s(kind, 11, 64, 32, 32);
        const PixelSample a(s, 5, 6, 32, 13);
        const float first = a.get1d(dims::bounce(2) + dims::kRoulette);
        const Vec2f pt = a.get2d(dims::bounce(1) + dims::kBsdfDir);
        // Other draws in between, another PixelSample of the same coordinates.
        for (uint32_t d = 0; d < 200; ++d) (void)a.get1d(d);
        const PixelSample b(s, 5, 6, 32, 13);
        EXPECT_EQ(first, b.get1d(dims::bounce(2) + dims::kRoulette)) << sampler_name(kind);
        EXPECT_EQ(pt, b.get2d(dims::bounce(1) + dims::kBsdfDir)) << sampler_name(kind);
        // Each coordinate matters.
        const Sampler other_seed(kind, 12, 64, 32, 32);
        EXPECT_NE(pt, PixelSample(other_seed, 5, 6, 32, 13).get2d(dims::bounce(1) + dims::kBsdfDir));
        EXPECT_NE(pt, PixelSample(s, 6, 6, 32, 13).get2d(dims::bounce(1) + dims::kBsdfDir));
        EXPECT_NE(pt, PixelSample(s, 5, 6, 32, 14).get2d(dims::bounce(1) + dims::kBsdfDir));
        EXPECT_NE(pt, a.get2d(dims::bounce(2) + dims::kBsdfDir));
        // Beyond the low-discrepancy dimensions: uniform numbers in [0, 1) still.
        const Vec2f deep = a.get2d(dims::kLdDimensions + 3);
        EXPECT_TRUE(deep.x >= 0 && deep.x < 1 && deep.y >= 0 && deep.y < 1);
    }
}

// A split camera sample's branch (PixelSample::other_sample, which carries the pixel's
// hash over) draws what a PixelSample made afresh for it draws, in every dimension kind:
// camera, vertex, past the low-discrepancy ones, and extra light samples; for a sampler
// of the same seed (the branch sampler) and of another.
TEST(Sampler, BranchSamplesAreFreshSamples) {
    for (SamplerKind kind : {SamplerKind::Independent, SamplerKind::Stratified, SamplerKind::Sobol,
                             SamplerKind::ZSobol, SamplerKind::Pmj02}) {
        const Sampler s(kind, 11, 16, 40, 30);
        const Sampler branches = s.with_spp(64, 40, 30), other_seed(kind, 12, 64, 40, 30);
        const PixelSample camera(s, 7, 21, 40, 5);
        for (const Sampler* t : {&branches, &other_seed})
            for (uint32_t j : {0u, 21u, 63u}) {
                const PixelSample a = camera.other_sample(*t, 7, 21, 40, j), b(*t, 7, 21, 40, j);
                for (uint32_t d : {0u, 2u, dims::bounce(1), dims::bounce(3) + dims::kRoulette,
                                   dims::kLdDimensions + 3, dims::extra_light(2, 1)}) {
                    ASSERT_EQ(a.get1d(d), b.get1d(d)) << sampler_name(kind) << " dimension " << d;
                    ASSERT_EQ(a.get2d(d + 1), b.get2d(d + 1)) << sampler_name(kind) << " dimension " << d;
                }
            }
    }
}

// A vertex's numbers drawn at once are the ones drawn one by one, for every vertex of
// the low-discrepancy layout and the first past it, and sample indices with high bits
// set, with sobol's AVX2 lanes and with its scalar stages.
TEST(Sampler, VertexDrawsAreTheSingleDraws) {
    for (SamplerKind kind : {SamplerKind::Stratified, SamplerKind::Sobol,
                             SamplerKind::ZSobol, SamplerKind::Pmj02})
    for (bool avx2 : {true, false}) {
        Sampler s(kind, 7, 16, 40, 30);
        if (__builtin_cpu_supports("avx2")) {
            ASSERT_TRUE(s.avx2_draws()) << "AVX2 draws are the default where the CPU has AVX2";
        }
        s.use_avx2_draws(avx2);
        for (uint32_t sample : {0u, 5u, 15u, 1000u, 0x8000000Fu, 0xFFFFFFFFu}) {
            const PixelSample ps(s, 39, 17, 40, sample);
            // One vertex past the low-discrepancy layout too, whose numbers are hashed.
            for (int b = 1; b <= dims::kLdBounces + 1; ++b) {
                const uint32_t d = dims::bounce(b);
                float v[dims::kPerBounce];
                ps.vertex_draws(d, v);
                const Vec2f light = ps.get2d(d + dims::kLightPoint),
                            dir = ps.get2d(d + dims::kBsdfDir);
                ASSERT_EQ(v[dims::kLightChoice], ps.get1d(d + dims::kLightChoice))
                    << sampler_name(kind);
                ASSERT_EQ(v[dims::kLightPoint], light.x);
                ASSERT_EQ(v[dims::kLightPoint + 1], light.y);
                ASSERT_EQ(v[dims::kBsdfLobe], ps.get1d(d + dims::kBsdfLobe));
                ASSERT_EQ(v[dims::kBsdfDir], dir.x);
                ASSERT_EQ(v[dims::kBsdfDir + 1], dir.y);
                ASSERT_EQ(v[dims::kRoulette], ps.get1d(d + dims::kRoulette));
                // A vertex's light or bounce numbers alone: the same, the rest untouched.
                for (VertexDraws parts : {VertexDraws::Light, VertexDraws::Bounce}) {
                    float w[dims::kPerBounce];
                    std::fill(std::begin(w), std::end(w), -1.0f);
                    ps.vertex_draws(d, w, parts);
                    for (uint32_t k = 0; k < dims::kPerBounce; ++k) {
                        const bool drawn =
                            (k < dims::kBsdfLobe) == (parts == VertexDraws::Light);
                        ASSERT_EQ(w[k], drawn ? v[k] : -1.0f)
                            << sampler_name(kind) << " number " << k;
                    }
                }
            }
        }
    }
}

namespace {

/// Irradiance at the origin (normal +z) from a unit-radiance 1 x 1 square centred above
/// it at height h, facing down: in closed form from the point-to-parallel-rectangle form
/// factor (four corner rectangles), E = sum of (1/2)[X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) +
/// Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2))] with X = Y = 0.5/h.
double square_irradiance(double h) {
    const double X = 0.5 / h, Y = 0.5 / h;
    return 4 * 0.5 * (X / std::sqrt(1 + X * X) * std::atan(Y / std::sqrt(1 + X * X)) +
                      Y / std::sqrt(1 + Y * Y) * std::atan(X / std::sqrt(1 + Y * Y)));
}

/// The light-sampling estimate of it from one uniform point on the square: h^2 / r^4.
double estimate(Vec2f u, double h) {
    const double x = u.x - 0.5, y = u.y - 0.5, r2 = x * x + y * y + h * h;
    return h * h / (r2 * r2);
}

/// The N-sample means of f over the pixels of a w x w image (each its own randomisation),
/// the numbers taken from the light-point dimensions of the first vertex; independent
/// numbers as the renderer draws them.
template <class F>
std::vector<double> pixel_means(SamplerKind kind, uint32_t n, uint64_t seed, int w, F&& f) {
    const Sampler s(kind, seed, int(n), w, w);
    std::vector<double> means;
    for (int y = 0; y < w; ++y)
        for (int x = 0; x < w; ++x) {
            double sum = 0;
            for (uint32_t i = 0; i < n; ++i) {
                Vec2f u;
                if (kind == SamplerKind::Independent) {
                    Rng rng(seed, uint64_t(y * w + x), i);
                    u.x = rng.next_float();
                    u.y = rng.next_float();
                } else {
                    u = PixelSample(s, x, y, w, i).get2d(dims::bounce(1) + dims::kLightPoint);
                }
                sum += f(u);
            }
            means.push_back(sum / n);
        }
    return means;
}

/// RMS error over 256 pixels of the N-sample estimate.
double rms_error(SamplerKind kind, uint32_t n, double h) {
    const double exact = square_irradiance(h);
    double sq = 0;
    const std::vector<double> means = pixel_means(kind, n, 2, 16, [&](Vec2f u) { return estimate(u, h); });
    for (double m : means) sq += (m - exact) * (m - exact);
    return std::sqrt(sq / double(means.size()));
}

/// Least-squares slope of log(error) against log(N).
double slope(SamplerKind kind, double h) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    int k = 0;
    for (uint32_t n : {16u, 64u, 256u, 1024u}) {
        const double lx = std::log(double(n)), ly = std::log(rms_error(kind, n, h));
        sx += lx;
        sy += ly;
        sxx += lx * lx;
        sxy += lx * ly;
        ++k;
    }
    return (k * sxy - sx * sy) / (k * sxx - sx * sx);
}

}  // namespace

TEST(Sampler, ClosedFormIrradianceConverges) {
    const double h = 0.6;
    // The estimator is right (so the errors below are errors, not bias).
    double sum = 0;
    Rng rng(1, 1);
    for (int i = 0; i < 200000; ++i) sum += estimate({rng.next_float(), rng.next_float()}, h);
    EXPECT_NEAR(sum / 200000, square_irradiance(h), 0.01 * square_irradiance(h));

    const double independent = slope(SamplerKind::Independent, h);
    EXPECT_NEAR(independent, -0.5, 0.1) << "independent samples converge as N^-1/2";
    for (SamplerKind kind : kLowDiscrepancy) {
        const double s = slope(kind, h);
        EXPECT_LE(s, -0.75) << sampler_name(kind);
        RecordProperty(sampler_name(kind), std::to_string(s));
    }
    // Stratified: N^-1/2 per stratum count at best, but it still beats independent.
    EXPECT_LT(slope(SamplerKind::Stratified, h), independent - 0.2);
}

// Padded dimensions must be independent of each other: two dimensions read at the same
// sample index from sequences with a shared structure are correlated, and a product of
// functions of both then converges worse than with independent numbers. Here the light
// point and the BSDF direction of a vertex: E[(x_a + y_a)(x_b + y_b)] = 1.
TEST(Sampler, PaddedDimensionsAreDecorrelated) {
    const uint32_t a = dims::bounce(1) + dims::kLightPoint, b = dims::bounce(1) + dims::kBsdfDir;
    auto rms = [&](SamplerKind kind, uint32_t n) {
        const int w = 16;
        const Sampler s(kind, 4, int(n), w, w);
        double sq = 0;
        for (int y = 0; y < w; ++y)
            for (int x = 0; x < w; ++x) {
                double sum = 0;
                for (uint32_t i = 0; i < n; ++i) {
                    Vec2f ua, ub;
                    if (kind == SamplerKind::Independent) {
                        Rng rng(4, uint64_t(y * w + x), i);
                        ua = {rng.next_float(), rng.next_float()};
                        ub = {rng.next_float(), rng.next_float()};
                    } else {
                        const PixelSample ps(s, x, y, w, i);
                        ua = ps.get2d(a);
                        ub = ps.get2d(b);
                    }
                    sum += double(ua.x + ua.y) * double(ub.x + ub.y);
                }
                sq += (sum / n - 1.0) * (sum / n - 1.0);
            }
        return std::sqrt(sq / (w * w));
    };
    for (uint32_t n : {16u, 64u}) {
        const double independent = rms(SamplerKind::Independent, n);
        for (SamplerKind kind : {SamplerKind::Stratified, SamplerKind::Sobol, SamplerKind::ZSobol, SamplerKind::Pmj02})
            EXPECT_LT(rms(kind, n), 0.7 * independent) << sampler_name(kind) << " n " << n;
    }
}

// Light triangles sampled by area take their barycentrics through uniform_triangle
// (renderer/sampling.h). It must be uniform over the triangle, and it must hand a
// stratified set on to the triangle still stratified: a smooth integrand over the
// triangle, estimated with a pixel's sobol points, must converge as those points do on
// the square. The fold that it replaced (reflect u1 + u2 > 1 back through the hypotenuse)
// is uniform too but overlays the folded half of the points on the other half: the
// reference below that this map has to beat.
TEST(Sampler, TriangleMapIsUniformAndKeepsStrata) {
    // Uniformity: 4^4 = 256 sub-triangles (midpoint subdivision), each 1/256 of the area.
    // A point's cell: the sub-triangle of (b1, b2) at level 4 is fixed by the integer parts
    // of 16 b1, 16 b2 and 16 (1 - b1 - b2).
    const auto cell = [](float b1, float b2) {
        const int i = std::min(15, int(16.0f * b1)), j = std::min(15, int(16.0f * b2));
        const bool upper = 16.0f * b1 - float(i) + 16.0f * b2 - float(j) > 1.0f;
        return (i * 16 + j) * 2 + (upper ? 1 : 0);
    };
    std::vector<int> count(512, 0);
    Rng rng(7, 3);
    const int n = 1 << 18;
    for (int k = 0; k < n; ++k) {
        float b1, b2;
        uniform_triangle(rng.next_float(), rng.next_float(), b1, b2);
        ASSERT_TRUE(b1 >= 0 && b2 >= 0 && b1 + b2 <= 1.0f) << b1 << " " << b2;
        ++count[size_t(cell(b1, b2))];
    }
    // Cells (i, j, upper) with i + j + upper > 15 lie outside the triangle: 256 are inside.
    double chi2 = 0;
    int inside = 0;
    for (int i = 0; i < 16; ++i)
        for (int j = 0; j < 16; ++j)
            for (int up = 0; up < 2; ++up) {
                const int c = count[size_t((i * 16 + j) * 2 + up)];
                if (i + j + up > 15) {
                    EXPECT_EQ(c, 0);
                    continue;
                }
                ++inside;
                const double e = double(n) / 256;
                chi2 += (c - e) * (c - e) / e;
            }
    ASSERT_EQ(inside, 256);
    EXPECT_LT(chi2, 255 + 5 * std::sqrt(2.0 * 255)) << "chi-square, 255 degrees of freedom";

    // Strata: the mean over 64 pixels of |error| of the integral of exp(b1 + 2 b2) over
    // the triangle (exact: 2 * (e^2/2 - e + 1/2)), 256 sobol points each.
    const double exact = 2.0 * (std::exp(2.0) / 2.0 - std::exp(1.0) + 0.5);
    const auto error = [&](SamplerKind kind, bool fold) {
        const std::vector<double> means = pixel_means(kind, 256, 11, 8, [&](Vec2f u) {
            float b1 = u.x, b2 = u.y;
            if (!fold)
                uniform_triangle(u.x, u.y, b1, b2);
            else if (b1 + b2 > 1.0f)
                b1 = 1.0f - b1, b2 = 1.0f - b2;
            return std::exp(double(b1) + 2.0 * double(b2));
        });
        double sum_err = 0;
        for (double m : means) sum_err += std::abs(m - exact);
        return sum_err / double(means.size());
    };
    const double independent = error(SamplerKind::Independent, false);
    const double sobol = error(SamplerKind::Sobol, false), sobol_fold = error(SamplerKind::Sobol, true);
    RecordProperty("independent", std::to_string(independent));
    RecordProperty("sobol", std::to_string(sobol));
    RecordProperty("sobol_fold", std::to_string(sobol_fold));
    // N^-3/4 against N^-1/2 at N = 256 is a factor of 4.
    EXPECT_LT(sobol, 0.25 * independent);
    EXPECT_LT(sobol, 0.5 * sobol_fold);
}
