// The integrator interface. Integrators see the scene, the shading bridge and an
// Accelerator; never which backend it is.
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "accel/accelerator.h"
#include "renderer/rng.h"
#include "renderer/sampler.h"
#include "renderer/scene_geometry.h"
#include "renderer/spawn.h"
#include "renderer/texture.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec3f;

/// First-hit facts a sample reports for the AOV channels.
struct AovSample {
    Vec3f normal;   ///< shading normal at the first hit (0 on a miss)
    Vec3f albedo;   ///< diffuse albedo at the first hit
    float depth = 0.0f;  ///< distance to the first hit (0 on a miss)
};

/// What one camera sample may use: the per-thread statistics and its random numbers,
/// drawn by dimension (the layout is in renderer/sampler.h, dims).
struct SampleContext {
    /// Members beyond these keep their own initialisers; vertex_ is left unset (nothing
    /// reads it before draw_vertex fills it): an aggregate's value-initialisation zeroed
    /// the whole context, branch sampler included, at every camera sample.
    SampleContext(const accel::Accelerator& a, accel::TraceStats& s, Rng& r,
                  AovSample first = {}, const PixelSample* ld = nullptr)
        : accel(a), stats(s), rng(r), aov(first), sampler(ld) {}
    const accel::Accelerator& accel;
    accel::TraceStats& stats;
    Rng& rng;
    AovSample aov;
    /// The sample's low-discrepancy numbers; null for the independent sampler, whose
    /// every dimension is the next number of rng, in call order.
    const PixelSample* sampler = nullptr;

    /// Draws the numbers of path vertex `bounce` (its kPerBounce dimensions) at once, for
    /// the low-discrepancy samplers: the independent hash chains then overlap in the CPU,
    /// where drawing each as the integrator reaches it waits on one chain at a time ("a
    /// vertex's draws at once" in renderer/README.md). The values are the same either way.
    /// `parts`: only the light or only the bounce numbers, where the vertex uses no other
    /// (a split camera hit: its light sample once, its bounces in the branches); a number
    /// not drawn is computed when read, so the values never depend on it.
    void draw_vertex(int bounce, VertexDraws parts = VertexDraws::All) {
        const uint32_t base = dims::bounce(bounce);
        if (!sampler || base + dims::kPerBounce > dims::kLdDimensions) return;
        sampler->vertex_draws(base, vertex_, parts);
        vertex_base_ = base;
        vertex_lo_ = base + (parts == VertexDraws::Bounce ? dims::kBsdfLobe : 0);
        vertex_n_ = parts == VertexDraws::All     ? dims::kPerBounce
                    : parts == VertexDraws::Light ? dims::kBsdfLobe
                                                  : dims::kPerBounce - dims::kBsdfLobe;
    }
    float get1d(uint32_t dim) {
        if (dim - vertex_lo_ < vertex_n_) return vertex_[dim - vertex_base_];
        return sampler ? sampler->get1d(dim) : rng.next_float();
    }
    Vec2f get2d(uint32_t dim) {
        if (dim - vertex_lo_ < vertex_n_)
            return {vertex_[dim - vertex_base_], vertex_[dim - vertex_base_ + 1]};
        if (sampler) return sampler->get2d(dim);
        const float u0 = rng.next_float();
        return {u0, rng.next_float()};
    }

    /// Bounce splitting (IntegratorSettings::split): branch j of a camera sample draws
    /// its numbers from the camera hit's bounce on as sample branch_base + j of the
    /// branch sampler, the render's sampler laid out for all of a pixel's branches, so
    /// that they form one stratified set ("bounce splitting" in renderer/README.md).
    /// Null for the independent sampler, whose stream just goes on.
    const Sampler* branch_sampler = nullptr;
    /// This sample's branches per camera hit (the render's SplitMap, "split by noise" in
    /// renderer/README.md); 0: the integrator's IntegratorSettings::split.
    int split = 0;
    int x = 0, y = 0, width = 0;
    /// The branch sampler's index of this sample's first branch: i * K for sample i of a
    /// uniform split K; under a split map (renderer/split_map.h), p0 * K plus (i - p0)
    /// times the pixel's own count for the samples after the map's first p0, so that a
    /// pixel's branches are always one prefix of the branch sampler's sequence.
    uint32_t branch_base = 0;
    void begin_branch(uint32_t j) {
        vertex_n_ = 0;
        if (!branch_sampler) return;
        // The camera sample's hash of its pixel carries over (PixelSample::other_sample).
        const PixelSample next = sampler->other_sample(*branch_sampler, x, y, width, branch_base + j);
        branch_.emplace(next);
        sampler = &*branch_;
    }
    std::optional<PixelSample> branch_{};

    /// draw_vertex's numbers, their first dimension, and the dimensions it drew:
    /// vertex_n_ of them from vertex_lo_ on (none before the first draw).
    float vertex_[dims::kPerBounce];
    uint32_t vertex_base_ = 0, vertex_lo_ = 0, vertex_n_ = 0;
};

struct IntegratorSettings {
    std::string name = "path";  ///< normals | direct | path
    int light_samples = 1;      ///< -l: samples per area light
    int max_depth = 5;          ///< -m
    bool accumulate = true;     ///< -o 1 (accumulate bounces) / -o 0 (exactly -m bounces)
    bool hemisphere = false;    ///< -H: uniform hemisphere sampling for direct light
    /// --rr: Russian roulette from the second bounce. kThroughputRoulette (the default):
    /// terminate with q = max(0, 1 - max component of beta * eta_scale), where eta_scale
    /// undoes the 1/eta^2 radiance scaling of refractions (pbrt-v4 PathIntegrator), so a
    /// path through mirror or glass keeps going while a dim one stops early. A value in
    /// (0, 1]: the course's fixed continuation probability (0.65 in CS184; 1 = no roulette).
    /// kSqrtThroughputRoulette: Cycles' gentler rule, continue with probability
    /// min(1, sqrt(max component of beta * eta_scale)) (path_state_continuation_probability).
    static constexpr float kThroughputRoulette = -1.0f;
    static constexpr float kSqrtThroughputRoulette = -2.0f;
    float rr_continue = kThroughputRoulette;
    bool throughput_roulette() const { return rr_continue < 0.0f; }
    bool sqrt_roulette() const { return rr_continue == kSqrtThroughputRoulette; }
    std::string only;           ///< --only=direct|indirect ("" = both)
    /// --split: bounce rays per camera hit. The camera hit's direct light is estimated
    /// once and its bounce sampled `split` times, each branch a path of its own (Arvo and
    /// Kirk 1990, splitting): indirect light, most of a diffuse image's noise, gets split
    /// times the samples without as many camera rays.
    int split = 4;
    /// --split-by: noise (default) sizes each pixel's split in proportion to its relative
    /// noise in its first samples, split on average (renderer/split_map.h); uniform gives
    /// every pixel split.
    bool split_by_noise = true;
    /// --offset: how secondary rays leave surfaces (renderer/spawn.h). ErrorBound offsets
    /// by the hit point's floating-point error bound (pbrt-v4 6.8); Epsilon is the plain
    /// scale-relative epsilon, kept for comparison.
    OffsetMode offset = OffsetMode::ErrorBound;
    /// --strategy: direct light by multiple importance sampling of lights and the BSDF
    /// (default; at diffuse surfaces only under --lights=mesh, against the bounce's own
    /// cosine sample), lights only, or BSDF sampling only at non-diffuse surfaces, where
    /// diffuse ones keep light sampling (or -H).
    enum class Strategy : uint8_t { Mis, Light, Bsdf } strategy = Strategy::Mis;
    /// --texture-filter: how textures are read (renderer/texture.h).
    TextureFilter texture_filter = TextureFilter::Trilinear;
    /// The camera's per-pixel spread for texture footprints: Camera::pixel_spread(width,
    /// height, spp) of the camera that renders. Left unset, trilinear reads the full image
    /// (a point footprint), as bilinear does.
    PixelSpread pixel_spread;
};

class Integrator {
public:
    virtual ~Integrator() = default;
    /// Radiance arriving along the camera ray (scene-linear RGB).
    virtual Vec3f li(const accel::Ray& ray, SampleContext& ctx) const = 0;
    /// True when li's values are display colours (normal shading), not radiance.
    virtual bool display_referred() const { return false; }
    /// Branches per camera sample (IntegratorSettings::split): the render draws their
    /// numbers from a sampler of this many times its sample count.
    virtual int branches() const { return 1; }
    /// Does the render size each pixel's branches by its first samples' noise
    /// (renderer/split_map.h)? Only where branches() > 1.
    virtual bool splits_by_noise() const { return false; }
};

/// Throws std::invalid_argument naming the integrator when it is unknown or unavailable.
class LightSet;
std::unique_ptr<Integrator> make_integrator(const IntegratorSettings& settings,
                                            const scenes::Scene& scene,
                                            const SceneGeometry& geometry,
                                            const LightSet* lights);

}  // namespace renderer
