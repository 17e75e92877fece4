// The loader against real files: the course's scenes in ../shared/scenes/cs184 and the
// project's own default scene scenes/cornell.dae.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <string>

#include "scenes/collada/collada.h"

namespace {

using scenes::LightType;
using scenes::Scene;
using scenes::Vec3f;

const std::string kCs184Dir = std::string(PT_SHARED_SCENES) + "/cs184";

#define REQUIRE_SHARED()                                                                 \
    do {                                                                                 \
        if (!std::filesystem::is_directory(kCs184Dir))                                   \
            GTEST_SKIP() << "shared scene folder " << kCs184Dir << " is absent";          \
    } while (0)

size_t count_lights(const Scene& s, LightType t) {
    size_t n = 0;
    for (const auto& l : s.lights) n += l.type == t;
    return n;
}

size_t count_emissive_meshes(const Scene& s) {
    size_t n = 0;
    for (const auto& m : s.meshes) n += s.materials.at(m.material).is_emissive();
    return n;
}

/// Invariants every loaded scene must satisfy, whatever the file.
void check_invariants(const Scene& s, const std::string& what) {
    SCOPED_TRACE(what);
    for (const auto& m : s.meshes) {
        ASSERT_GE(m.positions.size(), 1u) << "positions must carry the padding element";
        EXPECT_EQ(m.positions.back(), Vec3f(0.0f)) << "padding element is zero";
        EXPECT_EQ(m.indices.size() % 3, 0u);
        EXPECT_TRUE(m.uvs.empty()) << "CS184 materials have no textures: no uvs";
        EXPECT_LT(m.material, s.materials.size());
        for (uint32_t i : m.indices) ASSERT_LT(i, m.num_vertices());
        for (uint32_t i = 0; i < m.num_vertices(); ++i)
            ASSERT_TRUE(accel::is_finite(m.positions[i]));
        if (!m.normals.empty()) {
            ASSERT_EQ(m.normals.size(), m.num_vertices());
            for (const auto& n : m.normals) ASSERT_NEAR(accel::length(n), 1.0f, 1e-4f);
        }
    }
    for (const auto& sp : s.spheres) {
        EXPECT_GT(sp.radius, 0.0f);
        EXPECT_LT(sp.material, s.materials.size());
    }
    const auto b = s.bounds();
    ASSERT_FALSE(b.empty());
    EXPECT_TRUE(accel::is_finite(b.lo) && accel::is_finite(b.hi));
    EXPECT_LT(accel::max_component(b.diagonal()), 1e4f);
    EXPECT_GT(accel::max_component(b.diagonal()), 1e-3f);
}

struct Expect {
    uint64_t triangles;
    size_t spheres;
};

// Triangle counts are the sums of the files' polylist counts (all polygons are triangles
// in these exports; fan triangulation is tested on hand-written documents).
const std::map<std::string, Expect> kExpected = {
    {"CBbunny.dae", {28588, 0}},   {"CBempty.dae", {12, 0}}, {"CBgems.dae", {252, 0}},
    {"CBspheres_lambertian.dae", {12, 2}}, {"banana.dae", {2458, 0}},
    {"bunny.dae", {33696, 0}},     {"cow.dae", {5856, 0}},   {"cube.dae", {12, 0}},
    {"maxplanck.dae", {50801, 0}}, {"plane.dae", {2, 0}},    {"teapot.dae", {2464, 0}},
};

TEST(ColladaShared, EveryFileLoadsWithItsFacts) {
    REQUIRE_SHARED();
    size_t seen = 0;
    for (const auto& entry : std::filesystem::directory_iterator(kCs184Dir)) {
        if (entry.path().extension() != ".dae") continue;
        const std::string file = entry.path().filename().string();
        SCOPED_TRACE(file);
        ++seen;
        const auto t0 = std::chrono::steady_clock::now();
        Scene s;
        ASSERT_NO_THROW(s = scenes::load_collada(entry.path().string()));
        const double ms =
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        // Informational only (no threshold): the figures go into the loader's report.
        std::cout << file << ": " << s.num_triangles() << " triangles, " << s.spheres.size()
                  << " spheres, lights (area/point/dir/spot/env) "
                  << count_lights(s, LightType::Area) << "/" << count_lights(s, LightType::Point)
                  << "/" << count_lights(s, LightType::Directional) << "/"
                  << count_lights(s, LightType::Spot) << "/"
                  << count_lights(s, LightType::Environment) << ", "
                  << count_emissive_meshes(s) << " emissive meshes, " << s.materials.size()
                  << " materials, " << s.notes.size() << " notes, " << ms << " ms\n";
        check_invariants(s, file);
        EXPECT_EQ(s.up, Vec3f(0, 0, 1)) << "all course files are Z_UP";
        EXPECT_TRUE(s.camera.has_value());
        // The Cornell boxes use Blender's default 35 mm lens; the head models a longer one.
        const bool narrow = file == "cow.dae" || file == "teapot.dae" || file == "maxplanck.dae";
        EXPECT_NEAR(s.camera->xfov_deg, narrow ? 39.5978f : 49.13434f, 1e-3f);
        EXPECT_EQ(s.source, entry.path().string());
        auto it = kExpected.find(file);
        if (it != kExpected.end()) {
            EXPECT_EQ(s.num_triangles(), it->second.triangles);
            EXPECT_EQ(s.spheres.size(), it->second.spheres);
        }
        // Blender exported normals for every mesh in these files.
        for (const auto& m : s.meshes) EXPECT_FALSE(m.normals.empty()) << m.name;
    }
    EXPECT_EQ(seen, kExpected.size());
}

Scene load_shared(const std::string& file) {
    return scenes::load_collada(kCs184Dir + "/" + file);
}

TEST(ColladaShared, CowIsOneMeshWithWeldedVertices) {
    REQUIRE_SHARED();
    const Scene s = load_shared("cow.dae");
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.num_triangles(), 5856u);
    // A closed-ish mesh shares corners: welding must leave far fewer vertices than corners.
    EXPECT_LT(s.meshes[0].num_vertices(), 5856u * 3 / 2);
    EXPECT_EQ(count_lights(s, LightType::Directional), 1u);
}

TEST(ColladaShared, CBemptyLightIsAPointLight) {
    REQUIRE_SHARED();
    // Unlike the other boxes, CBempty.dae's light has no CGL technique: technique_common
    // describes a point light of intensity 5 (it is named "Area-light" but is not one).
    const Scene s = load_shared("CBempty.dae");
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].type, LightType::Point);
    EXPECT_EQ(s.lights[0].radiance, Vec3f(5, 5, 5));
    EXPECT_NEAR(s.lights[0].position.z, 1.49f, 1e-5f);
    EXPECT_EQ(count_emissive_meshes(s), 1u);
}

TEST(ColladaShared, CBgemsShortCameraMatrixIsRepaired) {
    REQUIRE_SHARED();
    // The file's camera <matrix> has 15 numbers; the camera must still look into the box
    // from (0, 3, 0) like the other boxes' cameras.
    const Scene s = load_shared("CBgems.dae");
    ASSERT_TRUE(s.camera.has_value());
    const auto& m = s.camera->camera_to_world;
    EXPECT_EQ(m.transform_point({0, 0, 0}), Vec3f(0, 3, 0));
    const Vec3f fwd = m.transform_vector({0, 0, -1});
    EXPECT_NEAR(fwd.y, -1.0f, 1e-6f);
    EXPECT_NEAR(m.transform_vector({0, 1, 0}).z, 1.0f, 1e-6f) << "up is the file's Z";
    EXPECT_NEAR(accel::length(accel::cross(m.transform_vector({1, 0, 0}), m.transform_vector({0, 1, 0})) -
                              m.transform_vector({0, 0, 1})),
                0.0f, 1e-6f)
        << "right-handed orthonormal basis";
    bool noted = false;
    for (const auto& n : s.notes) noted |= n.find("Camera") != std::string::npos;
    EXPECT_TRUE(noted);
}

TEST(ColladaShared, CornellBoxesHaveOneAreaLightAndAnEmissivePanel) {
    REQUIRE_SHARED();
    for (const char* f : {"CBspheres_lambertian.dae", "CBgems.dae", "CBbunny.dae"}) {
        SCOPED_TRACE(f);
        const Scene s = load_shared(f);
        EXPECT_EQ(s.lights.size(), 1u);
        EXPECT_EQ(count_lights(s, LightType::Area), 1u) << "CGL area wins over technique_common point";
        EXPECT_EQ(count_emissive_meshes(s), 1u);
        EXPECT_EQ(s.lights[0].radiance, Vec3f(10, 10, 10));
    }
}

TEST(ColladaShared, SpheresLambertianFacts) {
    REQUIRE_SHARED();
    const Scene s = load_shared("CBspheres_lambertian.dae");
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_NEAR(s.spheres[0].radius, 0.3f, 1e-6f);
    EXPECT_NEAR(s.spheres[0].center.x, -0.4f, 1e-6f);
    EXPECT_NEAR(s.spheres[0].center.y, 0.3f, 1e-6f);
    EXPECT_NEAR(s.spheres[0].center.z, 0.3f, 1e-6f);
    EXPECT_NEAR(s.spheres[1].center.x, 0.4f, 1e-6f);
    EXPECT_NE(s.spheres[0].material, s.spheres[1].material);
    EXPECT_EQ(s.materials[s.spheres[1].material].name, "lambertian");
    EXPECT_EQ(s.materials[s.spheres[1].material].albedo, Vec3f(0.8f));
    // Walls: red-ish left (0.6 0.2 0.2) and blue-ish right (0.2 0.2 0.6) in this file.
    bool red = false, blue = false;
    for (const auto& m : s.materials) {
        red |= m.albedo == Vec3f(0.6f, 0.2f, 0.2f);
        blue |= m.albedo == Vec3f(0.2f, 0.2f, 0.6f);
    }
    EXPECT_TRUE(red && blue);
}

TEST(ColladaShared, AreaLightMatchesTheEmissivePanel) {
    REQUIRE_SHARED();
    const Scene s = load_shared("CBspheres_lambertian.dae");
    ASSERT_EQ(s.lights.size(), 1u);
    const auto& l = s.lights[0];
    ASSERT_EQ(l.type, LightType::Area);
    const scenes::Mesh* panel = nullptr;
    for (const auto& m : s.meshes)
        if (s.materials[m.material].is_emissive()) panel = &m;
    ASSERT_NE(panel, nullptr);
    accel::Bounds3f pb;
    for (uint32_t i = 0; i < panel->num_vertices(); ++i) pb.extend(panel->positions[i]);
    // The panel is 0.8 x 0.6 at z ~ 1.49; the light is 0.6 x 0.8 at z = 1.49, centred.
    // The file offsets the panel node by 0.0043 along y (a Blender leftover).
    EXPECT_NEAR(l.position.x, pb.center().x, 1e-2f);
    EXPECT_NEAR(l.position.y, pb.center().y, 1e-2f);
    EXPECT_NEAR(l.position.z, pb.center().z, 1e-2f);
    const float area_light = accel::length(accel::cross(l.edge_u, l.edge_v));
    const Vec3f d = pb.diagonal();
    EXPECT_NEAR(area_light, d.x * d.y, 1e-3f);
    EXPECT_NEAR(accel::length(l.edge_u), 0.6f, 1e-5f);
    EXPECT_NEAR(accel::length(l.edge_v), 0.8f, 1e-5f);
    // Faces down into the box (Z_UP) and the edges span the rectangle orthogonally to it.
    EXPECT_NEAR(l.direction.z, -1.0f, 1e-5f);
    EXPECT_NEAR(accel::dot(l.edge_u, l.direction), 0.0f, 1e-5f);
    EXPECT_NEAR(accel::dot(l.edge_v, l.direction), 0.0f, 1e-5f);
    // The box below it: floor at z = 0, the light inside the box's bounds.
    const auto b = s.bounds();
    EXPECT_LT(l.position.z, b.hi.z + 1e-3f);
    EXPECT_GT(l.position.z, b.lo.z);
}

TEST(ColladaShared, WallNormalsPointIntoTheBox) {
    REQUIRE_SHARED();
    const Scene s = load_shared("CBempty.dae");
    const Vec3f centre = s.bounds().center();
    size_t checked = 0;
    for (const auto& m : s.meshes) {
        ASSERT_FALSE(m.normals.empty());
        for (uint32_t i = 0; i < m.num_vertices(); ++i) {
            EXPECT_GT(accel::dot(m.normals[i], centre - m.positions[i]), 0.0f) << m.name;
            ++checked;
        }
    }
    EXPECT_GE(checked, 20u);
}

TEST(ColladaShared, BananaHasTwoLights) {
    REQUIRE_SHARED();
    const Scene s = load_shared("banana.dae");
    EXPECT_EQ(s.lights.size(), 2u);
    EXPECT_EQ(count_lights(s, LightType::Environment), 1u);
    EXPECT_EQ(count_lights(s, LightType::Directional), 1u);
    for (const auto& l : s.lights) {
        if (l.type == LightType::Directional) {
            EXPECT_NEAR(accel::length(l.direction), 1.0f, 1e-5f);
        }
    }
    EXPECT_NEAR(s.camera->aspect, 1.777778f, 1e-5f);
}

TEST(ColladaShared, GemsAreGlassAndNothingIsReplaced) {
    REQUIRE_SHARED();
    const Scene gems = load_shared("CBgems.dae");
    size_t glass = 0;
    for (const auto& m : gems.materials) {
        EXPECT_TRUE(m.replaced.empty()) << m.name;
        if (m.bsdf != scenes::BsdfKind::Glass) continue;
        ++glass;
        EXPECT_FLOAT_EQ(m.ior, 1.45f) << m.name;
        EXPECT_EQ(m.reflectance, Vec3f(1.0f)) << m.name;
    }
    EXPECT_EQ(glass, 3u);
    for (const auto& n : gems.notes) EXPECT_EQ(n.find("rendered as diffuse"), std::string::npos) << n;

    // bunny.dae defines a CGL mirror effect that no material uses: nothing is replaced.
    const Scene bunny = load_shared("bunny.dae");
    for (const auto& m : bunny.materials) EXPECT_TRUE(m.replaced.empty()) << m.name;
}

TEST(ColladaDefaultScene, CornellDaeLoads) {
    const std::string path = std::string(PT_SOURCE_DIR) + "/scenes/cornell.dae";
    Scene s;
    ASSERT_NO_THROW(s = scenes::load_collada(path));
    check_invariants(s, path);
    EXPECT_GE(s.num_triangles(), 10u);
    EXPECT_EQ(s.spheres.size(), 2u);
    EXPECT_EQ(count_lights(s, LightType::Area), 1u);
    EXPECT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(count_emissive_meshes(s), 1u);
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_NEAR(s.camera->aspect, 4.0f / 3.0f, 1e-4f);
    EXPECT_NEAR(s.camera->xfov_deg, 49.13f, 0.01f);
    EXPECT_TRUE(s.notes.empty()) << s.notes.front();

    // Walls carry normals that point into the box; spheres sit on the floor inside it.
    const auto b = s.bounds();
    const Vec3f centre = b.center();
    for (const auto& m : s.meshes) {
        if (s.materials[m.material].is_emissive()) continue;
        ASSERT_FALSE(m.normals.empty()) << m.name;
        for (uint32_t i = 0; i < m.num_vertices(); ++i)
            EXPECT_GT(accel::dot(m.normals[i], centre - m.positions[i]), 0.0f) << m.name;
    }
    const int up = s.up.z == 1.0f ? 2 : 1;
    for (const auto& sp : s.spheres)
        EXPECT_NEAR(sp.center[up] - sp.radius, b.lo[up], 1e-4f) << "sphere rests on the floor";
    EXPECT_NE(s.materials[s.spheres[0].material].albedo, s.materials[s.spheres[1].material].albedo);

    // The area light faces down (against up) and sits where the emissive panel is.
    const auto& l = s.lights[0];
    EXPECT_NEAR(accel::dot(l.direction, s.up), -1.0f, 1e-5f);
    for (const auto& m : s.meshes)
        if (s.materials[m.material].is_emissive()) {
            accel::Bounds3f pb;
            for (uint32_t i = 0; i < m.num_vertices(); ++i) pb.extend(m.positions[i]);
            EXPECT_LT(accel::length(pb.center() - l.position), 0.02f);
        }
    // The camera looks into the box: level along +y at floor height, like the course's
    // boxes (so the course framing is level too), with the box centre well inside its
    // ~19 degree vertical half field of view.
    const Vec3f eye = s.camera->camera_to_world.transform_point({0, 0, 0});
    const Vec3f fwd = accel::normalize(s.camera->camera_to_world.transform_vector({0, 0, -1}));
    EXPECT_GT(fwd.y, 0.999f);
    EXPECT_GT(accel::dot(fwd, accel::normalize(centre - eye)), std::cos(15.0f * accel::kPi / 180.0f));
}

}  // namespace
