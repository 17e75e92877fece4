// The custom BVH on the shared CS184 meshes (cow, CBbunny, maxplanck): invariants,
// agreement with naive, and primary-ray statistics. Skips, saying why, when
// ../shared/scenes is absent or the COLLADA loader is not built yet.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "accel/accelerator.h"
#include "accel/bvh/bvh.h"
#include "accel/bvh/build.h"
#include "accel/bvh/wide.h"
#include "accel/naive/naive.h"
#include "renderer/camera.h"
#include "renderer/scene_geometry.h"
#include "scenes/load.h"

namespace {

using namespace accel;

struct Loaded {
    scenes::Scene scene;
    std::unique_ptr<renderer::SceneGeometry> geom;
    std::span<const GeometryView> views() const { return geom->views(); }
};

/// Loads ../shared/scenes/cs184/<file>; sets `skip` to the reason when the test cannot
/// run here (missing corpus, loader not built yet).
std::unique_ptr<Loaded> load(const std::string& file, std::string& skip) {
    const std::string path = std::string(PT_SHARED_SCENES) + "/cs184/" + file;
    if (!std::filesystem::exists(path)) {
        skip = path + " not found (the shared scene corpus is not beside this checkout)";
        return nullptr;
    }
    auto l = std::make_unique<Loaded>();
    try {
        l->scene = scenes::load_scene(path);
    } catch (const scenes::SceneError& e) {
        if (std::string(e.what()).find("not built yet") != std::string::npos) {
            skip = e.what();
            return nullptr;
        }
        throw;
    }
    l->geom = std::make_unique<renderer::SceneGeometry>(l->scene);
    return l;
}

#define LOAD_OR_SKIP(var, file)                 \
    std::string skip_##var;                     \
    auto var = load(file, skip_##var);          \
    if (!var) GTEST_SKIP() << skip_##var;

AccelOptions options(BvhSplit split, TriangleTest test) {
    AccelOptions o;
    o.split = split;
    o.triangle = test;
    o.keep_binary_tree = true;  // for inspect_bvh
    return o;
}

/// Primary rays for the course framing at W x H, one per pixel centre.
std::vector<Ray> camera_rays(const scenes::Scene& scene, int w, int h) {
    auto setup = renderer::make_camera(scene, renderer::CameraMode::Auto, w, h);
    std::vector<Ray> rays;
    rays.reserve(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            rays.push_back(setup.camera.generate_ray((x + 0.5f) / w, (y + 0.5f) / h));
    return rays;
}

/// Secondary rays from the primary hits: cosine-weighted diffuse bounces and shadow
/// rays towards a point light above the scene (t_max stops short of the light).
struct Secondary {
    std::vector<Ray> diffuse, shadow;
};
Secondary secondary_rays(const Accelerator& a, const std::vector<Ray>& primary, uint32_t seed) {
    Secondary s;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const Bounds3f bb = a.bounds();
    const float eps = 1e-4f * length(bb.diagonal());
    const Vec3f light = bb.center() + Vec3f(0.1f, 0.45f, 0.05f) * length(bb.diagonal());
    TraceStats st;
    for (const Ray& r : primary) {
        Hit h;
        if (!a.intersect(r, h, st)) continue;
        Vec3f n = normalize(h.ng);
        if (dot(n, r.dir) > 0) n = -n;
        const Vec3f p = r.org + r.dir * h.t + n * eps;
        // Cosine-weighted hemisphere around n (Malley's method).
        const float r1 = u(rng), r2 = u(rng);
        const float rad = std::sqrt(r1), phi = 2.0f * kPi * r2;
        const Vec3f t = normalize(std::abs(n.x) > 0.5f ? cross(n, Vec3f(0, 1, 0)) : cross(n, Vec3f(1, 0, 0)));
        const Vec3f b = cross(n, t);
        const Vec3f d = t * (rad * std::cos(phi)) + b * (rad * std::sin(phi)) + n * std::sqrt(std::max(0.0f, 1 - r1));
        s.diffuse.push_back({p, d, 0.0f, kInfinity});
        const Vec3f to = light - p;
        s.shadow.push_back({p, normalize(to), 0.0f, length(to) * (1 - 1e-4f)});
    }
    return s;
}

class BvhScenes : public ::testing::TestWithParam<const char*> {};

TEST_P(BvhScenes, InvariantsAndSahBeatsMidpoint) {
    LOAD_OR_SKIP(l, GetParam());
    double cost[3];
    for (BvhSplit split : {BvhSplit::Sah, BvhSplit::Midpoint, BvhSplit::Sbvh}) {
        auto a = make_bvh(l->views(), options(split, TriangleTest::Fast));
        auto rep = inspect_bvh(*a);
        ASSERT_TRUE(rep);
        for (const std::string& e : rep->errors) ADD_FAILURE() << e;
        EXPECT_TRUE(rep->ok());
        EXPECT_LE(rep->max_leaf_size, bvh::default_leaf_size(split));
        EXPECT_EQ(rep->leaf_size_limit, split == BvhSplit::Sbvh ? 16u : split == BvhSplit::Sah ? 8u : 4u);
        EXPECT_EQ(rep->primitives, a->info().primitives);
        EXPECT_EQ(a->info().primitives + a->info().dropped, l->scene.num_triangles() + l->scene.spheres.size());
        EXPECT_DOUBLE_EQ(rep->sah_cost, a->info().sah_cost);
        cost[int(split == BvhSplit::Sah ? 0 : split == BvhSplit::Midpoint ? 1 : 2)] = rep->sah_cost;
        EXPECT_LE(double(rep->references), (1.0 + bvh::kSbvhBudget) * double(rep->primitives));
        std::printf("%s %s: %llu prims (%llu dropped), %llu nodes, depth %u, SAH cost %.2f, build %.1f ms\n",
                    GetParam(), a->info().backend.c_str(), (unsigned long long)a->info().primitives,
                    (unsigned long long)a->info().dropped, (unsigned long long)rep->nodes, rep->depth,
                    rep->sah_cost, a->info().build_seconds * 1e3);
    }
    EXPECT_LT(cost[0], cost[1]);
    EXPECT_LE(cost[2], cost[0] * 1.05);  // spatial splits are only taken where the SAH gains
    // The compressed layout (Ylitie et al. 2017) passes the same inspection (every
    // primitive inside every box on its path), and the bytes per triangle traversal reads.
    AccelOptions q = options(BvhSplit::Sah, TriangleTest::Fast);
    q.nodes = NodeLayout::Quantized;
    auto a = make_bvh(l->views(), q);
    auto rep = inspect_bvh(*a);
    ASSERT_TRUE(rep);
    for (const std::string& e : rep->errors) ADD_FAILURE() << e;
    EXPECT_TRUE(rep->ok());
    EXPECT_TRUE(rep->quantized);
    const double tris = double(std::max<uint64_t>(1, rep->primitives));
    std::printf("%s traversal bytes/triangle: float nodes %.1f, quantized %.1f (%llu wide nodes, %llu blocks)\n",
                GetParam(), double(rep->wide_nodes * sizeof(bvh::WideNode) + rep->blocks * sizeof(bvh::Block)) / tris,
                double(rep->wide_nodes * sizeof(bvh::QuantNode) + rep->blocks * sizeof(bvh::Block)) / tris,
                (unsigned long long)rep->wide_nodes, (unsigned long long)rep->blocks);
}

TEST_P(BvhScenes, AgreesWithNaive) {
    LOAD_OR_SKIP(l, GetParam());
    auto primary = camera_rays(l->scene, 32, 24);
    for (TriangleTest test : {TriangleTest::Fast, TriangleTest::Watertight}) {
        auto naive = make_naive(l->views(), options(BvhSplit::Sah, test));
        auto sec = secondary_rays(*naive, primary, 7);
        std::vector<Ray> rays = primary;
        rays.insert(rays.end(), sec.diffuse.begin(), sec.diffuse.end());
        rays.insert(rays.end(), sec.shadow.begin(), sec.shadow.end());
        // The reference is slow (every primitive per ray): trace it once per test.
        std::vector<Hit> ref(rays.size());
        std::vector<char> ref_hit(rays.size());
        TraceStats s1;
        for (size_t i = 0; i < rays.size(); ++i) ref_hit[i] = naive->intersect(rays[i], ref[i], s1);
        for (BvhSplit split : {BvhSplit::Sah, BvhSplit::Midpoint, BvhSplit::Sbvh})
          for (Isa isa : supported_isas()) {  // every kernel this CPU runs (bvh_test names the rest)
            AccelOptions o = options(split, test);
            o.isa = isa;
            auto bvh = make_bvh(l->views(), o);
            SCOPED_TRACE(isa_name(isa));
            int mismatch = 0, ties = 0, hits = 0;
            TraceStats s2;
            for (size_t i = 0; i < rays.size(); ++i) {
                const Ray& r = rays[i];
                const Hit& a = ref[i];
                Hit b;
                const bool ha = ref_hit[i], hb = bvh->intersect(r, b, s2);
                const bool ob = bvh->occluded(r, s2);
                if (ha != hb || hb != ob) {
                    ++mismatch;
                    continue;
                }
                if (!ha) continue;
                ++hits;
                if (a.geom_id == b.geom_id && a.prim_id == b.prim_id) {
                    if (std::memcmp(&a.t, &b.t, 4) || a.u != b.u || a.v != b.v) ++mismatch;
                } else if (std::abs(a.t - b.t) <= 1e-5f * std::max(1.0f, std::abs(a.t))) {
                    ++ties;  // two primitives at the same distance (shared edge/vertex)
                } else {
                    ++mismatch;
                }
            }
            EXPECT_EQ(mismatch, 0) << bvh->info().backend;
            EXPECT_GT(hits, int(rays.size() / 10));
            EXPECT_LT(ties, int(rays.size() / 100) + 2);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Cs184, BvhScenes,
                         ::testing::Values("cow.dae", "CBbunny.dae", "maxplanck.dae"),
                         [](const auto& info) {
                             std::string n = info.param;
                             return n.substr(0, n.find('.'));
                         });

TEST(BvhScenesStats, CowPrimaryRaysTestsPerRay) {
    LOAD_OR_SKIP(l, "cow.dae");
    auto a = make_bvh(l->views(), options(BvhSplit::Sah, TriangleTest::Fast));
    TraceStats s;
    uint64_t hits = 0;
    for (const Ray& r : camera_rays(l->scene, 800, 600)) {
        Hit h;
        hits += a->intersect(r, h, s);
    }
    std::printf("cow 800x600 primary: %.3f tests/ray, %.2f nodes/ray, %.1f%% hit\n",
                s.tests_per_ray(), s.nodes_per_ray(), 100.0 * double(hits) / double(s.rays));
    EXPECT_EQ(s.rays, 800u * 600u);
    EXPECT_GT(hits, 0u);
    // The project's target for this tree (a property of the tree, not of timing).
    EXPECT_LE(s.tests_per_ray(), 3.4);
}

/// Not a test: single-thread rays/s for the three scenes (run with
/// --gtest_also_run_disabled_tests --gtest_filter='*Speed*').
TEST(BvhScenesStats, DISABLED_Speed) {
    for (const char* file : {"cow.dae", "CBbunny.dae", "maxplanck.dae"}) {
        std::string skip;
        auto l = load(file, skip);
        if (!l) GTEST_SKIP() << skip;
        for (BvhSplit split : {BvhSplit::Sah, BvhSplit::Midpoint})
            for (TriangleTest test : {TriangleTest::Fast, TriangleTest::Watertight}) {
                auto a = make_bvh(l->views(), options(split, test));
                auto primary = camera_rays(l->scene, 800, 600);
                auto sec = secondary_rays(*a, primary, 3);
                auto run = [&](const std::vector<Ray>& rays, bool shadow) {
                    TraceStats s;
                    uint64_t hits = 0;
                    auto t0 = std::chrono::steady_clock::now();
                    for (int rep = 0; rep < 3; ++rep)
                        for (const Ray& r : rays) {
                            Hit h;
                            hits += shadow ? a->occluded(r, s) : a->intersect(r, h, s);
                        }
                    double sec_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
                    std::printf("  %-10s %7.2f Mrays/s  %5.2f tests/ray %6.2f nodes/ray\n",
                                shadow ? "shadow" : (&rays == &primary ? "primary" : "diffuse"),
                                double(s.total_rays()) / sec_ * 1e-6, s.tests_per_ray(), s.nodes_per_ray());
                    return hits;
                };
                std::printf("%s %s (build %.1f ms, SAH %.2f)\n", file, a->info().backend.c_str(),
                            a->info().build_seconds * 1e3, a->info().sah_cost);
                run(primary, false);
                run(sec.shadow, true);
                run(sec.diffuse, false);
            }
    }
}

}  // namespace
