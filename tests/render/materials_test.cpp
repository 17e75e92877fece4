// Environment light, materials in the path integrator, and the course camera file:
// analytic references with statistical tolerances (no golden pixels, no timings).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "renderer/backend_spec.h"
#include "renderer/camera.h"
#include "renderer/envmap.h"
#include "renderer/image.h"
#include "renderer/integrators/path.h"
#include "renderer/lights.h"
#include "renderer/scene_geometry.h"
#include "renderer/sampling.h"
#include "tests/render/render_world.h"

using accel::Vec3f;
using namespace renderer;

namespace {

/// The integrator's estimate along `r` over n samples.
Estimate li(const World& w, const accel::Ray& r, int n) { return estimate(*w.integrator, *w.accel, r, n, 17); }

scenes::Texture constant_image(uint32_t w, uint32_t h, float v) {
    return scenes::Texture::from_rgb("constant", w, h, std::vector<float>(size_t(w) * h * 3, v));
}

/// A dim sky with a small bright sun (a 2x2-texel disc ~1.4 deg across at 256x128).
scenes::Texture sun_image() {
    scenes::Texture t = constant_image(256, 128, 0.2f);
    for (uint32_t y = 30; y < 32; ++y)
        for (uint32_t x = 80; x < 82; ++x)
            for (int c = 0; c < 3; ++c) {
                const float sun = 50000.0f;
                std::memcpy(&t.data[((size_t(y) * 256 + x) * 3 + size_t(c)) * 4], &sun, 4);
            }
    return t;
}

accel::Ray ray(const Vec3f& o, const Vec3f& d) {
    accel::Ray r;
    r.org = o;
    r.dir = accel::normalize(d);
    return r;
}

World env_world(const scenes::Texture& image, uint32_t material_kind_setup(scenes::Material&)) {
    World w;
    w.scene.up = Vec3f(0, 0, 1);
    scenes::Material m;
    material_kind_setup(m);
    w.scene.materials.push_back(m);
    w.scene.spheres.push_back({Vec3f(0.0f), 1.0f, 0});
    w.scene.textures.push_back(image);
    scenes::Light env;
    env.type = scenes::LightType::Environment;
    env.texture = 0;
    w.scene.lights.push_back(env);
    return w;
}

}  // namespace

TEST(Environment, ConstantMapOnDiffuseConvexObjectReadsAlbedoTimesE) {
    // Direct light only: a convex diffuse object under uniform radiance E reflects
    // albedo x E toward every direction.
    const float E = 2.5f;
    World w = env_world(constant_image(64, 32, E), [](scenes::Material& m) {
        m.albedo = Vec3f(0.5f);
        return 0u;
    });
    IntegratorSettings is;
    is.max_depth = 1;
    w.build(is);
    for (const Vec3f& d : {Vec3f(0, -1, 0), Vec3f(0.3f, -1, 0.5f), Vec3f(0, 0.2f, -1)}) {
        const Estimate e = li(w, ray(-d * 5.0f, d), 4000);
        EXPECT_NEAR(e.mean, 0.5 * E, 4 * e.se + 1e-3) << "view " << d.x << " " << d.y << " " << d.z;
    }
    // A camera ray that misses sees the map itself.
    EXPECT_NEAR(li(w, ray(Vec3f(0, -5, 0), Vec3f(0, -1, 0)), 4).mean, E, 1e-5);
}

TEST(Environment, PdfMatchesSamplesAndIntegratesToOne) {
    const scenes::Texture sun = sun_image();
    const EnvironmentMap map(sun, Vec3f(0, 0, 1));
    // Midpoint rule over (theta, phi), 4x4 points per texel: d omega = sin theta dtheta dphi.
    double integral = 0;
    const int nt = 128 * 4, np = 256 * 4;
    for (int i = 0; i < nt; ++i)
        for (int j = 0; j < np; ++j) {
            const double t = (i + 0.5) * accel::kPi / nt, p = (j + 0.5) * 2 * accel::kPi / np;
            const Vec3f d{float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)), float(std::cos(t))};
            integral += map.pdf(d) * std::sin(t) * (accel::kPi / nt) * (2 * accel::kPi / np);
        }
    EXPECT_NEAR(integral, 1.0, 1e-3) << "the pdf over the sphere";
    Rng rng(5, 6);
    for (int i = 0; i < 1000; ++i) {
        Vec3f d, L;
        float pdf;
        ASSERT_TRUE(map.sample(rng.next_float(), rng.next_float(), d, pdf, L));
        EXPECT_NEAR(pdf, map.pdf(d), 1e-3f * pdf) << "sample and pdf agree";
        EXPECT_EQ(L, map.radiance(d));
    }
}

TEST(Environment, ImportanceSamplingBeatsUniformOnASun) {
    // Irradiance at an upward-facing point: E = integral of L cos over the hemisphere.
    // Both estimators are unbiased; importance sampling must have the lower variance at
    // the same number of samples, and the two means agree.
    const scenes::Texture sun = sun_image();
    const EnvironmentMap map(sun, Vec3f(0, 0, 1));
    const int n = 100000;
    auto run = [&](bool importance) {
        Rng rng(importance ? 1 : 2, 3);
        double s1 = 0, s2 = 0;
        for (int i = 0; i < n; ++i) {
            Vec3f d, L;
            float pdf;
            double v = 0;
            if (importance) {
                if (map.sample(rng.next_float(), rng.next_float(), d, pdf, L) && d.z > 0) v = L.y * d.z / pdf;
            } else {
                d = uniform_sphere(rng.next_float(), rng.next_float());
                if (d.z > 0) v = map.radiance(d).y * d.z / EnvironmentMap::kUniformPdf;
            }
            s1 += v;
            s2 += v * v;
        }
        const double mean = s1 / n, var = s2 / n - mean * mean;
        return std::pair<double, double>(mean, var);
    };
    const auto [mi, vi] = run(true);
    const auto [mu, vu] = run(false);
    EXPECT_LT(vi * 10, vu) << "importance " << vi << " vs uniform " << vu;
    EXPECT_NEAR(mi, mu, 3 * std::sqrt(vi / n + vu / n));
}

TEST(Materials, MirrorSphereShowsTheEnvironment) {
    // A perfect mirror of reflectance R under constant E reads R x E from every view.
    World w = env_world(constant_image(32, 16, 3.0f), [](scenes::Material& m) {
        m.bsdf = scenes::BsdfKind::Mirror;
        m.reflectance = Vec3f(0.5f, 0.7f, 0.9f);
        return 0u;
    });
    w.build({});
    const Estimate e = li(w, ray(Vec3f(0.2f, -5, 0.1f), Vec3f(0, 1, 0)), 16);
    EXPECT_NEAR(e.mean, 0.7 * 3.0, 1e-4);
}

TEST(Materials, GlassSphereUnderConstantSkyIsInvisible) {
    // A clear dielectric sphere in a uniform environment: every path ends in the sky,
    // and the 1/eta^2 factors cancel on the way in and out, so it reads E (white
    // furnace for the smooth dielectric in the integrator, with TIR inside).
    World w = env_world(constant_image(32, 16, 1.5f), [](scenes::Material& m) {
        m.bsdf = scenes::BsdfKind::Glass;
        m.ior = 1.5f;
        return 0u;
    });
    IntegratorSettings is;
    is.max_depth = 64;
    is.rr_continue = 1.0f;
    w.build(is);
    for (float x : {0.0f, 0.5f, 0.9f}) {
        const Estimate e = li(w, ray(Vec3f(x, -5, 0), Vec3f(0, 1, 0)), 4000);
        EXPECT_NEAR(e.mean, 1.5, 4 * e.se + 5e-3) << "offset " << x;
    }
}

TEST(CourseCamera, SettingsFileAndErrors) {
    const auto dir = std::filesystem::temp_directory_path() / "materials_test_cam";
    std::filesystem::create_directories(dir);
    auto write = [&](const std::string& name, const std::string& text) {
        const std::string p = (dir / name).string();
        std::ofstream(p) << text;
        return p;
    };
    const std::string base =
        "50 37.5 1.3333 0.1 100\n0 -4 1\n0 0 1\n0 0 4 1 20\n1 0 0 0 0 -1 0 1 0\n800 600 1.2\n";
    const CameraSettings c = read_camera_settings(write("ok.txt", base));
    EXPECT_FLOAT_EQ(c.hfov_deg, 50.0f);
    EXPECT_EQ(c.position, Vec3f(0, -4, 1));
    EXPECT_EQ(c.target, Vec3f(0, 0, 1));
    EXPECT_EQ(c.up, Vec3f(0, 0, 1)) << "second column of the camera-to-world matrix";
    EXPECT_FALSE(c.has_lens);
    const CameraSettings l = read_camera_settings(write("lens.txt", base + "3.5 0.05\n"));
    EXPECT_TRUE(l.has_lens);
    EXPECT_FLOAT_EQ(l.focal_distance, 3.5f);
    EXPECT_FLOAT_EQ(l.lens_radius, 0.05f);
    auto error_of = [&](const std::string& name, const std::string& text) {
        try {
            read_camera_settings(write(name, text));
        } catch (const std::invalid_argument& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    std::string e = error_of("short.txt", "50 37.5 1.3 0.1 100\n0 -4 1\n");
    EXPECT_NE(e.find("short.txt"), std::string::npos) << e;
    EXPECT_NE(e.find("target.x"), std::string::npos) << e;
    e = error_of("bad.txt", "50 37.5 abc");
    EXPECT_NE(e.find("field 3 (ar)"), std::string::npos) << e;
    e = error_of("lens1.txt", base + "3.5\n");
    EXPECT_NE(e.find("lensRadius"), std::string::npos) << e;
    e = error_of("fov.txt", std::string("0 37.5 1.3333 0.1 100\n0 -4 1\n0 0 1\n0 0 4 1 20\n1 0 0 0 0 -1 0 1 0\n800 600 1.2\n"));
    EXPECT_NE(e.find("hFov"), std::string::npos) << e;
}

TEST(CourseCamera, ThinLensKeepsTheFocalPlaneSharp) {
    Camera cam(Vec3f(0, 0, 0), Vec3f(0, 1, 0), Vec3f(0, 0, 1), 60.0f, 45.0f);
    cam.set_lens(0.2f, 3.0f);
    const accel::Ray pin = cam.generate_ray(0.3f, 0.6f);
    const Vec3f focus = pin.org + pin.dir * (3.0f / pin.dir.y);
    Rng rng(1, 1);
    float spread = 0;
    for (int i = 0; i < 100; ++i) {
        const accel::Ray r = cam.generate_ray(0.3f, 0.6f, rng.next_float(), rng.next_float());
        const Vec3f at = r.org + r.dir * ((3.0f - r.org.y) / r.dir.y);
        EXPECT_NEAR(accel::length(at - focus), 0.0f, 1e-4f);
        EXPECT_LE(accel::length(r.org), 0.2f + 1e-6f);
        spread = std::max(spread, accel::length(r.org));
    }
    EXPECT_GT(spread, 0.1f) << "origins cover the lens";
}

namespace {

/// Veach's test scene in miniature (Veach 1997, fig. 9.2): a glossy floor lit by a tiny,
/// a medium and a large emitter of similar power. Built but for its integrator.
World glossy_floor_world() {
    World w;
    w.scene.up = Vec3f(0, 0, 1);
    scenes::Material floor;
    floor.bsdf = scenes::BsdfKind::MetallicRoughness;
    floor.albedo = Vec3f(0.9f);
    floor.metallic = 1.0f;
    floor.roughness = 0.3f;
    w.scene.materials.push_back(floor);
    w.scene.meshes.push_back(quad(Vec3f(-4, -4, 0), Vec3f(4, -4, 0), Vec3f(4, 6, 0), Vec3f(-4, 6, 0)));
    const struct { Vec3f c; float r, L; } lights[] = {
        {Vec3f(-1, 2, 1), 0.03f, 800.0f}, {Vec3f(0, 2, 1), 0.2f, 18.0f}, {Vec3f(1.5f, 2, 1.5f), 0.8f, 1.1f}};
    for (const auto& l : lights) {
        scenes::Material e;
        e.emission = Vec3f(l.L);
        w.scene.materials.push_back(e);
        w.scene.spheres.push_back({l.c, l.r, uint32_t(w.scene.materials.size() - 1)});
    }
    w.geometry = std::make_unique<SceneGeometry>(w.scene);
    w.accel = build_accelerator("custom", *w.geometry, {}, false);
    w.lights = std::make_unique<LightSet>(w.scene, LightModel::Mesh, w.notes);
    return w;
}

const Vec3f kGlossyFloorCamera(0, -3, 1.5f);

/// The floor points that mirror each light toward the camera, and points beside them.
std::vector<Vec3f> glossy_floor_targets() {
    std::vector<Vec3f> targets;
    for (const Vec3f& p : {Vec3f(-0.6f, 0, 0), Vec3f(0, 0, 0), Vec3f(0.75f, -0.5f, 0)})
        for (const Vec3f& d : {Vec3f(0.0f), Vec3f(0.15f, 0, 0), Vec3f(0, 0.3f, 0)}) targets.push_back(p + d);
    return targets;
}

}  // namespace

TEST(Mis, GlossyFloorWithLightsOfSeveralSizes) {
    // Light sampling wins on the tiny light, BSDF sampling on the large one; MIS must
    // beat both over the image (summed variance at the same sample count) and all three
    // must agree (each region's means within 3 standard errors). Direct light only.
    World w = glossy_floor_world();
    const Vec3f cam = kGlossyFloorCamera;
    const std::vector<Vec3f> targets = glossy_floor_targets();
    using S = IntegratorSettings::Strategy;
    const int n = 3000;
    double var_sum[3] = {0, 0, 0};
    std::vector<Estimate> est[3];
    for (int k = 0; k < 3; ++k) {
        IntegratorSettings is;
        is.max_depth = 1;
        is.strategy = k == 0 ? S::Mis : k == 1 ? S::Light : S::Bsdf;
        w.integrator = std::make_unique<PathIntegrator>(w.scene, *w.geometry, *w.lights, is);
        for (const Vec3f& t : targets) {
            est[k].push_back(li(w, ray(cam, t - cam), n));
            var_sum[k] += est[k].back().se * est[k].back().se;
        }
    }
    EXPECT_LT(var_sum[0], var_sum[1]) << "MIS vs light sampling only";
    EXPECT_LT(var_sum[0], var_sum[2]) << "MIS vs BSDF sampling only";
    for (size_t r = 0; r < targets.size(); ++r)
        for (int k = 1; k < 3; ++k) {
            const Estimate& a = est[0][r];
            const Estimate& b = est[k][r];
            EXPECT_NEAR(a.mean, b.mean, 3 * std::sqrt(a.se * a.se + b.se * b.se) + 1e-6)
                << "region " << r << " strategy " << k;
        }
    std::printf("summed variance: mis %.4g, light %.4g, bsdf %.4g\n", var_sum[0], var_sum[1], var_sum[2]);
}

namespace {

/// The Cornell boxes' slit in miniature: a diffuse floor (z = 0) and ceiling (z = 1.5),
/// albedo 0.7, and 0.01 below the ceiling a two-sided emissive panel (radiance 5) of two
/// triangles, 0.8 x 0.6. Not built.
World slit_world() {
    World w;
    w.scene.up = Vec3f(0, 0, 1);
    scenes::Material diffuse;
    diffuse.albedo = Vec3f(0.7f);
    w.scene.materials.push_back(diffuse);
    scenes::Material panel;
    panel.emission = Vec3f(5.0f);
    w.scene.materials.push_back(panel);
    w.scene.meshes.push_back(quad(Vec3f(-2, -2, 0), Vec3f(2, -2, 0), Vec3f(2, 2, 0), Vec3f(-2, 2, 0)));
    w.scene.meshes.push_back(quad(Vec3f(-2, -2, 1.5f), Vec3f(-2, 2, 1.5f), Vec3f(2, 2, 1.5f), Vec3f(2, -2, 1.5f)));
    w.scene.meshes.push_back(quad(Vec3f(-0.4f, -0.3f, 1.49f), Vec3f(0.4f, -0.3f, 1.49f),
                                  Vec3f(0.4f, 0.3f, 1.49f), Vec3f(-0.4f, 0.3f, 1.49f), 1));
    return w;
}

}  // namespace

TEST(Mis, DiffuseCeilingJustAboveATwoSidedPanel) {
    // The Cornell boxes' slit in miniature: a diffuse ceiling 0.01 above a two-sided
    // emissive panel of two triangles. From a ceiling point above the panel, the triangle
    // below fills nearly a hemisphere and its neighbour a sliver: light sampling picks
    // either by area, so half its samples are weak, while the bounce's cosine sampling
    // hits the panel almost surely. MIS at diffuse vertices (--strategy=mis) must agree
    // with light sampling alone and have less variance there, and agree in a closed room
    // at depth 4 where every vertex weighs both.
    World w = slit_world();
    using S = IntegratorSettings::Strategy;
    const int n = 20000;
    // Rays up from inside the slit onto the ceiling above the panel, and down onto the floor.
    const accel::Ray above = ray(Vec3f(0.1f, 0.05f, 1.495f), Vec3f(0, 0, 1));
    const accel::Ray floor = ray(Vec3f(0.5f, -1.0f, 1.0f), Vec3f(0.2f, -0.1f, -1.0f));
    Estimate e[2][2];
    for (int k = 0; k < 2; ++k) {
        IntegratorSettings is;
        is.max_depth = 4;
        is.strategy = k == 0 ? S::Mis : S::Light;
        w.build(is);
        e[k][0] = li(w, above, n);
        e[k][1] = li(w, floor, n);
    }
    for (int r = 0; r < 2; ++r)
        EXPECT_NEAR(e[0][r].mean, e[1][r].mean, 3 * std::sqrt(e[0][r].se * e[0][r].se + e[1][r].se * e[1][r].se))
            << (r == 0 ? "ceiling above the panel" : "floor");
    EXPECT_GT(e[0][0].mean, 1.0) << "the ceiling above the panel is lit";
    EXPECT_LT(e[0][0].se, 0.7 * e[1][0].se) << "MIS against light sampling alone above the panel";
    std::printf("above the panel: mis %.4f +- %.4f, light %.4f +- %.4f\n", e[0][0].mean, e[0][0].se, e[1][0].mean,
                e[1][0].se);
}

TEST(Mis, SplitBounceWeighsItsLightSampleAgainstEveryBranch) {
    // Split k ways (--split), the camera hit weighs its one light sample against k bounce
    // samples, and each branch the emitter its bounce ray finds against that light
    // sample, with the sample counts in the power heuristic (Veach 1997, 9.2.4): the
    // glossy floor (BSDF vertices) and the slit's ceiling and floor (diffuse vertices)
    // keep the unsplit estimate. Counting one bounce sample instead of k moves the
    // estimate beyond these bounds.
    World glossy = glossy_floor_world();
    World slit = slit_world();
    const accel::Ray slit_rays[] = {
        ray(Vec3f(0.1f, 0.05f, 1.495f), Vec3f(0, 0, 1)),
        ray(Vec3f(0.5f, -1.0f, 1.0f), Vec3f(0.2f, -0.1f, -1.0f))};
    std::vector<Estimate> est[2];
    for (int k = 0; k < 2; ++k) {
        IntegratorSettings is;
        is.max_depth = 2;
        is.split = k ? 4 : 1;
        glossy.integrator = std::make_unique<PathIntegrator>(
            glossy.scene, *glossy.geometry, *glossy.lights, is);
        for (const Vec3f& t : glossy_floor_targets())
            est[k].push_back(
                li(glossy, ray(kGlossyFloorCamera, t - kGlossyFloorCamera), 3000));
        is.max_depth = 4;
        slit.build(is);
        for (const accel::Ray& r : slit_rays) est[k].push_back(li(slit, r, 20000));
    }
    for (size_t r = 0; r < est[0].size(); ++r) {
        const Estimate& a = est[0][r];
        const Estimate& b = est[1][r];
        EXPECT_NEAR(a.mean, b.mean, 3 * std::sqrt(a.se * a.se + b.se * b.se) + 1e-6)
            << "ray " << r;
    }
}

TEST(Mis, EmitterGuardSaysYesToEveryRayThatFindsThePanel) {
    // LightSet::may_emit_toward lets a path the roulette ends skip the trace that would
    // only look for emission. It must say yes to every ray the backend finds an emitter
    // with (else light is lost), and no to most others (else it saves nothing).
    World w = slit_world();
    w.build(IntegratorSettings{});
    Rng rng(5, 6);
    int found = 0, said_no = 0, lost = 0;
    const int n = 200000;
    for (int i = 0; i < n; ++i) {
        accel::Ray r;
        // Origins in the room and in the slit above the panel; directions over the sphere.
        r.org = Vec3f(4 * rng.next_float() - 2, 4 * rng.next_float() - 2,
                      i % 4 ? 1.49f * rng.next_float() : 1.49f + 0.01f * rng.next_float());
        if (i % 2) {
            r.dir = uniform_sphere(rng.next_float(), rng.next_float());
        } else {
            // Toward the panel's outline or its diagonal, within a hair of it.
            const float a = rng.next_float(), e = (rng.next_float() - 0.5f) * 2e-3f;
            const int side = int(rng.next_float() * 5);
            const Vec3f target = side == 0   ? Vec3f(-0.4f + 0.8f * a, -0.3f + e, 1.49f)
                                 : side == 1 ? Vec3f(-0.4f + 0.8f * a, 0.3f + e, 1.49f)
                                 : side == 2 ? Vec3f(-0.4f + e, -0.3f + 0.6f * a, 1.49f)
                                 : side == 3 ? Vec3f(0.4f + e, -0.3f + 0.6f * a, 1.49f)
                                             : Vec3f(-0.4f + 0.8f * a + e, -0.3f + 0.6f * a, 1.49f);
            r.dir = accel::normalize(target - r.org);
            if (!(accel::dot(r.dir, r.dir) > 0.5f)) r.dir = Vec3f(0, 0, 1);
        }
        accel::Hit hit;
        accel::TraceStats st;
        const bool emits = w.accel->intersect(r, hit, st) &&
                           w.scene.materials[w.geometry->material(hit.geom_id, hit.prim_id)].is_emissive();
        const bool yes = w.lights->may_emit_toward(r);
        found += emits;
        said_no += !yes;
        lost += emits && !yes;
    }
    EXPECT_EQ(lost, 0) << "rays that find the panel but the guard turned away";
    EXPECT_GT(found, n / 10) << "rays that find the panel";
    EXPECT_GT(said_no, n / 3) << "the guard turns most rays that miss away";
    // With an environment every miss finds light: the guard always says yes.
    scenes::Light env;
    env.type = scenes::LightType::Environment;
    env.radiance = Vec3f(1.0f);
    w.scene.lights.push_back(env);
    w.build(IntegratorSettings{});
    accel::Ray away;
    away.org = Vec3f(0, 0, 0.5f);
    away.dir = Vec3f(0, 0, -1);
    EXPECT_TRUE(w.lights->may_emit_toward(away));
    std::printf("guard: %d of %d rays found the panel, %d turned away, %d lost\n", found, n, said_no, lost);
}

namespace {

/// The CS184 Cornell boxes' "one light, two descriptions" in miniature: a floor of
/// `floor_material` at z = 0 under a 1 x 1 emissive panel mesh at z = 2 (radiance Le,
/// both sides) and a CGL area light describing the same rectangle, facing down. With
/// `panel_emits` false the panel is a black, non-emitting occluder of the same shape:
/// what course mode must render when a bounce never sees the panel.
constexpr float kPanelLe = 6.0f;
World panel_world(const scenes::Material& floor_material, bool panel_emits, LightModel model) {
    World w;
    w.model = model;
    w.scene.up = Vec3f(0, 0, 1);
    w.scene.materials.push_back(floor_material);
    scenes::Material panel;
    if (panel_emits) {
        panel.emission = Vec3f(kPanelLe);
    } else {
        panel.albedo = Vec3f(0.0f);
    }
    w.scene.materials.push_back(panel);
    w.scene.meshes.push_back(quad(Vec3f(-3, -3, 0), Vec3f(3, -3, 0), Vec3f(3, 3, 0), Vec3f(-3, 3, 0)));
    w.scene.meshes.push_back(
        quad(Vec3f(-0.5f, -0.5f, 2), Vec3f(0.5f, -0.5f, 2), Vec3f(0.5f, 0.5f, 2), Vec3f(-0.5f, 0.5f, 2), 1));
    scenes::Light area;
    area.type = scenes::LightType::Area;
    area.radiance = Vec3f(kPanelLe);
    area.position = Vec3f(0, 0, 2);
    area.direction = Vec3f(0, 0, -1);
    area.edge_u = Vec3f(1, 0, 0);
    area.edge_v = Vec3f(0, 1, 0);
    w.scene.lights.push_back(area);
    return w;
}

/// The camera of panel_world: the floor point (0, -2, 0) mirrors the panel's centre; a
/// mirror floor shows the panel for |x| < 1/6, -2.17 < y < -1.83.
const Vec3f kPanelCam(0, -3, 1);

}  // namespace

TEST(CourseLights, MirrorShowsThePanelOnceInBothModes) {
    // Under --lights=course a bounce is black to emission except through delta lobes: a
    // mirror shows the panel (as the course's 3-2 does), exactly R x Le, and the area
    // light is not added on top (light sampling is skipped at a delta lobe). Mesh mode
    // reads the same.
    scenes::Material mirror;
    mirror.bsdf = scenes::BsdfKind::Mirror;
    mirror.reflectance = Vec3f(0.6f, 0.8f, 0.9f);
    for (LightModel model : {LightModel::Course, LightModel::Mesh}) {
        World w = panel_world(mirror, true, model);
        IntegratorSettings is;
        is.max_depth = 3;
        w.build(is);
        for (const Vec3f& t : {Vec3f(0, -2, 0), Vec3f(0.1f, -1.9f, 0), Vec3f(-0.1f, -2.1f, 0)}) {
            const Estimate e = li(w, ray(kPanelCam, t - kPanelCam), 64);
            EXPECT_NEAR(e.mean, 0.8 * kPanelLe, 4 * e.se + 1e-4)
                << light_model_name(model) << " at " << t.x << " " << t.y;
        }
        // Beside the panel's reflection the mirror shows the (black) far floor.
        const Vec3f off(0, -1.5f, 0);
        EXPECT_NEAR(li(w, ray(kPanelCam, off - kPanelCam), 64).mean, 0.0, 1e-6) << light_model_name(model);
    }
}

TEST(CourseLights, GlossyFloorSeesOnlyTheSampledAreaLight) {
    // At a microfacet (non-delta) surface course mode takes direct light from the
    // library_lights alone. If the BSDF bounce also added the panel's emission (with or
    // without an MIS weight), the panel would be counted on top of its area light. So the
    // glossy floor under the emitting panel must read what it reads under a black panel
    // of the same shape, which only the area light lights; region means within 4 standard
    // errors, on independent streams. The floor is lit (not a vacuous comparison), and
    // --strategy=bsdf, which in course mode falls back to MIS, reads the same.
    scenes::Material gold;
    gold.bsdf = scenes::BsdfKind::Microfacet;
    gold.alpha = 0.25f;
    using S = IntegratorSettings::Strategy;
    const int n = 6000;
    for (int depth : {1, 4}) {
        IntegratorSettings is;
        is.max_depth = depth;
        World course = panel_world(gold, true, LightModel::Course);
        course.build(is);
        World reference = panel_world(gold, false, LightModel::Course);
        reference.build(is);
        IntegratorSettings bsdf_is = is;
        bsdf_is.strategy = S::Bsdf;
        World course_bsdf = panel_world(gold, true, LightModel::Course);
        course_bsdf.build(bsdf_is);
        for (const Vec3f& t : {Vec3f(0, -2, 0), Vec3f(0.3f, -1.8f, 0), Vec3f(0, -1.4f, 0), Vec3f(-0.6f, -2.4f, 0)}) {
            const accel::Ray r = ray(kPanelCam, t - kPanelCam);
            const Estimate a = estimate(*course.integrator, *course.accel, r, n, 101);
            const Estimate b = estimate(*reference.integrator, *reference.accel, r, n, 202);
            const Estimate c = estimate(*course_bsdf.integrator, *course_bsdf.accel, r, n, 303);
            const std::string where = "depth " + std::to_string(depth) + " at " + std::to_string(t.x) + " " +
                                      std::to_string(t.y);
            EXPECT_GT(b.mean, 10 * b.se) << "the area light lights the floor, " << where;
            EXPECT_NEAR(a.mean, b.mean, 4 * std::sqrt(a.se * a.se + b.se * b.se)) << where;
            EXPECT_NEAR(c.mean, b.mean, 4 * std::sqrt(c.se * c.se + b.se * b.se)) << "strategy=bsdf, " << where;
        }
    }
}

TEST(CourseLights, GlossyFloorAgreesAcrossModesWhenTheLightIsThePanel) {
    // When the area light and the panel describe the same rectangle, mesh mode (panel
    // sampled as a light, MIS with the BSDF, counted once) and course mode (area light
    // sampled, panel black to bounces) estimate the same direct light on a glossy floor.
    scenes::Material gold;
    gold.bsdf = scenes::BsdfKind::Microfacet;
    gold.alpha = 0.25f;
    IntegratorSettings is;
    is.max_depth = 1;
    World course = panel_world(gold, true, LightModel::Course);
    course.build(is);
    World mesh = panel_world(gold, true, LightModel::Mesh);
    mesh.build(is);
    for (const Vec3f& t : {Vec3f(0, -2, 0), Vec3f(0.3f, -1.8f, 0), Vec3f(0, -1.4f, 0)}) {
        const accel::Ray r = ray(kPanelCam, t - kPanelCam);
        const Estimate a = estimate(*course.integrator, *course.accel, r, 6000, 11);
        const Estimate b = estimate(*mesh.integrator, *mesh.accel, r, 6000, 12);
        EXPECT_NEAR(a.mean, b.mean, 4 * std::sqrt(a.se * a.se + b.se * b.se)) << t.x << " " << t.y;
    }
}
