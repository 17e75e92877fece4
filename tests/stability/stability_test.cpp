// Fast part of the issue-8 stability suite (the full sweep is benchmarks/extremes):
// leaks at shared edges/vertices, false self-hits per offset mode, t against a double
// reference, the slab test's corner cases through the BVH, and NaN input. Real
// behaviour only, no timings.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <filesystem>
#include <limits>

#include "benchmarks/extremes.h"
#include "renderer/camera.h"
#include "renderer/integrators/path.h"
#include "renderer/lights.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "renderer/spawn.h"

using namespace extremes;

namespace {

std::unique_ptr<accel::Accelerator> build(const World& w, const char* backend, accel::TriangleTest test) {
    static thread_local accel::GeometryView gv;
    gv = w.view();
    accel::AccelOptions o;
    o.triangle = test;
    return accel::create_accelerator(backend, std::span<const accel::GeometryView>(&gv, 1), o);
}

/// Builds the custom BVH over w and runs the given budget of each measurement.
Counts measure_custom(const World& w, accel::TriangleTest test, uint64_t leak, uint64_t acne, uint64_t ref,
                      uint64_t seed) {
    auto acc = build(w, "custom", test);
    RayBudget b;
    b.leak = leak;
    b.acne = acne;
    b.ref = ref;
    return measure(w, *acc, b, seed);
}

const std::vector<Placement> kPlacements = {{1e-3, 0}, {1, 0}, {1, 1e4}, {1e3, 1e6}, {1e7, 1e6}};

}  // namespace

TEST(Leaks, WatertightNeverLeaksAtSharedEdgesAndVertices) {
    for (const UnitMesh& m : {make_icosphere(3), make_cube(8)})
        for (const Placement& pl : kPlacements) {
            World w = place_mesh(m, pl);
            Counts c = measure_custom(w, accel::TriangleTest::Watertight, 20000, 1, 1, 1);
            EXPECT_GT(c.leak_rays, 15000u);
            EXPECT_GT(c.axis_rays, 0u);
            EXPECT_EQ(c.leaks, 0u) << m.name << " " << pl.label();
        }
}

TEST(Leaks, WatertightNeverLeaksThroughInstances) {
    // The mesh as the one prototype of a two-level scene, rotated, scaled and translated
    // (extremes::instance_transform): the object-space ray meets both faces of an edge.
    for (const UnitMesh& m : {make_icosphere(3), make_cube(8)})
        for (const Placement& pl : std::vector<Placement>{{1e-3, 0}, {1e-3, 10}, {1, 1e4}, {1e3, 1e6}}) {
            const World unit = place_mesh(m, Placement{1, 0});
            const accel::GeometryView view = unit.view();
            const accel::PrototypeView proto{0, 1};
            const accel::InstanceView inst{0, instance_transform(pl)};
            for (const char* backend : {"custom", "naive"}) {
                accel::AccelOptions o;
                o.triangle = accel::TriangleTest::Watertight;
                auto acc = accel::create_accelerator(backend, std::span(&view, 1), o,
                                                     accel::InstanceSet{std::span(&proto, 1), std::span(&inst, 1)});
                const Counts c = measure_instance_leaks(unit, inst.object_to_world, *acc, 10000, 3);
                EXPECT_GT(c.leak_rays, 9000u);
                EXPECT_EQ(c.leaks, 0u) << m.name << " " << pl.label() << " " << backend;
            }
        }
}

// Placements where the error-bound offset once failed: far from the origin relative to
// the mesh's size (offset/scale 1e4, and s = 1 at 1e6 on a 1/16 grid), and the extremes.
const std::vector<Placement> kAcnePlacements = {{1e-6, 1e-2}, {1e-3, 0}, {1, 1e4}, {1, 1e6}, {1e7, 1e6}};

TEST(Acne, ErrorBoundOffsetHasNoFalseSelfHits) {
    for (const UnitMesh& m : {make_icosphere(3), make_cube(8)})
        for (const Placement& pl : kAcnePlacements) {
            World w = place_mesh(m, pl);
            Counts c = measure_custom(w, accel::TriangleTest::Watertight, 1, 20000, 1, 2);
            EXPECT_GT(c.acne_rays(0), 15000u);
            EXPECT_GT(c.shadow_rays[0], 5000u);
            EXPECT_EQ(c.acne_false(0), 0u) << m.name << " " << pl.label();
            // Hits decided below rounding stay rare: near edges only. Not at s = 1, t = 1e6,
            // where the error box (7 ulps of 1e6 per axis) is as large as the mesh and
            // every point is within rounding of every face.
            if (pl.offset < 1e5 * pl.scale) {
                EXPECT_LT(double(c.acne_ambiguous(0)), 0.02 * double(c.acne_rays(0))) << m.name << " " << pl.label();
            }
            std::printf("%s %s: false self-hits error-bound %llu/%llu (ambiguous %llu), epsilon %llu/%llu\n",
                        m.name.c_str(), pl.label().c_str(), (unsigned long long)c.acne_false(0),
                        (unsigned long long)c.acne_rays(0), (unsigned long long)c.acne_ambiguous(0),
                        (unsigned long long)c.acne_false(1), (unsigned long long)c.acne_rays(1));
        }
}

// The CS184 meshes (concave, self-intersecting teapot) at a far placement: no false
// self-hit either. Reported, not silently passed, when ../shared is absent.
TEST(Acne, CS184MeshesFarFromOrigin) {
    const std::string dir = std::string(PT_SHARED_SCENES) + "/cs184";
    for (const char* name : {"cow", "teapot"}) {
        const std::string path = dir + "/" + name + ".dae";
        if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared scenes not found: " << path;
        World w = place_mesh(load_unit_mesh(path, name), Placement{1, 1e4});
        Counts c = measure_custom(w, accel::TriangleTest::Watertight, 1, 20000, 1, 4);
        EXPECT_GT(c.acne_rays(0), 15000u);
        EXPECT_EQ(c.acne_false(0), 0u) << name;
        std::printf("%s s=1 t=1e4: false self-hits %llu/%llu, ambiguous %llu\n", name,
                    (unsigned long long)c.acne_false(0), (unsigned long long)c.acne_rays(0),
                    (unsigned long long)c.acne_ambiguous(0));
    }
}

// No light leaks through a thin wall (1e-3 of the scene, at least 64 ulps) from floor
// points beyond the rounding of the wall; leaks within it are reported.
TEST(ThinWall, NoLeaksBeyondRounding) {
    for (const Placement& pl : {Placement{1e-6, 0}, Placement{1, 0}, Placement{1, 1e4}, Placement{1e3, 1e6}}) {
        const double thickness = thin_wall_thickness(pl);
        const World w = make_thin_wall(thickness, pl);
        for (auto test : {accel::TriangleTest::Fast, accel::TriangleTest::Watertight}) {
            auto acc = build(w, "custom", test);
            const WallCounts c = measure_thin_wall(w, thickness, *acc, 50000, 5);
            EXPECT_EQ(c.rays[0], 50000u);
            EXPECT_EQ(c.leaks[0], c.leaks_within[0]) << pl.label();
            EXPECT_EQ(c.leaks[1], c.leaks_within[1]) << pl.label() << " (epsilon)";
            std::printf("%s: thin-wall leaks error-bound %llu (within rounding %llu), epsilon %llu of %llu\n",
                        pl.label().c_str(), (unsigned long long)c.leaks[0], (unsigned long long)c.leaks_within[0],
                        (unsigned long long)c.leaks[1], (unsigned long long)c.rays[0]);
        }
    }
}

// Rays float can decide (edge functions beyond pbrt-v4's error bound) are never missed by
// our backends, and our watertight t stays within pbrt-v4's bound on t's error.
TEST(Reference, DecidableRaysHitAndTStaysWithinTheErrorBound) {
    for (const Placement& pl : kPlacements)
        for (const UnitMesh& m : {make_icosphere(3), make_cube(8)}) {
            World w = place_mesh(m, pl);
            for (auto test : {accel::TriangleTest::Fast, accel::TriangleTest::Watertight}) {
                Counts c = measure_custom(w, test, 1, 1, 20000, 3);
                const char* tn = test == accel::TriangleTest::Fast ? "fast" : "watertight";
                EXPECT_GT(c.ref_compared, 5000u) << m.name << " " << pl.label();
                EXPECT_EQ(c.wrong_miss, 0u) << m.name << " " << pl.label() << " " << tn;
                if (test == accel::TriangleTest::Watertight) {
                    EXPECT_LE(c.max_t_over_bound, 1.0) << pl.label();
                }
                // Well-conditioned rays: t to a few parts in 1e4 at worst (random
                // directions include some near-grazing ones).
                EXPECT_LT(c.max_rel_t, 1e-3) << m.name << " " << pl.label() << " " << tn;
                std::printf("%s %s %s: max rel t error %.3g (grazing %.3g), |dt|/bound %.3g, wrong misses %llu/%llu\n",
                            m.name.c_str(), pl.label().c_str(), tn, c.max_rel_t, c.max_rel_t_grazing,
                            c.max_t_over_bound, (unsigned long long)c.wrong_miss, (unsigned long long)c.ref_rays);
            }
        }
}

// Williams 2005 / Ize 2013: the slab test with 0, -0 and tiny direction components and
// origins exactly on box faces; the BVH must agree with brute force.
TEST(SlabTest, BvhAgreesWithNaiveOnAxisAndFaceRays) {
    World w = place_mesh(make_cube(4), Placement{1, 0});
    for (auto test : {accel::TriangleTest::Fast, accel::TriangleTest::Watertight}) {
        auto bvh = build(w, "custom", test);
        auto naive = build(w, "naive", test);
        renderer::Rng rng(5, 0);
        accel::TraceStats st;
        int compared = 0, hits = 0;
        const float tiny[] = {0.0f, -0.0f, 1e-30f, -1e-30f, std::numeric_limits<float>::denorm_min(), 1e-7f};
        for (int i = 0; i < 20000; ++i) {
            accel::Ray r;
            // Origins on a box face (the cube's faces are the scene box's faces) or on
            // the plane of an inner grid line, with one dominant axis.
            const int k = int(rng.next_u32() % 3);
            const float grid[] = {-0.5f, -0.25f, 0.0f, 0.25f, 0.5f};
            for (int a = 0; a < 3; ++a) r.org[a] = grid[rng.next_u32() % 5] + (rng.next_u32() & 1 ? 0.0f : 0.1f);
            r.org[k] = (rng.next_u32() & 1) ? 0.5f : -0.5f;
            if (rng.next_u32() & 1) r.org[k] *= 3.0f;  // outside
            // On a face plane of the box only +-0 gives an exact answer both sides must
            // share: with dir = 1e-30 the exact ray leaves the box at t = 0 (the slab
            // test says so), while the triangle test, rounding 0.5 + 1e-30 to 0.5,
            // reports the boundary edge.
            for (int a = 0; a < 3; ++a)
                r.dir[a] = tiny[rng.next_u32() % (std::abs(r.org[a]) == 0.5f ? 2 : 6)];
            r.dir[k] = r.org[k] > 0 ? -1.0f : 1.0f;
            if (rng.next_u32() % 4 == 0) r.dir[k] = -r.dir[k];
            accel::Hit hb, hn;
            const bool b = bvh->intersect(r, hb, st), n = naive->intersect(r, hn, st);
            ASSERT_EQ(b, n) << "org " << r.org.x << " " << r.org.y << " " << r.org.z << " dir " << r.dir.x << " "
                            << r.dir.y << " " << r.dir.z;
            if (b) {
                EXPECT_EQ(hb.t, hn.t);
                ++hits;
            }
            EXPECT_EQ(bvh->occluded(r, st), naive->occluded(r, st));
            ++compared;
        }
        EXPECT_GT(hits, 1000);
        EXPECT_EQ(compared, 20000);
    }
}

// A light sample carries the light's normal and error bound, so the shadow segment stops
// short of the light's own surface even where it arrives at a grazing angle, far from
// the origin: the case a bare point (back-off along the segment only) gets wrong.
TEST(Lights, GrazingLightSamplesClearTheLightsOwnSurface) {
    for (double off : {0.0, 1e3, 1e5}) {
        const Vec3d o = offset_dir() * off;
        scenes::Scene scene;
        scenes::Material light;
        light.emission = Vec3f(1.0f);
        scene.materials = {light};
        // A unit square in the plane x = 0, emitting toward -x, tilted about z and y so
        // that no coordinate of a sampled point is exact, then shifted by o.
        auto frame = [](const Vec3d& v) {
            const double a = 0.3, b = 0.2;
            const Vec3d r(v.x * std::cos(a) - v.y * std::sin(a), v.x * std::sin(a) + v.y * std::cos(a), v.z);
            return Vec3d(r.x * std::cos(b) + r.z * std::sin(b), r.y, -r.x * std::sin(b) + r.z * std::cos(b));
        };
        scenes::Mesh m;
        for (const Vec3d& v : {Vec3d(0, -0.5, 0), Vec3d(0, 0.5, 0), Vec3d(0, 0.5, 1), Vec3d(0, -0.5, 1)})
            m.positions.push_back(Vec3f(o + frame(v)));
        m.pad_positions();
        m.indices = {0, 2, 1, 0, 3, 2};
        m.material = 0;
        scene.meshes.push_back(m);
        renderer::SceneGeometry geometry(scene);
        auto acc = renderer::build_accelerator("custom", geometry, {}, false);
        std::vector<std::string> notes;
        renderer::LightSet lights(scene, renderer::LightModel::Mesh, notes);
        ASSERT_EQ(lights.size(), 1u);
        ASSERT_EQ(lights.kind(0), renderer::LightSet::Kind::Mesh);
        renderer::Rng rng(7, 0);
        accel::TraceStats st;
        const Vec3f ng(frame(Vec3d(1, 0, 0)));  // the shading point's surface faces the light
        int n = 0, grazing = 0, with_normal = 0, without_normal = 0;
        for (int i = 0; i < 20000; ++i) {
            // In front of the light, close to its plane (yet beyond the point's own
            // rounding, 4 |err|_1, or the point itself may lie behind the light) and far
            // to the side: the segment arrives at cosines down to 1e-5.
            const double clear = 4.0 * 3.0 * double(renderer::gamma_bound(7)) * accel::length(o);
            const Vec3d local(-1e-3 - clear - 0.05 * rng.next_float(), (rng.next_float() - 0.5) * 400.0,
                              rng.next_float());
            const Vec3f p(o + frame(local));
            const Vec3f p_err = accel::vabs(p) * renderer::gamma_bound(7);
            renderer::LightSample ls;
            if (!lights.sample(0, p, ng, rng, ls) || !std::isfinite(ls.distance)) continue;
            ++n;
            grazing += std::abs(accel::dot(ls.normal, ls.wi)) < 0.01f;
            EXPECT_FLOAT_EQ(accel::length(ls.normal), 1.0f);
            const accel::Ray a = renderer::spawn_segment(p, p_err, ng, ls.target, ls.target_error, 2.0f,
                                                         renderer::OffsetMode::ErrorBound, ls.normal);
            const accel::Ray b = renderer::spawn_segment(p, p_err, ng, ls.target, ls.target_error, 2.0f,
                                                         renderer::OffsetMode::ErrorBound);
            with_normal += acc->occluded(a, st);
            without_normal += acc->occluded(b, st);
        }
        EXPECT_GT(n, 15000);
        EXPECT_GT(grazing, 1000);
        EXPECT_EQ(with_normal, 0) << "offset " << off;
        std::printf("offset %g: %d light samples (%d grazing): occluded by the light itself %d with its "
                    "normal, %d without\n",
                    off, n, grazing, with_normal, without_normal);
    }
}

// NaN/Inf never poisons a pixel: the degenerate triangle is dropped at build time and
// counted; rays with NaN components miss.
TEST(NaN, NanVertexIsDroppedAndNoPixelIsNaN) {
    scenes::Scene scene;
    scenes::Material floor, light;
    light.emission = Vec3f(4.0f);
    scene.materials = {floor, light};
    const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
    scenes::Mesh m;
    m.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}, {nan, 0, 0.5f}, {0, inf, 0.5f}};
    m.pad_positions();
    m.indices = {0, 1, 2, 0, 2, 3, 4, 1, 2, 0, 5, 3};  // two good, one NaN, one Inf triangle
    m.material = 0;
    scene.meshes.push_back(m);
    scenes::Mesh l;
    l.positions = {{-0.2f, -0.2f, 1}, {-0.2f, 0.2f, 1}, {0.2f, 0.2f, 1}, {0.2f, -0.2f, 1}};
    l.pad_positions();
    l.indices = {0, 1, 2, 0, 2, 3};
    l.material = 1;
    scene.meshes.push_back(l);
    renderer::SceneGeometry geometry(scene);
    for (const char* backend : {"naive", "custom"}) {
        auto acc = renderer::build_accelerator(backend, geometry, {}, false);
        EXPECT_EQ(acc->info().dropped, 2u) << backend;
        std::vector<std::string> notes;
        renderer::LightSet lights(scene, renderer::LightModel::Mesh, notes);
        renderer::IntegratorSettings is;
        renderer::PathIntegrator integ(scene, geometry, lights, is);
        renderer::Camera cam = renderer::make_camera(scene, renderer::CameraMode::Auto, 32, 24).camera;
        renderer::RenderSettings rs;
        rs.width = 32;
        rs.height = 24;
        rs.spp = 4;
        rs.progress = false;
        renderer::RenderResult res = renderer::render(cam, integ, *acc, rs);
        const renderer::Image& img = res.image;
        for (size_t i = 0; i < size_t(rs.width) * rs.height; ++i)
            for (int ch = 0; ch < 3; ++ch) ASSERT_TRUE(std::isfinite(img.pixels[i * img.nchannels() + ch]));
        // A NaN ray misses instead of crashing.
        accel::Ray r;
        r.org = Vec3f(0, 0, 5);
        r.dir = Vec3f(nan, 0, -1);
        accel::Hit h;
        accel::TraceStats st;
        EXPECT_FALSE(acc->intersect(r, h, st));
        EXPECT_FALSE(acc->occluded(r, st));
    }
}

TEST(Offsets, NextFloatMatchesNextafterOnEveryKindOfFloat) {
    // The bit-stepping next_float_up/down (renderer/spawn.h) against libm's nextafter:
    // zeros of both signs, denormals, normals of both signs, the largest finite float
    // (stepping up gives +inf), infinities and NaN, and a sweep of bit patterns.
    const float inf = std::numeric_limits<float>::infinity();
    std::vector<float> v = {0.0f, -0.0f, std::numeric_limits<float>::denorm_min(), -std::numeric_limits<float>::denorm_min(),
                            std::numeric_limits<float>::min(), -std::numeric_limits<float>::min(), 1.0f, -1.0f,
                            std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(), inf, -inf};
    for (uint32_t b = 1; b < 0xFF800000u; b += 0x00012345u) v.push_back(std::bit_cast<float>(b));
    for (const float x : v) {
        if (std::isnan(x)) continue;  // checked below: libm quiets a signalling NaN
        const float up = std::nextafter(x == 0.0f ? 0.0f : x, inf), down = std::nextafter(x == 0.0f ? -0.0f : x, -inf);
        EXPECT_EQ(std::bit_cast<uint32_t>(renderer::next_float_up(x)), std::bit_cast<uint32_t>(x == inf ? inf : up)) << x;
        EXPECT_EQ(std::bit_cast<uint32_t>(renderer::next_float_down(x)), std::bit_cast<uint32_t>(x == -inf ? -inf : down))
            << x;
    }
    EXPECT_TRUE(std::isnan(renderer::next_float_up(std::numeric_limits<float>::quiet_NaN())));
    EXPECT_TRUE(std::isnan(renderer::next_float_down(std::numeric_limits<float>::quiet_NaN())));
}
