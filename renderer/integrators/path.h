// Path tracing with next-event estimation (light sampling) or uniform hemisphere
// sampling (-H) for the direct part, Russian roulette, and the course's -m/-o semantics.
// `direct` is the same integrator with the depth fixed at 1.
#pragma once

#include "renderer/integrator.h"
#include "renderer/lights.h"

namespace renderer {

struct Interaction;

class PathIntegrator final : public Integrator {
public:
    PathIntegrator(const scenes::Scene& scene, const SceneGeometry& geometry, const LightSet& lights,
                   const IntegratorSettings& settings);
    Vec3f li(const accel::Ray& ray, SampleContext& ctx) const override;

private:
    /// Light arriving at `it` directly from emitters, times the BSDF and cosine.
    Vec3f direct(const Interaction& it, const Vec3f& wo, const Vec3f& albedo, SampleContext& ctx) const;
    Vec3f direct_lights(const Interaction& it, const Vec3f& albedo, SampleContext& ctx) const;
    Vec3f direct_hemisphere(const Interaction& it, const Vec3f& albedo, SampleContext& ctx) const;
    /// Does the light of path length `bounce` (0 = emission seen directly) count?
    bool counts(int bounce) const;

    const scenes::Scene& scene_;
    const SceneGeometry& geometry_;
    const LightSet& lights_;
    IntegratorSettings s_;
    float scale_;
};

}  // namespace renderer
