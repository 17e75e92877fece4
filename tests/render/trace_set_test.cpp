// trace_set_into, the timing loops' form of trace_set: it must give trace_set's outcomes
// whatever the array held before, so that reusing one array across timed traces (outside
// the clock, accel_bench's measure()) cannot leak a stale hit into a result or a count.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "renderer/raysets.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "renderer/xcheck.h"
#include "scenes/load.h"

namespace {

bool same(const renderer::RayOutcome& a, const renderer::RayOutcome& b) {
    return a.hit == b.hit && a.t == b.t && a.u == b.u && a.v == b.v && a.geom == b.geom && a.prim == b.prim &&
           a.ng == b.ng && a.inst == b.inst;
}

TEST(TraceSetInto, OverwritesEveryElementOfAReusedArray) {
    scenes::Scene scene = scenes::load_scene(std::string(PT_SOURCE_DIR) + "/scenes/cornell.dae");
    renderer::SceneGeometry geometry(scene);
    auto accel = renderer::build_accelerator("custom", geometry, {}, false);
    renderer::RaySetOptions ro;
    ro.count = 4000;
    size_t hits = 0, misses = 0;
    for (renderer::RayKind kind : {renderer::RayKind::Camera, renderer::RayKind::Shadow, renderer::RayKind::Diffuse}) {
        const renderer::RaySet set = renderer::make_ray_set(kind, scene, *accel, ro);
        accel::TraceStats st;
        const std::vector<renderer::RayOutcome> want = renderer::trace_set(*accel, set, st);
        for (const auto& o : want) (o.hit ? hits : misses)++;

        renderer::RayOutcome junk;
        junk.hit = true, junk.t = 123.0f, junk.u = junk.v = 0.5f, junk.geom = 7, junk.prim = 9;
        junk.ng = accel::Vec3f(1, 2, 3);
        // Same size as the set (the reused case), larger, and smaller.
        for (size_t n : {set.rays.size(), set.rays.size() + 17, set.rays.size() / 3}) {
            std::vector<renderer::RayOutcome> out(n, junk);
            accel::TraceStats st2;
            renderer::trace_set_into(*accel, set, st2, out);
            ASSERT_EQ(out.size(), want.size());
            size_t differ = 0;
            for (size_t i = 0; i < out.size(); ++i) differ += !same(out[i], want[i]);
            EXPECT_EQ(differ, 0u) << renderer::ray_kind_name(kind) << ", array of " << n;
        }
    }
    // Both outcomes occurred, so a stale hit over a miss (or the reverse) would have shown.
    EXPECT_GT(hits, 0u);
    EXPECT_GT(misses, 0u);
}

}  // namespace
