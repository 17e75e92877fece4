// What the render tests share: a scene with everything needed to render it, kept alive
// together.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "renderer/integrators/path.h"
#include "renderer/lights.h"
#include "renderer/scene_geometry.h"

namespace renderer {

/// Everything a render needs, kept alive together.
struct World {
    scenes::Scene scene;
    std::unique_ptr<SceneGeometry> geometry;
    std::unique_ptr<accel::Accelerator> accel;
    std::unique_ptr<LightSet> lights;
    std::unique_ptr<PathIntegrator> integrator;
    std::vector<std::string> notes;

    void build(const IntegratorSettings& is, const std::string& backend = "custom") {
        geometry = std::make_unique<SceneGeometry>(scene);
        accel = build_accelerator(backend, *geometry, {}, false);
        lights = std::make_unique<LightSet>(scene, notes);
        integrator = std::make_unique<PathIntegrator>(scene, *geometry, *lights, is);
    }
};

}  // namespace renderer
