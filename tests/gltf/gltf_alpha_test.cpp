// glTF 2.0 alphaMode and alphaCutoff (spec section 3.9.4) on a small file made here
// (tests/gltf/data/make_alpha.py writes alpha_quads.gltf: five quads in y = 0, one per
// material, OPAQUE / MASK / MASK with a cutoff and a factor / BLEND / MASK over a fully
// opaque texture). The loader reads the modes, cutoffs and alpha factors and keeps the
// base colour texture's alpha only where it can matter; the renderer's geometry masks
// just the meshes whose alpha can cut, and traces them as the modes say.
#include <gtest/gtest.h>


#include "accel/accelerator.h"
#include "renderer/scene_geometry.h"
#include "scenes/gltf/gltf.h"
#include "scenes/load.h"
#include "tests/gltf/gltf_text.h"

namespace {

const std::string kFile = std::string(PT_SOURCE_DIR) + "/tests/gltf/data/alpha_quads.gltf";

std::string file_text() { return gltf_text::read(kFile); }

scenes::Scene load_text(const std::string& text) { return gltf_text::load(text, "alpha_quads.gltf"); }

const scenes::Material& material(const scenes::Scene& s, const std::string& name) {
    for (const scenes::Material& m : s.materials)
        if (m.name == name) return m;
    ADD_FAILURE() << "no material " << name;
    return s.materials.front();
}

/// Mesh k's material, by the file's order of quads (quad k at x in [3k - 1, 3k + 1]).
uint32_t mesh_of(const scenes::Scene& s, int k) {
    for (uint32_t i = 0; i < s.meshes.size(); ++i)
        if (s.meshes[i].name.find("quad" + std::to_string(k)) != std::string::npos) return i;
    ADD_FAILURE() << "no mesh quad" << k;
    return 0;
}

/// Straight down onto quad k at its texel (i, j) of a 4x4 grid (u = (i + 0.5) / 4).
accel::Ray down_at(int k, int i, int j) {
    const float x = 3.0f * k - 1.0f + 2.0f * (float(i) + 0.5f) / 4.0f;
    const float z = 2.0f * (float(j) + 0.5f) / 4.0f - 1.0f;
    return accel::Ray{accel::Vec3f(x, 1.0f, z), accel::Vec3f(0.0f, -1.0f, 0.0f)};
}

}  // namespace

TEST(GltfAlpha, ModesCutoffsAndFactorsAreRead) {
    const scenes::Scene s = scenes::load_scene(kFile);
    const scenes::Material& opaque = material(s, "opaque");
    EXPECT_EQ(opaque.alpha_mode, scenes::AlphaMode::Opaque);
    EXPECT_FLOAT_EQ(opaque.base_alpha, 0.3f);
    const scenes::Material& mask = material(s, "mask_default");
    EXPECT_EQ(mask.alpha_mode, scenes::AlphaMode::Mask);
    EXPECT_FLOAT_EQ(mask.alpha_cutoff, 0.5f) << "the spec's default cutoff";
    EXPECT_FLOAT_EQ(mask.base_alpha, 1.0f);
    const scenes::Material& cut = material(s, "mask_cutoff");
    EXPECT_EQ(cut.alpha_mode, scenes::AlphaMode::Mask);
    EXPECT_FLOAT_EQ(cut.alpha_cutoff, 0.25f);
    EXPECT_FLOAT_EQ(cut.base_alpha, 0.8f);
    const scenes::Material& blend = material(s, "blend");
    EXPECT_EQ(blend.alpha_mode, scenes::AlphaMode::Blend);
    EXPECT_FLOAT_EQ(blend.base_alpha, 0.5f);
    EXPECT_EQ(material(s, "mask_opaque").alpha_mode, scenes::AlphaMode::Mask);
    for (const std::string& n : s.notes) EXPECT_EQ(n.find("alphaMode"), std::string::npos) << n;
}

TEST(GltfAlpha, TextureAlphaKeptOnlyWhereSomeTexelIsNotOpaque) {
    const scenes::Scene s = scenes::load_scene(kFile);
    const scenes::Material& mask = material(s, "mask_default");
    ASSERT_LT(mask.albedo_texture, s.textures.size());
    const scenes::Texture& checker = s.textures[mask.albedo_texture];
    ASSERT_GE(checker.slot[3], 0) << "the checker's alpha must be stored";
    const scenes::Material& mo = material(s, "mask_opaque");
    ASSERT_LT(mo.albedo_texture, s.textures.size());
    EXPECT_LT(s.textures[mo.albedo_texture].slot[3], 0) << "an all-opaque alpha channel is not worth a byte";
}

TEST(GltfAlpha, OnlyMeshesWhoseAlphaCanCutAreMasked) {
    const scenes::Scene s = scenes::load_scene(kFile);
    const renderer::SceneGeometry g(s);
    EXPECT_FALSE(g.views()[mesh_of(s, 0)].masked()) << "OPAQUE ignores alpha";
    EXPECT_TRUE(g.views()[mesh_of(s, 1)].masked());
    EXPECT_TRUE(g.views()[mesh_of(s, 2)].masked());
    EXPECT_TRUE(g.views()[mesh_of(s, 3)].masked());
    EXPECT_FALSE(g.views()[mesh_of(s, 4)].masked()) << "MASK over an opaque texture cannot cut";
}

// Straight down through texel centres: the checker quads keep exactly their opaque
// texels (the default cutoff 0.5, and 0.8 * alpha >= 0.25 for the other), the opaque quad
// and the MASK quad over an opaque texture every texel, on every backend.
TEST(GltfAlpha, MaskedQuadsCutWhereTheTextureSays) {
    const scenes::Scene s = scenes::load_scene(kFile);
    const renderer::SceneGeometry g(s);
    for (const std::string& backend : accel::available_backends()) {
        auto acc = accel::create_accelerator(backend, g.views(), {});
        accel::TraceStats st;
        for (int k : {0, 1, 2, 4})
            for (int j = 0; j < 4; ++j)
                for (int i = 0; i < 4; ++i) {
                    // Texel row j holds v in [j/4, (j+1)/4): the PNG row j.
                    const bool cut = (k == 1 || k == 2) && (i + j) % 2 == 0;
                    accel::Hit h;
                    const accel::Ray r = down_at(k, i, j);
                    EXPECT_EQ(acc->intersect(r, h, st), !cut) << backend << " quad " << k << " texel " << i << "," << j;
                    EXPECT_EQ(acc->occluded(r, st), !cut) << backend << " quad " << k << " texel " << i << "," << j;
                    if (!cut) {
                        EXPECT_EQ(h.geom_id, mesh_of(s, k));
                    }
                }
    }
}

// MASK over an opaque texture traces exactly as OPAQUE: the same hits, bit for bit.
TEST(GltfAlpha, MaskOverOpaqueTextureTracesAsOpaque) {
    const scenes::Scene s = scenes::load_scene(kFile);
    scenes::Scene o = s;
    o.materials[s.meshes[mesh_of(s, 4)].material].alpha_mode = scenes::AlphaMode::Opaque;
    const renderer::SceneGeometry gs(s), go(o);
    auto as = accel::create_accelerator("custom", gs.views(), {});
    auto ao = accel::create_accelerator("custom", go.views(), {});
    accel::TraceStats st;
    for (int j = 0; j < 16; ++j)
        for (int i = 0; i < 16; ++i) {
            const accel::Ray r{accel::Vec3f(8.0f + 0.13f * float(i) - 1.0f, 1.0f, 0.12f * float(j) - 0.95f),
                               accel::normalize(accel::Vec3f(0.05f, -1.0f, 0.03f))};
            accel::Hit a, b;
            ASSERT_EQ(as->intersect(r, a, st), ao->intersect(r, b, st));
            EXPECT_EQ(a.t, b.t);
            EXPECT_EQ(a.u, b.u);
            EXPECT_EQ(a.prim_id, b.prim_id);
            EXPECT_EQ(a.geom_id, b.geom_id);
        }
}

TEST(GltfAlpha, BadModeAndCutoffAreRefusedNamingTheMaterial) {
    auto refused = [](std::string text, const std::string& from, const std::string& to, const char* what) {
        const size_t at = text.find(from);
        ASSERT_NE(at, std::string::npos) << from;
        text.replace(at, from.size(), to);
        try {
            load_text(text);
            ADD_FAILURE() << "accepted " << to;
        } catch (const scenes::SceneError& e) {
            EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("mask_cutoff"), std::string::npos) << e.what();
        }
    };
    refused(file_text(), "\"alphaCutoff\": 0.25", "\"alphaCutoff\": -0.25", "alphaCutoff");
    refused(file_text(), "\"MASK\",\n   \"alphaCutoff\": 0.25", "\"CUTOUT\",\n   \"alphaCutoff\": 0.25", "alphaMode");
}
