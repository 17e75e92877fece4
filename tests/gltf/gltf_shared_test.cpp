// The three shared glTF sample models (../shared/scenes/gltf): counts are recomputed from
// each file's own JSON/accessors where practical, not copied from the loader.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>

#include "scenes/gltf/gltf.h"

namespace {

std::string shared(const std::string& rel) { return std::string(PT_SHARED_SCENES) + "/gltf/" + rel; }

#define REQUIRE_SHARED(rel)                                                                   \
    do {                                                                                      \
        if (!std::filesystem::exists(shared(rel)))                                            \
            GTEST_SKIP() << "shared scene folder " << PT_SHARED_SCENES                        \
                         << "/gltf not available (" << rel << ")";                            \
    } while (0)

/// Width/height from a PNG's IHDR, read independently of the loader.
std::pair<uint32_t, uint32_t> png_size(const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    unsigned char h[24] = {};
    f.read(reinterpret_cast<char*>(h), 24);
    auto be = [&](int o) { return (uint32_t(h[o]) << 24) | (uint32_t(h[o + 1]) << 16) | (uint32_t(h[o + 2]) << 8) | h[o + 3]; };
    return {be(16), be(20)};
}

bool has_note(const scenes::Scene& s, const std::string& needle) {
    for (const std::string& n : s.notes)
        if (n.find(needle) != std::string::npos) return true;
    return false;
}

/// Invariants every loaded mesh must satisfy (padding, index range, unit normals).
void check_meshes(const scenes::Scene& s) {
    for (const scenes::Mesh& m : s.meshes) {
        ASSERT_GE(m.positions.size(), 1u) << m.name;
        EXPECT_EQ(m.positions.back(), (scenes::Vec3f{0, 0, 0})) << m.name << ": padding element";
        EXPECT_EQ(m.indices.size() % 3, 0u);
        for (uint32_t i : m.indices) ASSERT_LT(i, m.num_vertices()) << m.name;
        if (!m.normals.empty()) {
            ASSERT_EQ(m.normals.size(), m.num_vertices());
            for (const auto& n : m.normals) ASSERT_NEAR(accel::length(n), 1.0f, 1e-4f);
        }
        if (!m.uvs.empty()) {
            ASSERT_EQ(m.uvs.size(), m.num_vertices());
        }
        ASSERT_LT(m.material, s.materials.size());
        for (uint32_t i = 0; i < m.num_vertices(); ++i) ASSERT_TRUE(accel::is_finite(m.positions[i]));
    }
}

TEST(GltfShared, Suzanne) {
    REQUIRE_SHARED("Suzanne/Suzanne.gltf");
    scenes::Scene s = scenes::load_gltf(shared("Suzanne/Suzanne.gltf"));
    EXPECT_EQ(s.format, scenes::SceneFormat::Gltf);
    EXPECT_EQ(s.up, (scenes::Vec3f{0, 1, 0}));
    // One primitive, indices accessor count 11808 -> 3936 triangles, 11808 vertices.
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.num_triangles(), 11808u / 3);
    EXPECT_EQ(s.meshes[0].num_vertices(), 11808u);
    EXPECT_FALSE(s.meshes[0].normals.empty());
    EXPECT_FALSE(s.meshes[0].uvs.empty()) << "base colour texture needs uvs";
    check_meshes(s);
    ASSERT_EQ(s.materials.size(), 1u);
    const scenes::Material& m = s.materials[0];
    EXPECT_EQ(m.name, "Suzanne");
    ASSERT_NE(m.albedo_texture, scenes::kNoTexture);
    EXPECT_EQ(m.emission_texture, scenes::kNoTexture);
    EXPECT_EQ(m.bsdf, scenes::BsdfKind::MetallicRoughness) << "default metallicFactor is 1";
    EXPECT_TRUE(m.replaced.empty());
    // The base colour and the metallic-roughness images are decoded.
    ASSERT_EQ(s.textures.size(), 2u);
    ASSERT_NE(m.metallic_roughness_texture, scenes::kNoTexture);
    const scenes::Texture& t = s.textures[m.albedo_texture];
    auto [w, h] = png_size(shared("Suzanne/Suzanne_BaseColor.png"));
    EXPECT_EQ(t.width, w);
    EXPECT_EQ(t.height, h);
    EXPECT_EQ(t.format, scenes::TexelFormat::U8) << "8-bit PNG stays 8-bit";
    EXPECT_TRUE(t.srgb);
    ASSERT_FALSE(t.levels.empty());
    EXPECT_EQ(t.levels.back().width, 1u);
    EXPECT_EQ(t.levels.back().height, 1u);
    const scenes::Texture& mr = s.textures[m.metallic_roughness_texture];
    EXPECT_EQ(mr.channels, 2) << "metallic-roughness keeps G and B only";
    EXPECT_FALSE(mr.srgb);
    EXPECT_TRUE(s.lights.empty());
    EXPECT_FALSE(s.camera.has_value());
    EXPECT_FALSE(has_note(s, "metallic-roughness")) << "modelled, not ignored";
}

TEST(GltfShared, DamagedHelmet) {
    REQUIRE_SHARED("DamagedHelmet.glb");
    scenes::Scene s = scenes::load_gltf(shared("DamagedHelmet.glb"));
    // 46,356 is the INDEX count; that is 15,452 triangles over 14,556 vertices.
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.num_triangles(), 46356u / 3);
    EXPECT_EQ(s.meshes[0].num_vertices(), 14556u);
    EXPECT_FALSE(s.meshes[0].normals.empty());
    EXPECT_FALSE(s.meshes[0].uvs.empty());
    check_meshes(s);
    ASSERT_EQ(s.materials.size(), 1u);
    const scenes::Material& m = s.materials[0];
    EXPECT_TRUE(m.is_emissive());
    ASSERT_NE(m.albedo_texture, scenes::kNoTexture);
    ASSERT_NE(m.emission_texture, scenes::kNoTexture);
    EXPECT_EQ(m.bsdf, scenes::BsdfKind::MetallicRoughness);
    EXPECT_NE(m.metallic_roughness_texture, scenes::kNoTexture);
    EXPECT_NE(m.normal_texture, scenes::kNoTexture);
    EXPECT_EQ(s.textures.size(), 4u) << "base colour, emissive, metallic-roughness, normal; occlusion not decoded";
    for (const auto& t : s.textures) {
        EXPECT_EQ(t.width, 2048u);
        EXPECT_EQ(t.height, 2048u);
        EXPECT_EQ(t.format, scenes::TexelFormat::U8);
        EXPECT_EQ(t.levels.size(), 12u) << "2048 down to 1";
    }
    EXPECT_EQ(s.textures[m.metallic_roughness_texture].channels, 2);
    EXPECT_EQ(s.textures[m.normal_texture].channels, 2) << "normal XY";
    EXPECT_GE(s.textures[m.emission_texture].channels, 3);
    EXPECT_TRUE(s.textures[m.emission_texture].srgb);
    // The node rotates +90 deg about X, (x,y,z) -> (x,-z,y). POSITION accessor bounds in
    // the file: min (-0.94746, -1.18716, -0.90099), max (0.94250, 0.81285, 0.90097).
    scenes::Bounds3f b = s.bounds();
    EXPECT_NEAR(b.lo.x, -0.94746f, 1e-4f);
    EXPECT_NEAR(b.hi.x, 0.94250f, 1e-4f);
    EXPECT_NEAR(b.lo.y, -0.90097f, 1e-4f);
    EXPECT_NEAR(b.hi.y, 0.90099f, 1e-4f);
    EXPECT_NEAR(b.lo.z, -1.18716f, 1e-4f);
    EXPECT_NEAR(b.hi.z, 0.81285f, 1e-4f);
    EXPECT_TRUE(s.lights.empty());
    EXPECT_FALSE(s.camera.has_value());
}

TEST(GltfShared, BoomBoxMissingUnneededTexture) {
    REQUIRE_SHARED("BoomBox/BoomBox.gltf");
    scenes::Scene s = scenes::load_gltf(shared("BoomBox/BoomBox.gltf"));
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.num_triangles(), 18108u / 3);
    EXPECT_EQ(s.meshes[0].num_vertices(), 3575u);
    check_meshes(s);
    EXPECT_TRUE(has_note(s, "BoomBox_occlusionRoughnessMetallic.png")) << "missing texture must be named";
    ASSERT_EQ(s.materials.size(), 1u);
    const scenes::Material& m = s.materials[0];
    ASSERT_NE(m.albedo_texture, scenes::kNoTexture);
    ASSERT_NE(m.emission_texture, scenes::kNoTexture);
    EXPECT_EQ(m.metallic_roughness_texture, scenes::kNoTexture) << "its image is missing: factors alone";
    EXPECT_NE(m.normal_texture, scenes::kNoTexture);
    EXPECT_EQ(s.textures.size(), 3u);
    auto [bw, bh] = png_size(shared("BoomBox/BoomBox_baseColor.png"));
    auto [ew, eh] = png_size(shared("BoomBox/BoomBox_emissive.png"));
    EXPECT_EQ(s.textures[m.albedo_texture].width, bw);
    EXPECT_EQ(s.textures[m.albedo_texture].height, bh);
    EXPECT_EQ(s.textures[m.emission_texture].width, ew);
    EXPECT_EQ(s.textures[m.emission_texture].height, eh);
    EXPECT_FALSE(s.meshes[0].uvs.empty());
    // The occlusion map is reported as ignored, not decoded.
    EXPECT_TRUE(has_note(s, "occlusionTexture"));
}

}  // namespace
