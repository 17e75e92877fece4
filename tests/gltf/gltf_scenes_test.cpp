// The project's own glTF scenes (scenes/*.gltf, written by scenes/make_gltf_scenes.py)
// load with the lights they were made for, and every saved fuzzer finding replays
// without crashing.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "scenes/gltf/gltf.h"

namespace {

using scenes::LightType;
using scenes::Scene;

std::string project(const std::string& rel) { return std::string(PT_SOURCE_DIR) + "/scenes/" + rel; }

int emissive_materials_in_use(const Scene& s) {
    std::vector<bool> used(s.materials.size(), false);
    for (const auto& m : s.meshes) used[m.material] = true;
    int n = 0;
    for (size_t i = 0; i < s.materials.size(); ++i) n += used[i] && s.materials[i].is_emissive();
    return n;
}

void expect_clean(const Scene& s) {
    EXPECT_EQ(s.format, scenes::SceneFormat::Gltf);
    ASSERT_TRUE(s.camera.has_value());
    for (const auto& m : s.materials) EXPECT_TRUE(m.replaced.empty()) << m.name << ": project scenes are diffuse";
    for (const auto& m : s.meshes) {
        EXPECT_EQ(m.normals.size(), m.num_vertices()) << m.name;
        EXPECT_TRUE(m.uvs.empty()) << m.name << ": no textures, so no uvs";
    }
}

TEST(GltfProjectScenes, CornellEmissive) {
    Scene s = scenes::load_gltf(project("cornell_emissive.gltf"));
    expect_clean(s);
    EXPECT_TRUE(s.lights.empty()) << "the only light is the emissive panel";
    EXPECT_EQ(emissive_materials_in_use(s), 1);
    EXPECT_EQ(s.num_triangles(), 5u * 2 + 2 + 2u * 12);  // walls, panel, two blocks
    scenes::Bounds3f b = s.bounds();
    EXPECT_FLOAT_EQ(b.lo.y, 0.0f);
    EXPECT_FLOAT_EQ(b.hi.y, 2.0f);
    // Camera in front of the open side, looking down -Z into the box.
    EXPECT_NEAR(s.camera->camera_to_world.m[2][3], 3.9f, 1e-5f);
    EXPECT_NEAR(s.camera->camera_to_world.m[2][2], 1.0f, 1e-5f);  // local +Z = world +Z
    for (const auto& m : s.materials)
        if (m.is_emissive()) {
            EXPECT_NEAR(m.emission.x, 17.0f, 1e-4f);  // emissiveFactor x emissiveStrength
        }
}

struct LightCase {
    const char* file;
    int lights;
    LightType type;
    int emissive;
};

class GltfLightScenes : public ::testing::TestWithParam<LightCase> {};

TEST_P(GltfLightScenes, LoadsWithItsLight) {
    const LightCase& c = GetParam();
    Scene s = scenes::load_gltf(project(std::string("lights/") + c.file));
    expect_clean(s);
    ASSERT_EQ(int(s.lights.size()), c.lights);
    EXPECT_EQ(emissive_materials_in_use(s), c.emissive);
    if (c.lights == 1) {
        const scenes::Light& l = s.lights[0];
        EXPECT_EQ(l.type, c.type);
        EXPECT_GT(l.radiance.x, 0.0f);
        if (l.type == LightType::Directional || l.type == LightType::Spot) {
            EXPECT_NEAR(accel::length(l.direction), 1.0f, 1e-5f);
            EXPECT_LT(l.direction.y, 0.0f) << "shines down onto the floor";
        }
        if (l.type == LightType::Spot) {
            EXPECT_NEAR(l.spot_cos_inner, std::cos(0.3f), 1e-6f);
            EXPECT_NEAR(l.spot_cos_outer, std::cos(0.5f), 1e-6f);
        }
        if (l.type == LightType::Point || l.type == LightType::Spot) {
            EXPECT_GT(l.position.y, 1.0f);
        }
    }
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, GltfLightScenes,
    ::testing::Values(LightCase{"point.gltf", 1, LightType::Point, 0},
                      LightCase{"directional.gltf", 1, LightType::Directional, 0},
                      LightCase{"spot.gltf", 1, LightType::Spot, 0},
                      LightCase{"emissive.gltf", 0, LightType::Point, 1},
                      LightCase{"environment.gltf", 0, LightType::Point, 0}),
    [](const ::testing::TestParamInfo<LightCase>& i) {
        std::string n = i.param.file;
        return n.substr(0, n.find('.'));
    });

/// Same three ways as tests/fuzz/gltf_fuzz.cpp: JSON, raw GLB, JSON wrapped in a GLB.
void replay(const std::vector<uint8_t>& data) {
    const char* dir = "/nonexistent-gltf-fuzz-dir";
    for (bool binary : {false, true}) {
        try {
            scenes::load_gltf_memory(data.data(), data.size(), "fuzz", dir, binary);
        } catch (const scenes::SceneError&) {
        }
    }
    size_t padded = (data.size() + 3) & ~size_t(3);
    std::vector<uint8_t> glb = {'g', 'l', 'T', 'F'};
    for (uint32_t v : {2u, uint32_t(20 + padded), uint32_t(padded), 0x4E4F534Au})
        for (int i = 0; i < 4; ++i) glb.push_back(uint8_t(v >> (8 * i)));
    glb.insert(glb.end(), data.begin(), data.end());
    glb.resize(20 + padded, ' ');
    if (!data.empty()) {
        try {
            scenes::load_gltf_memory(glb.data(), glb.size(), "fuzz", dir, true);
        } catch (const scenes::SceneError&) {
        }
    }
}

TEST(GltfFuzzRegressions, ReplayAll) {
    std::filesystem::path dir = std::string(PT_SOURCE_DIR) + "/tests/fuzz/regressions/gltf";
    int n = 0;
    if (std::filesystem::is_directory(dir))
        for (const auto& e : std::filesystem::directory_iterator(dir)) {
            if (!e.is_regular_file() || e.path().filename().string().front() == '.') continue;
            std::ifstream f(e.path(), std::ios::binary);
            std::vector<uint8_t> data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
            SCOPED_TRACE(e.path().filename().string());
            EXPECT_NO_THROW(replay(data));
            ++n;
        }
    RecordProperty("replayed", n);
}

}  // namespace
