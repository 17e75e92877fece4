#pragma once

#include "renderer/integrator.h"

namespace renderer {

class NormalsIntegrator final : public Integrator {
public:
    NormalsIntegrator(const scenes::Scene& scene, const SceneGeometry& geometry)
        : scene_(scene), geometry_(geometry) {}
    Vec3f li(const accel::Ray& ray, SampleContext& ctx) const override;
    bool display_referred() const override { return true; }

private:
    const scenes::Scene& scene_;
    const SceneGeometry& geometry_;
};

}  // namespace renderer
