// What the render tests share: a scene with everything needed to render it, kept alive
// together.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "renderer/camera.h"
#include "renderer/image.h"
#include "renderer/integrators/path.h"
#include "renderer/lights.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "scenes/load.h"

namespace renderer {

/// Mean and standard error of an estimator, from independent samples.
struct Estimate {
    double mean = 0, se = 0;
    uint64_t rays = 0;  ///< rays the n samples traced (camera and bounce rays)
    uint64_t shadow_rays = 0;  ///< their shadow rays: one per vertex and light sample
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
    e.rays = st.rays;
    e.shadow_rays = st.shadow_rays;
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

/// The fraction of `rays` shadow rays straight up (+y, t in [1e-4, 10]) from random points
/// of the square |x|, |z| < 0.95 at y = 0 that `acc` finds occluded: how much a masked or
/// blended cover above that floor stops, as a frequency with binomial error.
inline double fraction_blocked_upward(const accel::Accelerator& acc, int rays) {
    accel::TraceStats st;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-0.95f, 0.95f);
    int blocked = 0;
    for (int k = 0; k < rays; ++k) {
        const accel::Ray up{Vec3f(pos(rng), 0.0f, pos(rng)), Vec3f(0, 1, 0), 1e-4f, 10.0f};
        blocked += acc.occluded(up, st);
    }
    return double(blocked) / rays;
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

struct Rendered {
    RenderResult result;
    Camera camera;
};

/// A scene file rendered at w x h, framed as the course frames it at 480x360.
inline Rendered render_file(const std::string& path, const IntegratorSettings& is, int w, int h, int spp,
                            int threads, const std::string& backend = "custom", uint64_t seed = 0,
                            int adaptive_batch = 0, float tol = 0.05f) {
    World s;
    s.scene = scenes::load_scene(path);
    s.build(is, backend);
    // Frame as the course does at 480x360, at a lower resolution.
    CameraOverrides ov;
    ov.hfov_deg = make_camera(s.scene, CameraMode::Auto, 480, 360).camera.hfov_deg();
    Rendered r;
    r.camera = make_camera(s.scene, CameraMode::Auto, w, h, ov).camera;
    RenderSettings rs;
    rs.width = w;
    rs.height = h;
    rs.spp = spp;
    rs.threads = threads;
    rs.seed = seed;
    rs.progress = false;
    rs.adaptive_batch = adaptive_batch;
    rs.adaptive_tol = tol;
    r.result = render(r.camera, *s.integrator, *s.accel, rs);
    return r;
}

/// Region means of illuminance over a G x G grid, with standard errors from the
/// per-pixel variance of the mean.
inline std::vector<Estimate> region_means(const Image& img, int grid) {
    std::vector<Estimate> out(size_t(grid) * grid);
    std::vector<int> count(out.size(), 0);
    for (int y = 0; y < img.height; ++y)
        for (int x = 0; x < img.width; ++x) {
            const float* p = img.at(x, y);
            const size_t k = size_t(y * grid / img.height) * grid + size_t(x * grid / img.width);
            out[k].mean += 0.2126 * p[kR] + 0.7152 * p[kG] + 0.0722 * p[kB];
            out[k].se += p[kVariance];  // sum of variances of pixel means
            ++count[k];
        }
    for (size_t k = 0; k < out.size(); ++k) {
        out[k].mean /= count[k];
        out[k].se = std::sqrt(out[k].se) / count[k];
    }
    return out;
}

/// Region means agree within z standard errors, plus `rel` of the mean where an estimator
/// is known to be heavy-tailed (its sample variance then understates its error).
inline void expect_same_regions(const Image& a, const Image& b, int grid, double z, const std::string& what,
                                double rel = 0.0) {
    auto ra = region_means(a, grid), rb = region_means(b, grid);
    for (size_t k = 0; k < ra.size(); ++k) {
        const double se = std::sqrt(ra[k].se * ra[k].se + rb[k].se * rb[k].se);
        EXPECT_NEAR(ra[k].mean, rb[k].mean, z * se + rel * std::max(ra[k].mean, rb[k].mean) + 1e-6)
            << what << ", region " << k;
    }
}

}  // namespace renderer
