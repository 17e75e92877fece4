// Unit tests for the shared intersectors (accel/triangle.h, accel/sphere.h) and the
// naive backend built on them.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "accel/accelerator.h"
#include "accel/primitive.h"
#include "accel/sphere.h"
#include "accel/triangle.h"

using namespace accel;

namespace {

const Vec3f kV0{0, 0, 0}, kV1{1, 0, 0}, kV2{0, 1, 0};

Ray make_ray(Vec3f o, Vec3f d, float tmin = 0.0f, float tmax = kInfinity) {
    Ray r;
    r.org = o;
    r.dir = d;
    r.t_min = tmin;
    r.t_max = tmax;
    return r;
}

bool hit_mt(const Ray& r, TriangleHit& h, Vec3f a = kV0, Vec3f b = kV1, Vec3f c = kV2) {
    return intersect_triangle_mt(r, a, b, c, r.t_max, h);
}
bool hit_wt(const Ray& r, TriangleHit& h, Vec3f a = kV0, Vec3f b = kV1, Vec3f c = kV2) {
    return intersect_triangle_wt(r, WatertightRay(r.dir), a, b, c, r.t_max, h);
}

}  // namespace

// Both tests must give the same t and barycentrics on clean interior hits.
TEST(Triangle, InteriorHitGivesDistanceAndBarycentrics) {
    Ray r = make_ray({0.25f, 0.5f, 2.0f}, {0, 0, -1});
    TriangleHit a, b;
    ASSERT_TRUE(hit_mt(r, a));
    ASSERT_TRUE(hit_wt(r, b));
    for (const TriangleHit& h : {a, b}) {
        EXPECT_NEAR(h.t, 2.0f, 1e-6f);
        EXPECT_NEAR(h.u, 0.25f, 1e-6f);  // weight of v1 = x
        EXPECT_NEAR(h.v, 0.5f, 1e-6f);   // weight of v2 = y
    }
}

TEST(Triangle, BothWindingsAreHit) {
    Ray r = make_ray({0.2f, 0.2f, -3.0f}, {0, 0, 1});  // from behind
    TriangleHit a, b;
    EXPECT_TRUE(hit_mt(r, a));
    EXPECT_TRUE(hit_wt(r, b));
    EXPECT_NEAR(a.t, 3.0f, 1e-6f);
    EXPECT_NEAR(b.t, 3.0f, 1e-6f);
}

TEST(Triangle, MissesOutsideAndParallel) {
    TriangleHit h;
    EXPECT_FALSE(hit_mt(make_ray({0.8f, 0.8f, 1}, {0, 0, -1}), h));  // beyond the hypotenuse
    EXPECT_FALSE(hit_wt(make_ray({0.8f, 0.8f, 1}, {0, 0, -1}), h));
    EXPECT_FALSE(hit_mt(make_ray({-0.1f, 0.5f, 1}, {0, 0, -1}), h));
    EXPECT_FALSE(hit_wt(make_ray({-0.1f, 0.5f, 1}, {0, 0, -1}), h));
    // In the plane, parallel to it.
    EXPECT_FALSE(hit_mt(make_ray({-1, 0.25f, 0}, {1, 0, 0}), h));
    EXPECT_FALSE(hit_wt(make_ray({-1, 0.25f, 0}, {1, 0, 0}), h));
    // Above the plane, parallel to it.
    EXPECT_FALSE(hit_mt(make_ray({-1, 0.25f, 1}, {1, 0, 0}), h));
    EXPECT_FALSE(hit_wt(make_ray({-1, 0.25f, 1}, {1, 0, 0}), h));
    // Pointing away.
    EXPECT_FALSE(hit_mt(make_ray({0.2f, 0.2f, 1}, {0, 0, 1}), h));
    EXPECT_FALSE(hit_wt(make_ray({0.2f, 0.2f, 1}, {0, 0, 1}), h));
}

TEST(Triangle, RespectsTminAndTmax) {
    TriangleHit h;
    Ray r = make_ray({0.2f, 0.2f, 2}, {0, 0, -1}, 0.0f, 1.999f);
    EXPECT_FALSE(hit_mt(r, h));
    EXPECT_FALSE(hit_wt(r, h));
    r = make_ray({0.2f, 0.2f, 2}, {0, 0, -1}, 2.001f, 10.0f);
    EXPECT_FALSE(hit_mt(r, h));
    EXPECT_FALSE(hit_wt(r, h));
    r = make_ray({0.2f, 0.2f, 2}, {0, 0, -1}, 1.5f, 2.5f);
    EXPECT_TRUE(hit_mt(r, h));
    EXPECT_TRUE(hit_wt(r, h));
}

TEST(Triangle, UnnormalisedDirectionMeasuresTInDirectionUnits) {
    TriangleHit a, b;
    Ray r = make_ray({0.2f, 0.2f, 4}, {0, 0, -2});
    ASSERT_TRUE(hit_mt(r, a));
    ASSERT_TRUE(hit_wt(r, b));
    EXPECT_NEAR(a.t, 2.0f, 1e-6f);
    EXPECT_NEAR(b.t, 2.0f, 1e-6f);
}

TEST(Triangle, WatertightHitsExactEdgesAndVertices) {
    TriangleHit h;
    // Exactly on the edge v0-v1 (y = 0), on the hypotenuse, and on each vertex.
    EXPECT_TRUE(hit_wt(make_ray({0.5f, 0.0f, 1}, {0, 0, -1}), h));
    EXPECT_TRUE(hit_wt(make_ray({0.5f, 0.5f, 1}, {0, 0, -1}), h));
    EXPECT_TRUE(hit_wt(make_ray({0, 0, 1}, {0, 0, -1}), h));
    EXPECT_TRUE(hit_wt(make_ray({1, 0, 1}, {0, 0, -1}), h));
    EXPECT_TRUE(hit_wt(make_ray({0, 1, 1}, {0, 0, -1}), h));
}

// The defining property of Woop 2013: a ray through a shared edge hits at least one of the
// two triangles. Fire many rays at random points of the diagonal of a skewed quad.
TEST(Triangle, WatertightNeverLetsARaySlipThroughASharedEdge) {
    std::mt19937 gen(1234);
    std::uniform_real_distribution<float> U(0.0f, 1.0f);
    const Vec3f a{0.1f, 0.3f, 0.7f}, b{1.3f, 0.2f, 0.9f}, c{1.1f, 1.7f, 0.2f}, d{-0.2f, 1.2f, 0.4f};
    int slipped = 0;
    for (int i = 0; i < 200000; ++i) {
        const float s = U(gen);
        const Vec3f on_edge = a + (c - a) * s;  // shared edge a-c of triangles abc and acd
        const Vec3f org = on_edge + Vec3f(U(gen) - 0.5f, U(gen) - 0.5f, 2.0f + U(gen));
        const Ray r = make_ray(org, on_edge - org);
        TriangleHit h;
        const bool hit = hit_wt(r, h, a, b, c) || hit_wt(r, h, a, c, d);
        slipped += !hit;
    }
    EXPECT_EQ(slipped, 0);
}

TEST(Triangle, NaNInputsNeverHit) {
    const float nan = std::nanf("");
    TriangleHit h;
    EXPECT_FALSE(hit_mt(make_ray({nan, 0.2f, 1}, {0, 0, -1}), h));
    EXPECT_FALSE(hit_wt(make_ray({nan, 0.2f, 1}, {0, 0, -1}), h));
    EXPECT_FALSE(hit_mt(make_ray({0.2f, 0.2f, 1}, {0, nan, -1}), h));
    EXPECT_FALSE(hit_wt(make_ray({0.2f, 0.2f, 1}, {0, nan, -1}), h));
    EXPECT_FALSE(hit_mt(make_ray({0.2f, 0.2f, 1}, {0, 0, -1}), h, {nan, 0, 0}));
    EXPECT_FALSE(hit_wt(make_ray({0.2f, 0.2f, 1}, {0, 0, -1}), h, {nan, 0, 0}));
}

TEST(Triangle, DegenerateDetection) {
    EXPECT_FALSE(triangle_is_degenerate(kV0, kV1, kV2));
    EXPECT_TRUE(triangle_is_degenerate(kV0, kV0, kV2));                  // repeated vertex
    EXPECT_TRUE(triangle_is_degenerate(kV0, {1, 1, 1}, {2, 2, 2}));      // collinear
    EXPECT_TRUE(triangle_is_degenerate(kV0, kV1, {std::nanf(""), 0, 0}));
    EXPECT_TRUE(triangle_is_degenerate(kV0, kV1, {kInfinity, 0, 0}));
    // Tiny but valid: dot(n, n) would underflow here, the test must not call it degenerate.
    const float e = 1e-20f;
    EXPECT_FALSE(triangle_is_degenerate({0, 0, 0}, {e, 0, 0}, {0, e, 0}));
}

TEST(Sphere, HitsNearRootFromOutside) {
    float t;
    ASSERT_TRUE(intersect_sphere(make_ray({0, 0, 5}, {0, 0, -1}), {0, 0, 0}, 1.0f, kInfinity, t));
    EXPECT_NEAR(t, 4.0f, 1e-6f);
}

// Course trap: a sphere test that misses rays starting inside.
TEST(Sphere, RayStartingInsideHitsFarRoot) {
    float t;
    ASSERT_TRUE(intersect_sphere(make_ray({0, 0, 0}, {0, 0, 1}), {0, 0, 0}, 2.0f, kInfinity, t));
    EXPECT_NEAR(t, 2.0f, 1e-6f);
    ASSERT_TRUE(intersect_sphere(make_ray({0.5f, 0.2f, 0.1f}, {0.3f, -0.4f, 0.8f}), {0, 0, 0}, 1.0f,
                                 kInfinity, t));
    const Vec3f p = Vec3f(0.5f, 0.2f, 0.1f) + Vec3f(0.3f, -0.4f, 0.8f) * t;
    EXPECT_NEAR(length(p), 1.0f, 1e-5f);
    EXPECT_GT(t, 0.0f);
}

TEST(Sphere, TminSkipsNearRoot) {
    float t;
    // From outside, t_min beyond the near root: the far root is returned.
    ASSERT_TRUE(intersect_sphere(make_ray({0, 0, 5}, {0, 0, -1}, 4.5f), {0, 0, 0}, 1.0f, kInfinity, t));
    EXPECT_NEAR(t, 6.0f, 1e-6f);
    EXPECT_FALSE(intersect_sphere(make_ray({0, 0, 5}, {0, 0, -1}, 0.0f, 3.9f), {0, 0, 0}, 1.0f, 3.9f, t));
}

TEST(Sphere, MissesAndBehind) {
    float t;
    EXPECT_FALSE(intersect_sphere(make_ray({0, 2, 5}, {0, 0, -1}), {0, 0, 0}, 1.0f, kInfinity, t));
    EXPECT_FALSE(intersect_sphere(make_ray({0, 0, 5}, {0, 0, 1}), {0, 0, 0}, 1.0f, kInfinity, t));
    EXPECT_FALSE(intersect_sphere(make_ray({0, 0, 5}, {0, std::nanf(""), -1}), {0, 0, 0}, 1.0f,
                                  kInfinity, t));
}

// Far from the origin, b^2 - 4ac loses every digit; the stable form must still hit.
TEST(Sphere, StableForSmallSphereFarAway) {
    float t;
    const Vec3f c{0, 0, -1e5f};
    ASSERT_TRUE(intersect_sphere(make_ray({0, 0, 0}, {0, 0, -1}), c, 0.01f, kInfinity, t));
    EXPECT_NEAR(t, 1e5f - 0.01f, 0.02f);
    ASSERT_TRUE(intersect_sphere(make_ray({0.005f, 0, 0}, {0, 0, -1}), c, 0.01f, kInfinity, t));
}

TEST(Sphere, UnnormalisedDirection) {
    float t;
    ASSERT_TRUE(intersect_sphere(make_ray({0, 0, 5}, {0, 0, -4}), {0, 0, 0}, 1.0f, kInfinity, t));
    EXPECT_NEAR(t, 1.0f, 1e-6f);
}

// The naive backend: closest hit over a few primitives, occlusion, degenerate drops, stats.
TEST(Naive, ClosestHitOcclusionAndStats) {
    std::vector<Vec3f> pos = {{-1, -1, 0}, {1, -1, 0}, {0, 1, 0},      // z = 0
                              {-1, -1, -2}, {1, -1, -2}, {0, 1, -2},   // z = -2
                              {0, 0, 0}, {0, 0, 0}};                   // degenerate + padding
    std::vector<uint32_t> idx = {0, 1, 2, 3, 4, 5, 6, 6, 6, 0, 1, 99};  // last: out of range
    std::vector<float> spheres = {0, 0, -5, 1};
    std::vector<GeometryView> views{GeometryView::triangles(pos.data(), 7, idx.data(), 4),
                                    GeometryView::sphere_list(spheres.data(), 1)};
    for (TriangleTest test : {TriangleTest::Fast, TriangleTest::Watertight}) {
        AccelOptions o;
        o.triangle = test;
        auto a = create_accelerator("naive", views, o);
        EXPECT_EQ(a->info().primitives, 3u);
        EXPECT_EQ(a->info().dropped, 2u);
        TraceStats st;
        Hit h;
        ASSERT_TRUE(a->intersect(make_ray({0, 0, 5}, {0, 0, -1}), h, st));
        EXPECT_EQ(h.geom_id, 0u);
        EXPECT_EQ(h.prim_id, 0u);
        EXPECT_NEAR(h.t, 5.0f, 1e-6f);
        EXPECT_GT(h.ng.z, 0.0f);  // counter-clockwise seen from +z
        // Skip the first triangle with t_min: the second one, then the sphere.
        ASSERT_TRUE(a->intersect(make_ray({0, 0, 5}, {0, 0, -1}, 6.0f), h, st));
        EXPECT_EQ(h.prim_id, 1u);
        ASSERT_TRUE(a->intersect(make_ray({0, 0, 5}, {0, 0, -1}, 8.0f), h, st));
        EXPECT_EQ(h.geom_id, 1u);
        EXPECT_NEAR(h.t, 9.0f, 1e-5f);
        EXPECT_NEAR(h.ng.z, 1.0f, 1e-5f);
        EXPECT_TRUE(a->occluded(make_ray({0, 0, 5}, {0, 0, -1}, 0.0f, 6.0f), st));
        EXPECT_FALSE(a->occluded(make_ray({0, 0, 5}, {0, 0, -1}, 0.0f, 4.0f), st));
        EXPECT_FALSE(a->intersect(make_ray({5, 5, 5}, {0, 0, -1}), h, st));
        EXPECT_EQ(st.rays, 4u);
        EXPECT_EQ(st.shadow_rays, 2u);
        EXPECT_EQ(st.nodes_visited, 0u);
        // Every closest-hit query tests all 3 primitives; occlusion stops early.
        EXPECT_GE(st.prim_tests, 4u * 3u + 1u);
        EXPECT_LE(st.prim_tests, 4u * 3u + 2u * 3u);
    }
}

TEST(Factory, UnknownBackendIsAClearError) {
    std::vector<GeometryView> none;
    try {
        create_accelerator("octree", none, {});
        FAIL() << "expected AccelError";
    } catch (const AccelError& e) {
        EXPECT_NE(std::string(e.what()).find("octree"), std::string::npos);
    }
}
