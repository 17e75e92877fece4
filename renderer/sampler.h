// Where a camera sample's random numbers come from (--sampler). Every number is a pure
// function of (seed, pixel, sample index, dimension), so an image is bit-identical for any
// split of the work (threads, tiles, passes, MPI ranks, a resumed checkpoint), as with the
// per-sample streams of renderer/rng.h.
//
//  - independent: the sample's own PCG32 stream (renderer/rng.h), drawn in call order, as
//    the renderer always drew them (the dimension index is then only a label).
//  - stratified: jittered strata per dimension, their order permuted per pixel and
//    dimension (pbrt-v4 StratifiedSampler). Needs the sample count up front.
//  - sobol: Owen-scrambled Sobol points, padded: each 1D or 2D dimension takes the first
//    one or two Sobol dimensions (a (0,2)-sequence) with its sample index shuffled and its
//    values scrambled by hashes of (seed, pixel, dimension) (Burley 2020, "Practical
//    Hash-based Owen Scrambling", JCGT 9(4)).
//  - zsobol: the same points indexed along a Morton curve over the pixels, with the base-4
//    digits of the index permuted per dimension, so the error of neighbouring pixels is
//    blue noise (Ahmed and Wonka 2020, "Screen-Space Blue-Noise Diffusion of Monte Carlo
//    Sampling Error via Hierarchical Ordering of Pixels"; pbrt-v4 ZSobolSampler).
//  - pmj02: progressive multi-jittered (0,2) points (Christensen, Kensler and Kilpatrick
//    2018, "Progressive Multi-Jittered Sample Sequences"), generated at start-up into
//    tables as Cycles does, one table per dimension, read in a random order per pixel
//    and dimension within the sample count (pbrt-v4's padding) and Owen-scrambled per
//    pixel and dimension (Cycles shifts them by Cranley-Patterson rotation instead,
//    which breaks the elementary intervals that Owen scrambling keeps). Needs the sample
//    count up front.
//
// The low-discrepancy samplers give each dimension below kLdDimensions its own stratified
// sequence; beyond it they fall back to independent hashing of (seed, pixel, sample, dim),
// as pbrt-v4 and Cycles do for deep bounces.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "accel/math.h"
#include "renderer/rng.h"

namespace renderer {

using accel::Vec2f;

enum class SamplerKind : uint8_t { Independent, Stratified, Sobol, ZSobol, Pmj02 };

/// "independent" | "stratified" | "sobol" | "zsobol" | "pmj02"; throws
/// std::invalid_argument otherwise.
SamplerKind parse_sampler(const std::string& name);
const char* sampler_name(SamplerKind kind);

/// The dimension layout of a camera sample: the one place it is written down. 2D entries
/// take two consecutive dimensions, drawn together as one 2D point. Under bounce
/// splitting (IntegratorSettings::split = K), the pixel, lens and camera-hit light
/// dimensions are sample i's, and branch j reads the camera hit's lobe, direction and
/// roulette and every later vertex as sample i * K + j of the same layout, from a sampler
/// of K times the sample count (SampleContext::begin_branch); under a split map, from
/// the pixel's first p0 samples on at its own count (SampleContext::branch_base).
namespace dims {
inline constexpr uint32_t kPixel = 0;  ///< 2D: position inside the pixel
inline constexpr uint32_t kLens = 2;   ///< 2D: point on the thin lens
/// Per path vertex (bounce b = 1, 2, ...): bounce(b) + one of these.
/// 1D: which placement of an instanced emissive mesh (a mesh's triangle is picked with
/// the first number of kLightPoint, LightSet::sample)
inline constexpr uint32_t kLightChoice = 0;
inline constexpr uint32_t kLightPoint = 1;   ///< 2D: the point on the light (or -H's direction)
inline constexpr uint32_t kBsdfLobe = 3;     ///< 1D: which lobe of a BSDF
inline constexpr uint32_t kBsdfDir = 4;      ///< 2D: the BSDF's (or diffuse bounce's) direction
inline constexpr uint32_t kRoulette = 6;     ///< 1D: Russian roulette
inline constexpr uint32_t kPerBounce = 7;
inline constexpr uint32_t kFirstBounce = 4;
/// Vertices whose dimensions are low-discrepancy; deeper ones are hashed independently.
inline constexpr int kLdBounces = 16;
inline constexpr uint32_t kLdDimensions = kFirstBounce + kPerBounce * kLdBounces;
constexpr uint32_t bounce(int b) { return kFirstBounce + kPerBounce * uint32_t(b - 1); }
/// The k-th further light sample of a vertex (k >= 1: a second light, or -l > 1): not in
/// the low-discrepancy layout, hashed independently.
constexpr uint32_t extra_light(int b, uint32_t k) { return 0x40000000u + (uint32_t(b) << 20) + 4u * k; }
}  // namespace dims

/// A render's sampler: its kind and what it precomputes (tables, digit counts), shared
/// read-only by every thread.
class Sampler {
public:
    /// spp: the render's samples per pixel (stratified and zsobol lay out their strata and
    /// indices for it); width, height: the image, for zsobol's Morton indices.
    Sampler(SamplerKind kind, uint64_t seed, int spp, int width, int height);
    SamplerKind kind() const { return kind_; }
    uint64_t seed() const { return seed_; }
    /// The same sampler (seed, tables) laid out for another sample count: bounce
    /// splitting's branch sampler (IntegratorSettings::split).
    Sampler with_spp(int spp, int width, int height) const;
    /// Whether sobol's PixelSample::vertex_draws computes its seven numbers in the lanes
    /// of one AVX2 register (on by default where the CPU has AVX2) or one by one; the
    /// numbers are the same bits either way. For tests and A/B measurements.
    void use_avx2_draws(bool on);
    bool avx2_draws() const { return avx2_; }

private:
    void lay_out(int spp, int width, int height);
    friend class PixelSample;
    SamplerKind kind_;
    uint64_t seed_;
    uint32_t spp_ = 1;
    bool avx2_ = false;
    int strata_x_ = 1, strata_y_ = 1;  // stratified: spp = strata_x * strata_y
    int log2_spp_ = 0, base4_digits_ = 0;  // zsobol
    /// pmj02: kPmjTables tables of kPmjSamples points, 32-bit fixed point (x, y) pairs.
    std::vector<uint32_t> pmj_;
    /// Per low-discrepancy dimension, the parts of its hashes that depend on the dimension
    /// (and seed) alone, made once per render instead of at every draw: the innermost
    /// step of PixelSample::key, and zsobol's scramble seed.
    std::vector<uint64_t> dim_hash_, zsobol_scramble_;
};

inline constexpr uint32_t kPmjSamples = 1024;
inline constexpr uint32_t kPmjTables = 64;

/// Generates n (a power of two) pmj02 points as 32-bit fixed point, x then y per point,
/// from the stream `seed`. Every prefix of power-of-two length is a (0,m,2)-net.
std::vector<uint32_t> generate_pmj02(uint32_t n, uint64_t seed);

/// Which of a path vertex's numbers PixelSample::vertex_draws computes: all, the light
/// sample's (choice and point), or the bounce's (lobe, direction, roulette).
enum class VertexDraws : uint8_t { All, Light, Bounce };

/// The numbers of one camera sample. Cheap to make (a few hashes); no virtual calls: one
/// switch on the kind per draw.
class PixelSample {
public:
    PixelSample(const Sampler& sampler, int x, int y, int width, uint32_t sample);
    /// Sample `sample` of `sampler` for the same pixel (x, y), reusing this one's hash of
    /// (seed, pixel) where the seeds agree: the branches of a split camera sample.
    PixelSample other_sample(const Sampler& sampler, int x, int y, int width, uint32_t sample) const;
    float get1d(uint32_t dim) const;
    Vec2f get2d(uint32_t dim) const;
    /// The kPerBounce numbers of the path vertex whose dimensions start at `base` (below
    /// kLdDimensions), as get1d and get2d would give them, into out[0 .. kPerBounce);
    /// `parts`: only its light numbers (out[kLightChoice .. kBsdfLobe)) or only its
    /// bounce numbers (out[kBsdfLobe .. kPerBounce)), the others left as they were.
    void vertex_draws(uint32_t base, float* out,
                      VertexDraws parts = VertexDraws::All) const;

private:
    template <bool kLight, bool kBounce>
    void vertex_draws(uint32_t base, float* out) const;
    template <bool kLight, bool kBounce>
    void vertex_draws_avx2(uint32_t base, float* out) const;
    const Sampler* s_;
    uint64_t pixel_key_;  // hash of (seed, pixel), pixel = y * width + x: key()'s per-sample part
    uint64_t morton_;    // zsobol: Morton code of (x, y), shifted above the sample bits
    uint32_t sample_;
    // sample_'s bits reversed, where sobol's index shuffle starts
    uint32_t reversed_sample_;
    PixelSample(const Sampler& sampler, int x, int y, uint32_t sample, uint64_t pixel_key);
    /// The samplers that hash every draw, for which sample_hash_ is made up front.
    bool hashes_every_draw() const {
        return s_->kind_ == SamplerKind::Independent || s_->kind_ == SamplerKind::Stratified;
    }
    uint64_t sample_hash_[2];  // the sample's part of `hashed`, for its two coordinates
    uint64_t key(uint32_t dim) const;
    /// The one key of the path vertex whose dimensions start at `base` (sobol_seeds).
    uint64_t vertex_key(uint32_t base) const;
    /// A sobol draw's seeds: its index shuffle's, and its first and second coordinate's
    /// Owen scrambles.
    void sobol_seeds(uint32_t dim, uint32_t seeds[3]) const;
    float hashed(uint32_t dim, uint32_t which) const;
    static const uint32_t* pmj_point(const Sampler& s, uint32_t dim, uint32_t sample, uint64_t key);
};

}  // namespace renderer
