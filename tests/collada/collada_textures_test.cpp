// Diffuse textures in COLLADA's profile_COMMON, as exporters other than the course's write
// them: the <newparam> chain from <texture> to <image> (1.4.1) and a direct image id, the
// sampler's wraps and magnification, texture coordinates flipped to the scene's v (0 at
// the image's top), and a missing image file as a warning. The image is a 2x2 PNG written
// by OpenImageIO into a temporary folder beside the document.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "renderer/texture.h"
#include "scenes/collada/collada.h"

namespace {

using scenes::Scene;
using scenes::TextureWrap;
using scenes::Vec3f;

/// Top row red, green; bottom row blue, white.
void write_png(const std::filesystem::path& path) {
    const unsigned char px[12] = {255, 0, 0, 0, 255, 0, 0, 0, 255, 255, 255, 255};
    auto out = OIIO::ImageOutput::create(path.string());
    ASSERT_TRUE(out);
    ASSERT_TRUE(out->open(path.string(), OIIO::ImageSpec(2, 2, 3, OIIO::TypeDesc::UINT8)));
    ASSERT_TRUE(out->write_image(OIIO::TypeDesc::UINT8, px));
    out->close();
}

std::string effect(const std::string& id, const std::string& params, const std::string& texture) {
    return "<effect id=\"" + id + "\"><profile_COMMON>" + params + "<technique sid=\"common\"><lambert><diffuse>" +
           texture + "</diffuse></lambert></technique></profile_COMMON></effect>";
}

std::string node(int i, const std::string& material) {
    return "<node id=\"n" + std::to_string(i) + "\"><translate>" + std::to_string(2 * i) +
           " 0 0</translate><instance_geometry url=\"#quad\"><bind_material><technique_common>"
           "<instance_material symbol=\"mat\" target=\"#" + material +
           "\"/></technique_common></bind_material></instance_geometry></node>";
}

/// Four placements of one quad (positions (0..1)^2 at z = 0, uvs equal to x, y), each
/// bound to one material: a texture through the newparam chain with CLAMP / MIRROR /
/// NEAREST, the same image named directly, an image whose file is missing, a colour.
std::string document() {
    const std::string chain =
        "<newparam sid=\"surf\"><surface type=\"2D\"><init_from>img</init_from></surface></newparam>"
        "<newparam sid=\"samp\"><sampler2D><source>surf</source><wrap_s>CLAMP</wrap_s><wrap_t>MIRROR</wrap_t>"
        "<magfilter>NEAREST</magfilter></sampler2D></newparam>";
    return "<?xml version=\"1.0\"?><COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">"
           "<library_images><image id=\"img\"><init_from>tex%20file.png</init_from></image>"
           "<image id=\"gone\"><init_from>file:///nonexistent/gone.png</init_from></image></library_images>"
           "<library_effects>" +
           effect("fx1", chain, "<texture texture=\"samp\" texcoord=\"UVMap\"/>") +
           effect("fx2", "", "<texture texture=\"img\" texcoord=\"UVMap\"/>") +
           effect("fx3", "", "<texture texture=\"gone\" texcoord=\"UVMap\"/>") +
           effect("fx4", "", "<color>0.5 0.25 0.125 1</color>") +
           "</library_effects><library_materials>"
           "<material id=\"m1\"><instance_effect url=\"#fx1\"/></material>"
           "<material id=\"m2\"><instance_effect url=\"#fx2\"/></material>"
           "<material id=\"m3\"><instance_effect url=\"#fx3\"/></material>"
           "<material id=\"m4\"><instance_effect url=\"#fx4\"/></material></library_materials>"
           "<library_geometries><geometry id=\"quad\"><mesh>"
           "<source id=\"pos\"><float_array id=\"pos-a\" count=\"12\">0 0 0 1 0 0 1 1 0 0 1 0</float_array>"
           "<technique_common><accessor source=\"#pos-a\" count=\"4\" stride=\"3\"/></technique_common></source>"
           "<source id=\"uv\"><float_array id=\"uv-a\" count=\"8\">0 0 1 0 1 1 0 1</float_array>"
           "<technique_common><accessor source=\"#uv-a\" count=\"4\" stride=\"2\"/></technique_common></source>"
           "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#pos\"/></vertices>"
           "<triangles material=\"mat\" count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
           "<input semantic=\"TEXCOORD\" source=\"#uv\" offset=\"1\" set=\"0\"/><p>0 0 1 1 2 2 0 0 2 2 3 3</p>"
           "</triangles></mesh></geometry></library_geometries>"
           "<library_visual_scenes><visual_scene id=\"s\">" +
           node(0, "m1") + node(1, "m2") + node(2, "m3") + node(3, "m4") +
           "</visual_scene></library_visual_scenes><scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>";
}

class ColladaTextures : public testing::Test {
protected:
    void SetUp() override {
        dir_ = std::filesystem::temp_directory_path() / ("pt_collada_tex_" + std::to_string(::getpid()));
        std::filesystem::create_directories(dir_);
        write_png(dir_ / "tex file.png");
        std::ofstream(dir_ / "scene.dae") << document();
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }
    std::filesystem::path dir_;
};

TEST_F(ColladaTextures, DiffuseImagesSamplersAndUvsAreRead) {
    const Scene s = scenes::load_collada((dir_ / "scene.dae").string());
    ASSERT_EQ(s.meshes.size(), 4u);
    ASSERT_EQ(s.textures.size(), 2u) << "one image under two samplers; the missing one not at all";
    const auto& m1 = s.materials[s.meshes[0].material];
    const auto& m2 = s.materials[s.meshes[1].material];
    const auto& m3 = s.materials[s.meshes[2].material];
    const auto& m4 = s.materials[s.meshes[3].material];
    ASSERT_NE(m1.albedo_texture, scenes::kNoTexture);
    ASSERT_NE(m2.albedo_texture, scenes::kNoTexture);
    EXPECT_EQ(m1.albedo, Vec3f(1.0f)) << "the texture is the diffuse colour";
    const scenes::Texture& clamped = s.textures[m1.albedo_texture];
    EXPECT_EQ(clamped.wrap_s, TextureWrap::ClampToEdge);
    EXPECT_EQ(clamped.wrap_t, TextureWrap::MirroredRepeat);
    EXPECT_TRUE(clamped.magnify_nearest);
    const scenes::Texture& plain = s.textures[m2.albedo_texture];
    EXPECT_EQ(plain.wrap_s, TextureWrap::Repeat);
    EXPECT_FALSE(plain.magnify_nearest);
    // The missing file: a warning naming it, the material untextured, its mesh without uvs.
    EXPECT_EQ(m3.albedo_texture, scenes::kNoTexture);
    ASSERT_EQ(s.warnings.size(), 1u);
    EXPECT_NE(s.warnings[0].find("gone.png"), std::string::npos) << s.warnings[0];
    EXPECT_NE(s.warnings[0].find("not found"), std::string::npos) << s.warnings[0];
    EXPECT_TRUE(s.meshes[2].uvs.empty());
    EXPECT_EQ(m4.albedo_texture, scenes::kNoTexture);
    EXPECT_EQ(m4.albedo, Vec3f(0.5f, 0.25f, 0.125f));
    EXPECT_TRUE(s.meshes[3].uvs.empty()) << "uvs only where the material reads a texture";
    // Each corner's uv is COLLADA's with v flipped, so the quad's lower-left quarter reads
    // the image's lower-left texel: blue, white, green, red from the quad's (0, 0)
    // corner round.
    const Vec3f want[4] = {{0, 0, 1}, {1, 1, 1}, {0, 1, 0}, {1, 0, 0}};
    for (size_t k = 0; k < 2; ++k) {
        const scenes::Mesh& m = s.meshes[k];
        ASSERT_EQ(m.uvs.size(), m.num_vertices());
        const scenes::Texture& t = s.textures[s.materials[m.material].albedo_texture];
        for (uint32_t v = 0; v < m.num_vertices(); ++v) {
            const Vec3f p = m.positions[v] - Vec3f(2.0f * float(k), 0.0f, 0.0f);
            EXPECT_NEAR(m.uvs[v].x, p.x, 1e-6f);
            EXPECT_NEAR(m.uvs[v].y, 1.0f - p.y, 1e-6f);
            const accel::Vec2f inward{0.25f + 0.5f * m.uvs[v].x, 0.25f + 0.5f * m.uvs[v].y};
            const Vec3f c = renderer::lookup(t, inward, renderer::kNoFootprint, renderer::TextureFilter::Nearest).rgb();
            const int corner = int(p.x + 0.5f) + 2 * int(p.y + 0.5f);  // (0,0) (1,0) (0,1) (1,1)
            const Vec3f& w = want[corner == 2 ? 3 : corner == 3 ? 2 : corner];
            EXPECT_NEAR(c.x, w.x, 1e-6f) << "mesh " << k << " vertex " << v;
            EXPECT_NEAR(c.y, w.y, 1e-6f) << "mesh " << k << " vertex " << v;
            EXPECT_NEAR(c.z, w.z, 1e-6f) << "mesh " << k << " vertex " << v;
        }
    }
}

TEST_F(ColladaTextures, UndecodableImageFailsNamingIt) {
    std::ofstream(dir_ / "tex file.png") << "not a png";
    try {
        scenes::load_collada((dir_ / "scene.dae").string());
        ADD_FAILURE() << "an undecodable image was accepted";
    } catch (const scenes::SceneError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("<image id=\"img\">"), std::string::npos) << m;
        EXPECT_NE(m.find("tex file.png"), std::string::npos) << m;
    }
}

}  // namespace
