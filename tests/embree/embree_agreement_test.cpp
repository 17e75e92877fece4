// The Embree backend must answer every query as the naive reference does: same hit or
// miss, same primitive (except exact ties), same t, our normal convention, same dropped
// primitives. Checked in normal mode (Embree's own triangle test) and in counting mode
// (Embree's BVH, our primitive tests).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <tbb/global_control.h>

#include "accel/accelerator.h"
#include "accel/embree/embree.h"
#include "tests/embree/test_meshes.h"
#include "renderer/scene_geometry.h"
#include "scenes/load.h"

using namespace accel;
using test_meshes::TestMesh;
using test_meshes::random_in_box;
using test_meshes::tessellated_sphere;

namespace {

struct TestSpheres {
    std::vector<float> xyzr;
    GeometryView view() const { return GeometryView::sphere_list(xyzr.data(), uint32_t(xyzr.size() / 4)); }
};

TestMesh triangle_soup(uint32_t n, uint32_t seed, const Vec3f& offset = Vec3f(0.0f)) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> edge(-0.3f, 0.3f);
    TestMesh m;
    for (uint32_t i = 0; i < n; ++i) {
        Vec3f c = random_in_box(rng, Vec3f(-2.0f), Vec3f(2.0f)) + offset;
        for (int k = 0; k < 3; ++k) {
            m.positions.push_back(c + Vec3f(edge(rng), edge(rng), edge(rng)));
            m.indices.push_back(3 * i + k);
        }
    }
    m.finish();
    return m;
}

/// Height field over [-2,2]^2 at y ~ -1: every interior edge is shared by two triangles.
TestMesh grid(uint32_t n) {
    TestMesh m;
    for (uint32_t i = 0; i <= n; ++i)
        for (uint32_t j = 0; j <= n; ++j) {
            float x = -2.0f + 4.0f * float(i) / float(n), z = -2.0f + 4.0f * float(j) / float(n);
            m.positions.push_back({x, -1.0f + 0.1f * std::sin(3.0f * x) * std::cos(2.0f * z), z});
        }
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = 0; j < n; ++j) {
            uint32_t a = i * (n + 1) + j, b = a + 1, c = a + n + 1, d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
    m.finish();
    return m;
}

TestSpheres random_spheres(uint32_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> rad(0.05f, 0.5f);
    TestSpheres s;
    for (uint32_t i = 0; i < n; ++i) {
        Vec3f c = random_in_box(rng, Vec3f(-2.0f), Vec3f(2.0f));
        s.xyzr.insert(s.xyzr.end(), {c.x, c.y, c.z, rad(rng)});
    }
    return s;
}

/// Rays from outside and inside the scene box toward points in it; some with a finite
/// [t_min, t_max] window so clipping is exercised as well.
std::vector<Ray> random_rays(uint32_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    std::vector<Ray> rays;
    rays.reserve(n);
    for (uint32_t i = 0; i < n; ++i) {
        Ray r;
        r.org = (i % 4 == 0) ? random_in_box(rng, Vec3f(-2.0f), Vec3f(2.0f))
                             : random_in_box(rng, Vec3f(-6.0f), Vec3f(6.0f));
        r.dir = random_in_box(rng, Vec3f(-2.0f), Vec3f(2.0f)) - r.org;
        if (i % 5 == 1) {
            r.t_min = 0.3f * u(rng);
            r.t_max = r.t_min + 1.5f * u(rng);
        }
        rays.push_back(r);
    }
    return rays;
}

/// How closely two backends must agree on a hit of the same primitive. Counting mode
/// runs our very intersector on the very same inputs, so it must agree bit for bit.
/// Normal mode runs Embree's own triangle test, whose rounding differs from ours:
/// t to 1e-5 relative (relative to at least 0.01, since for a ray that starts a hair
/// from a triangle both t are tiny and their absolute rounding is what matters), and
/// barycentrics to 1e-3 (they are ill-conditioned for grazing rays on small triangles).
/// A plane-distance rounding error becomes a t error divided by |cos| of the angle
/// between ray and normal, so for grazing rays (|cos| < 0.1) the t bound is scaled by
/// 0.1/|cos|; the report counts how often that was needed.
struct Tolerance {
    float t_rel = 1e-5f;
    float uv = 1e-3f;
    static Tolerance exact() { return {0.0f, 0.0f}; }
};

struct AgreementReport {
    uint64_t rays = 0, hits = 0, ties = 0, grazing_relaxed = 0;
    float max_t_rel = 0.0f, max_uv = 0.0f;
};

/// Compares `test` against `ref` on every ray; non-fatal failures name the ray index.
AgreementReport expect_agreement(const Accelerator& test, const Accelerator& ref,
                                 const std::vector<Ray>& rays, const std::string& what,
                                 Tolerance tol = {}) {
    AgreementReport rep;
    TraceStats st, sr;
    int failures = 0;
    for (size_t i = 0; i < rays.size() && failures < 10; ++i) {
        const Ray& ray = rays[i];
        Hit ht, hr;
        bool bt = test.intersect(ray, ht, st);
        bool br = ref.intersect(ray, hr, sr);
        bool ot = test.occluded(ray, st);
        ++rep.rays;
        auto fail = [&](const std::string& why) {
            ADD_FAILURE() << what << ": ray " << i << ": " << why << " (test t=" << ht.t << " u,v="
                          << ht.u << "," << ht.v << " geom " << ht.geom_id << " prim " << ht.prim_id
                          << "; ref t=" << hr.t << " u,v=" << hr.u << "," << hr.v << " geom "
                          << hr.geom_id << " prim " << hr.prim_id << ")";
            ++failures;
        };
        if (bt != br) { fail("hit/miss differs"); continue; }
        if (ot != bt) { fail("occluded disagrees with intersect"); continue; }
        if (!bt) continue;
        ++rep.hits;
        if (!(ht.t >= ray.t_min && ht.t <= ray.t_max)) { fail("t outside [t_min, t_max]"); continue; }
        const float t_rel = std::abs(ht.t - hr.t) / std::max(hr.t, 0.01f);
        const float cos_abs = std::abs(dot(normalize(hr.ng), normalize(ray.dir)));
        const float t_bound = tol.t_rel * std::max(1.0f, 0.1f / std::max(cos_abs, 1e-4f));
        if (!(t_rel <= t_bound)) { fail("t differs (|cos| " + std::to_string(cos_abs) + ")"); continue; }
        if (t_rel > tol.t_rel) ++rep.grazing_relaxed;
        rep.max_t_rel = std::max(rep.max_t_rel, t_rel);
        const bool same_prim = ht.geom_id == hr.geom_id && ht.prim_id == hr.prim_id;
        if (!same_prim) {
            ++rep.ties;  // same t (checked above), different primitive: a shared edge/vertex
            continue;
        }
        const float dn = dot(ht.ng, hr.ng);
        const float cn = length(cross(normalize(ht.ng), normalize(hr.ng)));
        if (!(dn > 0.0f) || !(cn < 1e-3f)) { fail("normal not parallel with the same sign"); continue; }
        const float duv = std::max(std::abs(ht.u - hr.u), std::abs(ht.v - hr.v));
        if (!(duv <= tol.uv)) { fail("u/v differ"); continue; }
        rep.max_uv = std::max(rep.max_uv, duv);
    }
    EXPECT_EQ(failures, 0) << what;
    // Ties need a ray through a shared edge or vertex at float precision: rare.
    EXPECT_LE(rep.ties * 1000, std::max<uint64_t>(rep.hits, 1000)) << what << ": too many ties";
    return rep;
}

std::unique_ptr<Accelerator> naive(std::span<const GeometryView> views, const AccelOptions& o) {
    return create_accelerator("naive", views, o);
}

struct Scenario {
    std::string name;
    std::vector<TestMesh> meshes;
    std::vector<TestSpheres> spheres;
    std::vector<GeometryView> views;
};

Scenario make_scenario(const std::string& name) {
    Scenario s;
    s.name = name;
    if (name == "soup") s.meshes.push_back(triangle_soup(3000, 7));
    if (name == "sphere") s.meshes.push_back(tessellated_sphere(48, 96, Vec3f(0.2f, 0.1f, -0.3f), 1.5f));
    if (name == "grid") s.meshes.push_back(grid(64));
    if (name == "spheres") s.spheres.push_back(random_spheres(300, 11));
    if (name == "mixed") {
        s.meshes.push_back(grid(16));
        s.spheres.push_back(random_spheres(40, 5));
        s.meshes.push_back(triangle_soup(500, 9));
        s.meshes.push_back(tessellated_sphere(12, 24, Vec3f(1.0f, 1.0f, 1.0f), 0.7f));
    }
    // Views are taken after all vectors are in place (moves would not invalidate the
    // data pointers anyway, but this keeps the dependency obvious).
    if (name == "mixed") {
        s.views = {s.meshes[0].view(), s.spheres[0].view(), s.meshes[1].view(), s.meshes[2].view()};
    } else {
        for (const auto& m : s.meshes) s.views.push_back(m.view());
        for (const auto& sp : s.spheres) s.views.push_back(sp.view());
    }
    return s;
}

const char* kScenarios[] = {"soup", "sphere", "grid", "spheres", "mixed"};

AccelOptions options(bool count, TriangleTest test = TriangleTest::Fast) {
    AccelOptions o;
    o.embree_count = count;
    o.triangle = test;
    return o;
}

}  // namespace

TEST(EmbreeAgreement, NormalModeMatchesNaive) {
    for (const char* name : kScenarios) {
        Scenario s = make_scenario(name);
        AccelOptions o = options(false);
        auto e = make_embree(s.views, o);
        auto n = naive(s.views, o);
        EXPECT_EQ(e->info().primitives, n->info().primitives) << name;
        EXPECT_EQ(e->info().dropped, n->info().dropped) << name;
        EXPECT_FALSE(e->info().counts_prims);
        EXPECT_EQ(e->info().backend, "embree(high)");
        auto rep = expect_agreement(*e, *n, random_rays(20000, 3), std::string("normal/") + name);
        std::printf("[normal/%s] %llu rays, %llu hits, %llu ties, max rel dt %.2g (%llu grazing "
                    "hits above 1e-5), max du/dv %.2g\n",
                    name, (unsigned long long)rep.rays, (unsigned long long)rep.hits,
                    (unsigned long long)rep.ties, rep.max_t_rel,
                    (unsigned long long)rep.grazing_relaxed, rep.max_uv);
        EXPECT_GT(rep.hits, rep.rays / 10) << name << ": rays should mostly hit something";
    }
}

TEST(EmbreeAgreement, CountingModeMatchesNaive) {
    for (TriangleTest test : {TriangleTest::Fast, TriangleTest::Watertight}) {
        for (const char* name : kScenarios) {
            Scenario s = make_scenario(name);
            AccelOptions o = options(true, test);
            auto e = make_embree(s.views, o);
            auto n = naive(s.views, o);
            EXPECT_TRUE(e->info().counts_prims);
            EXPECT_FALSE(e->info().counts_nodes);
            EXPECT_EQ(e->info().backend, test == TriangleTest::Fast ? "embree(count, high, fast)"
                                                                    : "embree(count, high, watertight)");
            EXPECT_EQ(e->info().dropped, n->info().dropped);
            auto rep = expect_agreement(*e, *n, random_rays(10000, 4), std::string("count/") + name,
                                        Tolerance::exact());
            EXPECT_GT(rep.hits, rep.rays / 10) << name;
        }
    }
}

// What the tools call: the factory must hand out this backend under its name.
TEST(EmbreeAgreement, FactoryBuildsEmbree) {
    const auto names = available_backends();
    EXPECT_NE(std::find(names.begin(), names.end(), "embree"), names.end());
    Scenario s = make_scenario("mixed");
    AccelOptions o = options(true, TriangleTest::Watertight);
    o.embree_quality = EmbreeQuality::Low;
    o.embree_robust = true;
    auto e = create_accelerator("embree", s.views, o);
    EXPECT_EQ(e->info().backend, "embree(count, low, watertight, robust)");
    expect_agreement(*e, *naive(s.views, o), random_rays(2000, 51), "factory", Tolerance::exact());
}

TEST(EmbreeAgreement, BoundsMatchNaive) {
    for (bool count : {false, true}) {
        Scenario s = make_scenario("mixed");
        auto e = make_embree(s.views, options(count));
        auto n = naive(s.views, options(count));
        Bounds3f be = e->bounds(), bn = n->bounds();
        for (int k = 0; k < 3; ++k) {
            EXPECT_NEAR(be.lo[k], bn.lo[k], 1e-5f) << "count=" << count;
            EXPECT_NEAR(be.hi[k], bn.hi[k], 1e-5f) << "count=" << count;
        }
    }
}

TEST(EmbreeAgreement, QualitiesAndRobustBuildAndAgree) {
    Scenario s = make_scenario("mixed");
    auto n = naive(s.views, AccelOptions{});
    const auto rays = random_rays(5000, 21);
    for (bool count : {false, true})
        for (bool robust : {false, true})
            for (EmbreeQuality q : {EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High}) {
                AccelOptions o = options(count);
                o.embree_quality = q;
                o.embree_robust = robust;
                auto e = make_embree(s.views, o);
                const std::string label = e->info().backend;
                EXPECT_NE(label.find(q == EmbreeQuality::Low      ? "low"
                                     : q == EmbreeQuality::Medium ? "medium"
                                                                  : "high"),
                          std::string::npos)
                    << label;
                EXPECT_EQ(label.find("robust") != std::string::npos, robust) << label;
                expect_agreement(*e, *n, rays, label, count ? Tolerance::exact() : Tolerance{});
            }
}

// build_threads must limit the build only: Embree's own "threads=N" would install a
// process-wide TBB limit for the accelerator's lifetime and throttle the renderer.
TEST(EmbreeAgreement, BuildThreadsOptionHasNoProcessWideEffect) {
    const auto parallelism = [] {
        return tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
    };
    const size_t before = parallelism();
    Scenario s = make_scenario("soup");
    for (bool count : {false, true}) {
        AccelOptions o = options(count);
        o.build_threads = 1;
        auto e = make_embree(s.views, o);
        EXPECT_EQ(parallelism(), before) << "while the accelerator lives";
        auto n = naive(s.views, o);
        expect_agreement(*e, *n, random_rays(3000, 8), count ? "threads=1/count" : "threads=1",
                         count ? Tolerance::exact() : Tolerance{});
    }
}

// Informational: build time and memory per quality on a 90k-triangle scene. No
// thresholds (timings depend on the machine); asserts only what must hold everywhere.
TEST(EmbreeInfo, BuildPerQuality) {
    TestMesh soup = triangle_soup(50000, 31);
    TestMesh ball = tessellated_sphere(100, 200, Vec3f(0.5f), 1.0f);
    std::vector<GeometryView> views{soup.view(), ball.view()};
    for (bool count : {false, true})
        for (EmbreeQuality q : {EmbreeQuality::Low, EmbreeQuality::Medium, EmbreeQuality::High}) {
            AccelOptions o = options(count);
            o.embree_quality = q;
            auto e = make_embree(views, o);
            EXPECT_EQ(e->info().primitives, 50000u + 39600u);
            EXPECT_GT(e->info().bytes, 0u);
            TraceStats st;
            Hit h;
            const auto rays = random_rays(50000, 37);
            const auto t0 = std::chrono::steady_clock::now();
            for (const Ray& r : rays) e->intersect(r, h, st);
            const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            std::printf("[%s] %llu prims: build %.4f s, %.2f MiB, %.2f Mrays/s (1 thread)%s\n",
                        e->info().backend.c_str(), (unsigned long long)e->info().primitives,
                        e->info().build_seconds, double(e->info().bytes) / (1024.0 * 1024.0),
                        double(rays.size()) / secs * 1e-6,
                        count ? (", " + std::to_string(st.tests_per_ray()) + " prim tests/ray").c_str() : "");
        }
}

TEST(EmbreeRays, TMinTMaxAndInsideStarts) {
    for (bool count : {false, true}) {
        SCOPED_TRACE(count ? "counting" : "normal");
        TestSpheres sp;
        sp.xyzr = {0.0f, 0.0f, 0.0f, 1.0f};
        TestMesh ball = tessellated_sphere(32, 64, Vec3f(5.0f, 0.0f, 0.0f), 1.0f);
        std::vector<GeometryView> views{sp.view(), ball.view()};
        auto e = make_embree(views, options(count));
        TraceStats st;
        Hit h;

        // Starting at the sphere's centre: the near root is behind, the far root is hit.
        Ray inside{{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 2.0f}};
        ASSERT_TRUE(e->intersect(inside, h, st));
        EXPECT_NEAR(h.t, 0.5f, 1e-6f);
        EXPECT_EQ(h.geom_id, 0u);
        EXPECT_EQ(h.prim_id, 0u);
        EXPECT_GT(h.ng.z, 0.0f) << "sphere normal is hit point - centre (outward)";
        EXPECT_NEAR(h.ng.z, 1.0f, 1e-5f);

        // Through the sphere from outside: near root; with t_min past it, the far root.
        Ray through{{0.0f, 0.0f, -3.0f}, {0.0f, 0.0f, 1.0f}};
        ASSERT_TRUE(e->intersect(through, h, st));
        EXPECT_NEAR(h.t, 2.0f, 1e-5f);
        EXPECT_LT(h.ng.z, 0.0f);
        through.t_min = 2.5f;
        ASSERT_TRUE(e->intersect(through, h, st));
        EXPECT_NEAR(h.t, 4.0f, 1e-5f);
        through.t_min = 4.5f;
        EXPECT_FALSE(e->intersect(through, h, st));
        EXPECT_FALSE(e->occluded(through, st));
        through.t_min = 0.0f;
        through.t_max = 1.9f;
        EXPECT_FALSE(e->intersect(through, h, st));
        EXPECT_FALSE(e->occluded(through, st));
        through.t_max = 2.1f;
        EXPECT_TRUE(e->occluded(through, st));

        // The tessellated ball (geom 1): outward winding gives an outward normal at entry,
        // and from inside the far wall's normal points along the ray.
        Ray at_ball{{5.0f, 0.05f, -3.0f}, {0.0f, 0.0f, 1.0f}};
        ASSERT_TRUE(e->intersect(at_ball, h, st));
        EXPECT_EQ(h.geom_id, 1u);
        EXPECT_NEAR(h.t, 2.0f, 0.01f);
        EXPECT_LT(h.ng.z, 0.0f);
        Ray from_centre{{5.0f, 0.05f, 0.0f}, {0.0f, 0.0f, 1.0f}};
        ASSERT_TRUE(e->intersect(from_centre, h, st));
        EXPECT_NEAR(h.t, 1.0f, 0.01f);
        EXPECT_GT(h.ng.z, 0.0f);
        from_centre.t_max = 0.9f;
        EXPECT_FALSE(e->intersect(from_centre, h, st));

        EXPECT_EQ(st.rays, 8u);
        EXPECT_EQ(st.shadow_rays, 3u);
    }
}

TEST(EmbreeRays, MissLeavesHitUntouched) {
    TestMesh m = grid(4);
    std::vector<GeometryView> views{m.view()};
    auto e = make_embree(views, options(false));
    Hit h;
    h.t = 123.0f;
    h.prim_id = 77;
    TraceStats st;
    EXPECT_FALSE(e->intersect(Ray{{0.0f, 5.0f, 0.0f}, {0.0f, 1.0f, 0.0f}}, h, st));
    EXPECT_EQ(h.t, 123.0f);
    EXPECT_EQ(h.prim_id, 77u);
}

// Normal mode cannot see Embree's primitive tests, so it must not report any (a zero
// with counts_prims == false, rather than a partial count of just the spheres).
TEST(EmbreeCounting, NormalModeReportsNoPrimTests) {
    Scenario s = make_scenario("mixed");
    auto e = make_embree(s.views, options(false));
    TraceStats st;
    Hit h;
    uint64_t hits = 0;
    for (const Ray& r : random_rays(1000, 41)) {
        hits += e->intersect(r, h, st);
        e->occluded(r, st);
    }
    EXPECT_GT(hits, 0u);
    EXPECT_EQ(st.rays, 1000u);
    EXPECT_EQ(st.shadow_rays, 1000u);
    EXPECT_EQ(st.prim_tests, 0u);
    EXPECT_EQ(st.nodes_visited, 0u);
}

TEST(EmbreeEdgeCases, EmptyGeometry) {
    for (bool count : {false, true}) {
        TestMesh empty_mesh;
        empty_mesh.finish();
        TestSpheres no_spheres;
        std::vector<GeometryView> none;
        std::vector<GeometryView> empties{empty_mesh.view(), no_spheres.view()};
        for (const auto* views : {&none, &empties}) {
            auto e = make_embree(*views, options(count));
            EXPECT_EQ(e->info().primitives, 0u);
            EXPECT_EQ(e->info().dropped, 0u);
            EXPECT_TRUE(e->bounds().empty());
            Hit h;
            TraceStats st;
            Ray r{{0.0f, 0.0f, -5.0f}, {0.0f, 0.0f, 1.0f}};
            EXPECT_FALSE(e->intersect(r, h, st));
            EXPECT_FALSE(e->occluded(r, st));
            EXPECT_EQ(st.prim_tests, 0u);
        }
    }
}

TEST(EmbreeEdgeCases, OutOfRangeAndDegenerateTrianglesAreDroppedLikeNaive) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    // View 0: valid triangles interleaved with out-of-range indices, zero-area triangles
    // (repeated vertex, collinear vertices) and a NaN vertex: Embree must not read out of
    // bounds (it gets a filtered copy) and prim ids must still be the view's own.
    TestMesh bad;
    bad.positions = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0},    // 0-2: fine
                     {2, -1, 0},  {4, -1, 0}, {3, 1, 0},    // 3-5: fine
                     {0, 0, 1},   {1, 1, 1},  {2, 2, 1},    // 6-8: collinear
                     {nan, 0, 0}, {5, 5, 5},  {6, 6, 0},    // 9: NaN
                     {2, -1, 0.5f}, {4, -1, 0.5f}, {3, 1, 0.5f}};  // 12-14: behind 3-5
    bad.indices = {0, 1, 2,        // 0 ok
                   0, 1, 99,       // 1 out of range
                   3, 4, 5,        // 2 ok
                   6, 7, 8,        // 3 collinear
                   1, 1, 2,        // 4 repeated vertex
                   9, 10, 11,      // 5 NaN
                   4000000000u, 0, 1,  // 6 out of range
                   14, 13, 12};    // 7 ok, reversed winding
    bad.finish();
    // View 1: in range, but degenerate triangles only some of the time: shared buffers.
    TestMesh degenerate_only = grid(3);
    degenerate_only.indices.insert(degenerate_only.indices.end(), {0, 0, 0, 0, 0, 5});
    // View 2: spheres with invalid radii or centre.
    TestSpheres sp;
    sp.xyzr = {0, 0, 5, 0.5f, 1, 0, 5, 0.0f, 2, 0, 5, -1.0f, 3, 0, 5, nan, nan, 0, 5, 1.0f, 4, 0, 5, 0.25f};
    std::vector<GeometryView> views{bad.view(), degenerate_only.view(), sp.view()};

    for (bool count : {false, true}) {
        SCOPED_TRACE(count ? "counting" : "normal");
        auto e = make_embree(views, options(count));
        auto n = naive(views, options(count));
        EXPECT_EQ(n->info().dropped, 5u + 2u + 4u);  // guards this test's own arithmetic
        EXPECT_EQ(e->info().dropped, n->info().dropped);
        EXPECT_EQ(e->info().primitives, n->info().primitives);

        Hit h;
        TraceStats st;
        // Triangles 2 and 7 overlap in x/y, 0.5 apart in z, opposite windings: whichever
        // side the ray comes from decides the id, which must be the view's own index
        // (in normal mode Embree numbers the filtered copy 0..2).
        ASSERT_TRUE(e->intersect(Ray{{3.0f, -0.5f, -1.0f}, {0.0f, 0.0f, 1.0f}}, h, st));
        EXPECT_EQ(h.geom_id, 0u);
        EXPECT_EQ(h.prim_id, 2u);
        EXPECT_NEAR(h.t, 1.0f, 1e-6f);
        EXPECT_GT(h.ng.z, 0.0f);
        ASSERT_TRUE(e->intersect(Ray{{3.0f, -0.5f, 2.0f}, {0.0f, 0.0f, -1.0f}}, h, st));
        EXPECT_EQ(h.prim_id, 7u);
        EXPECT_NEAR(h.t, 1.5f, 1e-6f);
        EXPECT_LT(h.ng.z, 0.0f);
        ASSERT_TRUE(e->intersect(Ray{{0.0f, -0.5f, -1.0f}, {0.0f, 0.0f, 1.0f}}, h, st));
        EXPECT_EQ(h.prim_id, 0u);
        EXPECT_GT(h.ng.z, 0.0f);  // cross(v1-v0, v2-v0) of triangle 0 points to +z
        ASSERT_TRUE(e->intersect(Ray{{4.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 1.0f}}, h, st));
        EXPECT_EQ(h.geom_id, 2u);
        EXPECT_EQ(h.prim_id, 5u);  // the 0.25 sphere, after three dropped ones
        EXPECT_NEAR(h.t, 4.75f, 1e-5f);

        expect_agreement(*e, *n, random_rays(5000, 13), count ? "dropped/count" : "dropped/normal",
                         count ? Tolerance::exact() : Tolerance{});
    }
}

TEST(EmbreeCounting, FewTestsPerRayOnLargeMesh) {
    TestMesh big = tessellated_sphere(100, 200, Vec3f(0.0f), 1.8f);  // 39,800 triangles
    std::vector<GeometryView> views{big.view()};
    auto e = make_embree(views, options(true));
    ASSERT_GE(e->info().primitives, 10000u);
    TraceStats st;
    Hit h;
    uint64_t hits = 0;
    for (const Ray& r : random_rays(4000, 17)) {
        hits += e->intersect(r, h, st);
        e->occluded(r, st);
    }
    const double per_ray = st.tests_per_ray();
    std::printf("[count] %llu triangles: %.2f prim tests/ray over %llu rays (%llu hits)\n",
                (unsigned long long)e->info().primitives, per_ray,
                (unsigned long long)st.total_rays(), (unsigned long long)hits);
    EXPECT_EQ(st.total_rays(), 8000u);
    EXPECT_GT(per_ray, 0.0);
    EXPECT_LT(per_ray, 0.01 * double(e->info().primitives));
}

// Concurrent queries with one TraceStats per thread: same answers as one thread, and
// the per-thread counters sum to the single-thread ones (no shared counting state).
TEST(EmbreeCounting, PerThreadCountsSumToSingleThreadCounts) {
    Scenario s = make_scenario("mixed");
    const auto rays = random_rays(6000, 23);
    for (bool count : {true, false}) {
        SCOPED_TRACE(count ? "counting" : "normal");
        auto e = make_embree(s.views, options(count));
        auto run = [&](size_t begin, size_t end, TraceStats& st, std::vector<Hit>& hits) {
            for (size_t i = begin; i < end; ++i) {
                Hit h;
                if (e->intersect(rays[i], h, st)) hits[i] = h;
                e->occluded(rays[i], st);
            }
        };
        TraceStats single;
        std::vector<Hit> single_hits(rays.size());
        run(0, rays.size(), single, single_hits);

        TraceStats a, b;
        std::vector<Hit> par_hits(rays.size());
        const size_t half = rays.size() / 2;
        std::thread ta([&] { run(0, half, a, par_hits); });
        std::thread tb([&] { run(half, rays.size(), b, par_hits); });
        ta.join();
        tb.join();
        TraceStats sum = a;
        sum += b;
        EXPECT_EQ(sum.rays, single.rays);
        EXPECT_EQ(sum.shadow_rays, single.shadow_rays);
        EXPECT_EQ(sum.prim_tests, single.prim_tests);
        if (count) {
            EXPECT_GT(a.prim_tests, 0u);
            EXPECT_GT(b.prim_tests, 0u);
        }
        int mismatches = 0;
        for (size_t i = 0; i < rays.size(); ++i)
            mismatches += par_hits[i].prim_id != single_hits[i].prim_id ||
                          par_hits[i].geom_id != single_hits[i].geom_id ||
                          par_hits[i].t != single_hits[i].t;
        EXPECT_EQ(mismatches, 0);
    }
}

TEST(EmbreeInfo, BytesAndTimes) {
    TestMesh small = triangle_soup(100, 1);
    TestMesh large = triangle_soup(50000, 2);
    std::vector<GeometryView> vs{small.view()}, vl{large.view()};
    for (bool count : {false, true}) {
        auto es = make_embree(vs, options(count));
        auto el = make_embree(vl, options(count));
        EXPECT_GT(es->info().bytes, 0u);
        // Memory is what Embree allocated during the build (memory monitor callback).
        EXPECT_GT(el->info().bytes, es->info().bytes);
        EXPECT_GT(el->info().bytes, 50000u * 8u) << "a BVH over 50k primitives is not tiny";
        EXPECT_GT(el->info().build_seconds, 0.0);
        std::printf("[%s] 50k soup: %.2f MiB, build %.4f s\n", el->info().backend.c_str(),
                    double(el->info().bytes) / (1024.0 * 1024.0), el->info().build_seconds);
    }
}

TEST(EmbreeScenes, CowAgreesWithNaive) {
    const std::string path = std::string(PT_SHARED_SCENES) + "/cs184/cow.dae";
    if (!std::filesystem::exists(path)) GTEST_SKIP() << "shared scenes not found: " << path;
    scenes::Scene scene;
    try {
        scene = scenes::load_scene(path);
    } catch (const scenes::SceneError& err) {
        if (std::string(err.what()).find("not built yet") != std::string::npos)
            GTEST_SKIP() << err.what();
        throw;
    }
    renderer::SceneGeometry geometry(scene);
    const Bounds3f b = scene.bounds();
    ASSERT_FALSE(b.empty());
    // Rays from around the model toward points inside its box.
    std::mt19937 rng(99);
    std::vector<Ray> rays;
    const Vec3f d = b.diagonal();
    for (int i = 0; i < 3000; ++i) {
        Ray r;
        r.org = random_in_box(rng, b.lo - d, b.hi + d);
        r.dir = random_in_box(rng, b.lo, b.hi) - r.org;
        rays.push_back(r);
    }
    for (bool count : {false, true}) {
        auto e = make_embree(geometry.views(), options(count));
        auto n = naive(geometry.views(), options(count));
        EXPECT_EQ(e->info().dropped, n->info().dropped);
        EXPECT_EQ(e->info().primitives, n->info().primitives);
        auto rep = expect_agreement(*e, *n, rays, count ? "cow/count" : "cow/normal",
                                    count ? Tolerance::exact() : Tolerance{});
        std::printf("[cow %s] %llu prims, %llu hits of %llu rays, %llu ties\n",
                    e->info().backend.c_str(), (unsigned long long)e->info().primitives,
                    (unsigned long long)rep.hits, (unsigned long long)rep.rays,
                    (unsigned long long)rep.ties);
        EXPECT_GT(rep.hits, 0u);
    }
}
