// Ray records (renderer/ray_record.h): the recorder keeps the first rays of each kind and
// traces them as its backend does; a record reads back as written, and a damaged file or
// another scene's record is refused with the file's name.
#include <gtest/gtest.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "renderer/ray_record.h"
#include "renderer/raysets.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "renderer/xcheck.h"
#include "scenes/load.h"

namespace {

using renderer::RayKind;

struct Cornell {
    scenes::Scene scene = scenes::load_scene(std::string(PT_SOURCE_DIR) + "/scenes/cornell.dae");
    renderer::SceneGeometry geometry{scene};
    std::unique_ptr<accel::Accelerator> accel = renderer::build_accelerator("custom", geometry, {}, false);
};

bool same_ray(const accel::Ray& a, const accel::Ray& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

std::string temp_path(const char* name) { return ::testing::TempDir() + name; }

TEST(RayRecord, TheRecorderKeepsTheFirstRaysOfEachKindAndTracesAsItsBackend) {
    Cornell c;
    renderer::RaySetOptions ro;
    ro.count = 3000;
    const renderer::RaySet cam = renderer::make_ray_set(RayKind::Camera, c.scene, *c.accel, ro);
    const renderer::RaySet shadow = renderer::make_ray_set(RayKind::Shadow, c.scene, *c.accel, ro);
    renderer::RayRecorder rec(*c.accel, 1000);
    // From several threads: the cap counts them all.
    tbb::parallel_for(size_t(0), cam.rays.size(), [&](size_t i) {
        accel::TraceStats st_rec, st_ref;
        accel::Hit h_rec, h_ref;
        const bool a = rec.intersect(cam.rays[i], h_rec, st_rec);
        const bool b = c.accel->intersect(cam.rays[i], h_ref, st_ref);
        EXPECT_EQ(a, b);
        if (a && b) {
            EXPECT_EQ(h_rec.t, h_ref.t);
        }
        EXPECT_EQ(rec.occluded(shadow.rays[i], st_rec), c.accel->occluded(shadow.rays[i], st_ref));
        EXPECT_EQ(st_rec.prim_tests, st_ref.prim_tests);
    });
    const renderer::RayRecord r = rec.record(renderer::scene_primitives(c.scene));
    EXPECT_EQ(r.closest.size(), 1000u);
    EXPECT_EQ(r.any_hit.size(), 1000u);
    EXPECT_EQ(r.scene_primitives, c.scene.world_triangles() + c.scene.spheres.size());  // two spheres
    // Every kept ray is one that was traced, of its own kind.
    for (const accel::Ray& ray : r.closest)
        EXPECT_TRUE(std::any_of(cam.rays.begin(), cam.rays.end(), [&](const accel::Ray& x) { return same_ray(x, ray); }));
    for (const accel::Ray& ray : r.any_hit)
        EXPECT_TRUE(
            std::any_of(shadow.rays.begin(), shadow.rays.end(), [&](const accel::Ray& x) { return same_ray(x, ray); }));
}

TEST(RayRecord, ReadsBackAsWrittenAndFeedsTheRenderKinds) {
    Cornell c;
    renderer::RaySetOptions ro;
    ro.count = 500;
    renderer::RayRecord r;
    r.scene_primitives = renderer::scene_primitives(c.scene);
    r.closest = renderer::make_ray_set(RayKind::Diffuse, c.scene, *c.accel, ro).rays;
    r.any_hit = renderer::make_ray_set(RayKind::Shadow, c.scene, *c.accel, ro).rays;
    r.any_hit.resize(321);
    const std::string path = temp_path("round_trip.rays");
    renderer::write_ray_record(path, r);
    const renderer::RayRecord back = renderer::read_ray_record_for(path, c.scene);
    ASSERT_EQ(back.closest.size(), r.closest.size());
    ASSERT_EQ(back.any_hit.size(), r.any_hit.size());
    for (size_t i = 0; i < r.closest.size(); ++i) EXPECT_TRUE(same_ray(back.closest[i], r.closest[i]));
    for (size_t i = 0; i < r.any_hit.size(); ++i) EXPECT_TRUE(same_ray(back.any_hit[i], r.any_hit[i]));

    // The render kinds take the first `count` of their rays, and shadow rays are any-hit.
    ro.record = &back;
    ro.count = 400;
    const renderer::RaySet closest = renderer::make_ray_set(RayKind::RenderClosest, c.scene, *c.accel, ro);
    const renderer::RaySet any = renderer::make_ray_set(RayKind::RenderShadow, c.scene, *c.accel, ro);
    EXPECT_EQ(closest.rays.size(), 400u);
    EXPECT_EQ(any.rays.size(), 321u);
    EXPECT_FALSE(closest.occlusion());
    EXPECT_TRUE(any.occlusion());
    EXPECT_TRUE(same_ray(closest.rays[399], r.closest[399]));
    RayKind k;
    ASSERT_TRUE(renderer::parse_ray_kind("render-shadow", k));
    EXPECT_EQ(k, RayKind::RenderShadow);
    // Without a record they cannot be made.
    ro.record = nullptr;
    EXPECT_THROW(renderer::make_ray_set(RayKind::RenderClosest, c.scene, *c.accel, ro), std::invalid_argument);
    std::remove(path.c_str());
}

/// The message read_ray_record_for throws for `path`, or "" if it reads.
std::string refusal(const std::string& path, const scenes::Scene& scene) {
    try {
        renderer::read_ray_record_for(path, scene);
    } catch (const std::invalid_argument& e) {
        return e.what();
    }
    return "";
}

TEST(RayRecord, DamagedFilesAndOtherScenesAreRefusedByName) {
    Cornell c;
    renderer::RayRecord r;
    r.scene_primitives = renderer::scene_primitives(c.scene);
    r.closest.assign(10, accel::Ray{{0, 0, 0}, {0, 0, 1}, 0.0f, accel::kInfinity});
    r.any_hit.assign(4, accel::Ray{{0, 1, 0}, {0, 0, 1}, 0.0f, 1.0f});
    const std::string good = temp_path("good.rays");
    renderer::write_ray_record(good, r);
    ASSERT_EQ(refusal(good, c.scene), "");

    std::ifstream in(good, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto write = [](const std::string& p, const std::string& b) { std::ofstream(p, std::ios::binary) << b; };

    const std::string cut = temp_path("cut.rays");
    write(cut, bytes.substr(0, bytes.size() - 5));
    EXPECT_NE(refusal(cut, c.scene).find("cut.rays"), std::string::npos);
    EXPECT_NE(refusal(cut, c.scene).find("header counts 10 + 4"), std::string::npos);

    const std::string text = temp_path("text.rays");
    write(text, "hello, not rays at all, but long enough for a header of forty bytes");
    EXPECT_NE(refusal(text, c.scene).find("not a ray record"), std::string::npos);

    // A non-finite origin: what no render traces.
    renderer::RayRecord bad = r;
    bad.any_hit[2].org.y = std::numeric_limits<float>::quiet_NaN();
    const std::string nan = temp_path("nan.rays");
    renderer::write_ray_record(nan, bad);
    EXPECT_NE(refusal(nan, c.scene).find("any-hit ray 2 is not finite"), std::string::npos);

    // Another scene's rays.
    renderer::RayRecord other = r;
    other.scene_primitives += 1;
    const std::string elsewhere = temp_path("elsewhere.rays");
    renderer::write_ray_record(elsewhere, other);
    EXPECT_NE(refusal(elsewhere, c.scene).find("recorded in a scene of"), std::string::npos);

    EXPECT_NE(refusal(temp_path("absent.rays"), c.scene).find("cannot open"), std::string::npos);
    for (const std::string& p : {good, cut, text, nan, elsewhere}) std::remove(p.c_str());
}

}  // namespace
