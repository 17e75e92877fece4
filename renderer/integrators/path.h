// Path tracing with next-event estimation (light sampling) or uniform hemisphere
// sampling (-H) for the direct part, Russian roulette (on the throughput, or the course's
// fixed probability), and the course's -m/-o semantics.
// `direct` is the same integrator with the depth fixed at 1.
#pragma once

#include <limits>

#include "renderer/integrator.h"
#include "renderer/lights.h"

namespace renderer {

struct Interaction;
namespace bsdf {
class Bsdf;
}

class PathIntegrator final : public Integrator {
public:
    PathIntegrator(const scenes::Scene& scene, const SceneGeometry& geometry, const LightSet& lights,
                   const IntegratorSettings& settings);
    Vec3f li(const accel::Ray& ray, SampleContext& ctx) const override;

    int branches() const override { return s_.max_depth >= 2 ? s_.split : 1; }
    bool splits_by_noise() const override { return s_.split_by_noise; }

private:
    /// What a path vertex does: its direct light, its bounce, and how many bounce samples
    /// the vertex takes in all (the split at the camera hit), which weigh its light
    /// samples against the light its bounce rays find.
    struct VertexParts {
        bool direct = true;
        bool bounce = true;
        float bsdf_count = 1.0f;
        /// The vertex's numbers it reads.
        VertexDraws draws() const {
            return direct && bounce ? VertexDraws::All
                   : direct         ? VertexDraws::Light
                                    : VertexDraws::Bounce;
        }
    };
    /// The path from its first vertex `it` (reached along -wo) on, the first vertex doing
    /// `first`: the light it gathers.
    Vec3f walk(Interaction it, Vec3f wo, VertexParts first, SampleContext& ctx) const;
    /// The camera hit's direct light once and its bounce `split` times, the branches
    /// averaged (IntegratorSettings::split, or the pixel's SampleContext::split).
    Vec3f split_at_camera_hit(const Interaction& it, const Vec3f& wo, int split,
                              SampleContext& ctx) const;
    /// Light arriving at `it` directly from emitters, times the BSDF and cosine.
    /// `bounce`: the vertex's index along the path (1 = first hit), for its dimensions.
    /// mis: weigh each light sample against the diffuse bounce's cosine sampling, which
    /// then adds the light it finds (found_light).
    /// bsdf_count: bounce samples the light sample is weighed against (split).
    Vec3f direct_lights(const Interaction& it, int bounce, const Vec3f& albedo,
                        SampleContext& ctx, bool mis, float bsdf_count) const;
    Vec3f direct_hemisphere(const Interaction& it, int bounce, const Vec3f& albedo, SampleContext& ctx) const;
    /// One vertex on a non-diffuse material: direct light through its BSDF (skipped for
    /// delta lobes), then a BSDF-sampled bounce. Updates it, wo, beta; false ends the
    /// path. eta_scale: the product of eta^2 over the refractions so far (for the
    /// roulette). base_colour: make_bsdf's, where already looked up. part: what the
    /// vertex does (VertexParts).
    bool scatter(const scenes::Material& m, int bounce, Interaction& it, Vec3f& wo,
                 Vec3f& beta, float& eta_scale, Vec3f& L, SampleContext& ctx,
                 const Vec3f* base_colour, VertexParts part) const;
    Vec3f direct_bsdf(const Interaction& it, int bounce, const Vec3f& wo_l,
                      const Vec3f& t, const Vec3f& bt, const bsdf::Bsdf& b,
                      SampleContext& ctx, float bsdf_count) const;
    /// The light that a BSDF-sampled ray from p (shading normal n) in direction wi found:
    /// the emitter `next` it hit, or the environment when next is null, times
    /// weight(light density), the light strategy's density for that direction.
    template <class W>
    Vec3f found_light(const Interaction* next, const accel::Hit& hit, const Vec3f& p, const Vec3f& n,
                      const Vec3f& wi, W&& weight) const;
    /// The throughput roulette at a vertex whose dimensions start at d: the chance to end
    /// into q; true when the path goes on (it then carries beta / (1 - q) once the light
    /// its bounce ray found is added).
    bool roulette(const Vec3f& beta, float eta_scale, uint32_t d, SampleContext& ctx, float& q) const;
    /// Traces the bounce ray from `it` toward wi; true when it hits. `it` becomes the hit's
    /// interaction (moved) where the path goes on or the hit emits: a path that ends needs
    /// only an emitter's light.
    bool trace_bounce(Interaction& it, const Vec3f& wi, bool goes_on, accel::Hit& hit, SampleContext& ctx,
                      bool& moved) const;
    /// Does the surface a ray hit emit (its material; before any interaction is made)?
    bool emissive(const accel::Hit& hit) const;
    /// Is the light sample's shadow ray (segment, or ray for infinitely far lights) blocked?
    bool occluded(const Interaction& it, const LightSample& ls, SampleContext& ctx) const;
    /// Does the light of path length `bounce` (0 = emission seen directly) count? The
    /// bounces [counted_lo_, counted_hi_] that --only and -a leave, set once: counts runs
    /// several times per vertex, where comparing --only's string cost 1 % of a render's
    /// instructions.
    bool counts(int bounce) const { return bounce >= counted_lo_ && bounce <= counted_hi_; }
    int counted_lo_ = 0, counted_hi_ = std::numeric_limits<int>::max();

    const scenes::Scene& scene_;
    const SceneGeometry& geometry_;
    const LightSet& lights_;
    IntegratorSettings s_;
    float scale_;
    /// Do diffuse vertices combine light and bounce sampling by MIS? Under --lights=mesh
    /// with --strategy=mis ("diffuse MIS" in renderer/README.md).
    bool diffuse_mis_ = false;
    /// Does any material use KHR_materials_unlit? Scenes without one skip its tests.
    bool unlit_ = false;
    /// Does any material read a texture? Untextured scenes compute no footprint.
    bool textured_ = false;
    /// The texture footprint of a hit, for textured materials only. `camera`: found by
    /// the camera ray of direction `dir`.
    void footprint(Interaction& it, bool camera, const Vec3f& dir) const;
};

}  // namespace renderer
