// Plugins (accel/plugin/accel_plugin.h) behind the backend edge: the example plugin
// renders and traces as the built-in backends do, our own BVH through the ABI gives the
// compiled-in BVH's very hits and counters, and every way a plugin can be unusable is
// refused with its path and reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "accel/accelerator.h"
#include "renderer/raysets.h"
#include "renderer/scene_geometry.h"
#include "renderer/xcheck.h"
#include "scenes/load.h"
#include "tests/render/render_world.h"

using namespace renderer;

namespace {

std::string plugin(const std::string& name) { return std::string(PT_BINARY_DIR) + "/plugins/lib" + name + ".so"; }
std::string bad_plugin(const std::string& kind) {
    return std::string(PT_BINARY_DIR) + "/tests/plugins/libbad_plugin_" + kind + ".so";
}
std::string shared_scene(const std::string& rel) { return std::string(PT_SHARED_SCENES) + "/" + rel; }

/// The message of the AccelError that building `backend` over a one-triangle scene throws.
std::string refusal(const std::string& backend) {
    scenes::Scene scene;
    scene.meshes.push_back(quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}));
    SceneGeometry geometry(scene);
    try {
        build_accelerator(backend, geometry, {}, false);
    } catch (const accel::AccelError& e) {
        return e.what();
    }
    return "(accepted)";
}

}  // namespace

// The example plugin renders CBbunny as the custom backend does: same rays, same sample
// streams, hits that differ at most by rounding, so the region means agree far inside
// the statistical tolerance.
TEST(Plugin, ExampleRendersCBbunnyLikeTheCustomBackend) {
    if (!std::filesystem::exists(PT_SHARED_SCENES))
        GTEST_SKIP() << "shared scene corpus not found at " << PT_SHARED_SCENES;
    IntegratorSettings is;
    is.name = "path";
    const std::string scene = shared_scene("cs184/CBbunny.dae");
    Rendered custom = render_file(scene, is, 64, 48, 16, 0, "custom", 7);
    Rendered example = render_file(scene, is, 64, 48, 16, 0, "plugin:" + plugin("accel_plugin_example"), 7);
    expect_same_regions(custom.result.image, example.result.image, 4, 3.0, "example plugin vs custom");
    // Tighter than noise: the same seed gives the same paths up to rounding of hit points.
    auto a = region_means(custom.result.image, 4), b = region_means(example.result.image, 4);
    for (size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k].mean, b[k].mean, 0.01 * a[k].mean) << "region " << k;
    // The plugin's counters reached the statistics.
    EXPECT_GT(example.result.stats.nodes_visited, 0u);
    EXPECT_GT(example.result.stats.prim_tests, 0u);
    EXPECT_EQ(example.result.stats.rays, custom.result.stats.rays);
}

// Our BVH through the ABI is our BVH: every hit and every counter the same as compiled in,
// on every ray kind (the example's batched entry points are traced here too).
TEST(Plugin, OursThroughTheAbiGivesTheCompiledInHitsAndCounters) {
    if (!std::filesystem::exists(PT_SHARED_SCENES))
        GTEST_SKIP() << "shared scene corpus not found at " << PT_SHARED_SCENES;
    const scenes::Scene scene = scenes::load_scene(shared_scene("cs184/cow.dae"));
    SceneGeometry geometry(scene);
    auto custom = build_accelerator("custom", geometry, {}, false);
    auto ours = build_accelerator("plugin:" + plugin("accel_plugin_ours") + ":sah:fast", geometry, {}, false);
    auto example = build_accelerator("plugin:" + plugin("accel_plugin_example"), geometry, {}, false);
    EXPECT_FALSE(ours->has_batches());
    EXPECT_TRUE(example->has_batches());
    EXPECT_NE(ours->info().backend.find("plugin ours 1.0"), std::string::npos) << ours->info().backend;
    EXPECT_EQ(ours->info().nodes, custom->info().nodes);
    for (RayKind kind : kAllRayKinds) {
        RaySetOptions o;
        o.count = 4000;
        const RaySet set = make_ray_set(kind, scene, *custom, o);
        accel::TraceStats sc, so, se;
        const auto rc = trace_set(*custom, set, sc), ro = trace_set(*ours, set, so), re = trace_set(*example, set, se);
        ASSERT_EQ(rc.size(), ro.size());
        size_t same = 0, example_same = 0;
        for (size_t i = 0; i < rc.size(); ++i) {
            same += rc[i].hit == ro[i].hit && rc[i].t == ro[i].t && rc[i].prim == ro[i].prim && rc[i].ng == ro[i].ng;
            example_same += rc[i].hit == re[i].hit;
        }
        EXPECT_EQ(same, rc.size()) << ray_kind_name(kind);
        EXPECT_GE(example_same, rc.size() - rc.size() / 200) << ray_kind_name(kind);
        EXPECT_EQ(so.nodes_visited, sc.nodes_visited) << ray_kind_name(kind);
        EXPECT_EQ(so.prim_tests, sc.prim_tests) << ray_kind_name(kind);
        EXPECT_EQ(se.total_rays(), sc.total_rays()) << ray_kind_name(kind);
        EXPECT_GT(se.nodes_visited, se.total_rays()) << ray_kind_name(kind);
    }
}

TEST(Plugin, OptionsReachThePlugin) {
    EXPECT_NE(refusal("plugin:" + plugin("accel_plugin_example") + ":leaf=0").find("unknown option 'leaf=0'"),
              std::string::npos);
    EXPECT_NE(refusal("plugin:" + plugin("accel_plugin_ours") + ":sah:octree").find("unknown option 'octree'"),
              std::string::npos);
    EXPECT_EQ(refusal("plugin:" + plugin("accel_plugin_example") + ":leaf=2,bins=8"), "(accepted)");
}

// Each unusable plugin is refused before any tracing, naming its path and the reason.
TEST(Plugin, UnusablePluginsAreRefusedWithTheReason) {
    const struct {
        std::string backend, reason;
    } cases[] = {
        {"plugin:/nonexistent/libnothing.so", "plugin /nonexistent/libnothing.so: no such file"},
        {"plugin:" + std::string(PT_SOURCE_DIR) + "/README.md", "cannot be loaded"},
        {"plugin:" + bad_plugin("wrong_abi"), "ABI version 42, but this host speaks version 1"},
        {"plugin:" + bad_plugin("no_entry"), "no entry point 'accel_plugin_entry'"},
        {"plugin:" + bad_plugin("build_fails"), "build failed (error): this plugin refuses every scene"},
    };
    for (const auto& c : cases) {
        const std::string msg = refusal(c.backend);
        EXPECT_NE(msg.find(c.reason), std::string::npos) << c.backend << ": " << msg;
        const std::string path = c.backend.substr(7);
        EXPECT_NE(msg.find(path), std::string::npos) << "names the path: " << msg;
    }
    EXPECT_TRUE(accel::is_backend_name("plugin:x.so"));
    EXPECT_FALSE(accel::is_backend_name("plugin:"));
    EXPECT_FALSE(accel::is_backend_name("octree"));
}

// A plugin's hit naming a primitive that does not exist stops the process (exit 2, one
// line) instead of sending the renderer out of bounds.
TEST(PluginDeathTest, AHitOnANonexistentPrimitiveIsFatal) {
    scenes::Scene scene;
    scene.meshes.push_back(quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}));
    SceneGeometry geometry(scene);
    auto acc = build_accelerator("plugin:" + bad_plugin("wrong_ids"), geometry, {}, false);
    accel::Ray ray;
    ray.org = {0.5f, 0.5f, 1.0f};
    ray.dir = {0, 0, -1};
    accel::Hit hit;
    accel::TraceStats st;
    EXPECT_EXIT(acc->intersect(ray, hit, st), ::testing::ExitedWithCode(2),
                "intersect failed \\(error\\): returned a hit on geometry 7777, primitive 0, which does not exist");
}
