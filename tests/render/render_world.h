// What the render tests share: a scene with everything needed to render it, kept alive
// together.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "renderer/integrators/path.h"
#include "renderer/lights.h"
#include "renderer/scene_geometry.h"

namespace renderer {

/// Mean and standard error of an estimator, from independent samples.
struct Estimate {
    double mean = 0, se = 0;
};

inline Estimate estimate(const Integrator& integ, const accel::Accelerator& acc, const accel::Ray& ray, int n,
                  uint64_t seed, int channel = 1) {
    double s1 = 0, s2 = 0;
    accel::TraceStats st;
    for (int i = 0; i < n; ++i) {
        Rng rng(seed, uint64_t(i));
        SampleContext ctx{acc, st, rng, {}};
        const Vec3f L = integ.li(ray, ctx);
        const double v = L[channel];
        s1 += v;
        s2 += v * v;
    }
    Estimate e;
    e.mean = s1 / n;
    e.se = std::sqrt(std::max(0.0, (s2 / n - e.mean * e.mean) / (n - 1)));
    return e;
}

/// A quad a-b-c-d (counter-clockwise seen from its front) as two triangles.
inline scenes::Mesh quad(Vec3f a, Vec3f b, Vec3f c, Vec3f d, uint32_t material = 0) {
    scenes::Mesh m;
    m.positions = {a, b, c, d};
    m.pad_positions();
    m.indices = {0, 1, 2, 0, 2, 3};
    m.material = material;
    return m;
}

/// Everything a render needs, kept alive together.
struct World {
    scenes::Scene scene;
    std::unique_ptr<SceneGeometry> geometry;
    std::unique_ptr<accel::Accelerator> accel;
    std::unique_ptr<LightSet> lights;
    std::unique_ptr<PathIntegrator> integrator;
    std::vector<std::string> notes;
    LightModel model = LightModel::Mesh;

    void build(const IntegratorSettings& is, const std::string& backend = "custom") {
        geometry = std::make_unique<SceneGeometry>(scene);
        accel = build_accelerator(backend, *geometry, {}, false);
        lights = std::make_unique<LightSet>(scene, model, notes);
        integrator = std::make_unique<PathIntegrator>(scene, *geometry, *lights, is);
    }
};

}  // namespace renderer
