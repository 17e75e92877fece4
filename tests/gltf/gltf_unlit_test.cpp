// KHR_materials_unlit on a small file made here (tests/gltf/data/make_unlit.py writes
// unlit_panel.gltf: a diffuse floor, an upright unlit panel of base colour (0.9, 0.5,
// 0.2) that requires the extension, a point light, a camera).
// The loader accepts the required extension and reads only the base colour; the camera
// sees exactly that colour whatever the lights; and the panel lights nothing: the floor
// in front of it is what it is with a black panel in its place.
#include <gtest/gtest.h>


#include "renderer/camera.h"
#include "renderer/render.h"
#include "scenes/gltf/gltf.h"
#include "scenes/load.h"
#include "tests/gltf/gltf_text.h"
#include "tests/render/render_world.h"

using namespace renderer;

namespace {

const std::string kFile = std::string(PT_SOURCE_DIR) + "/tests/gltf/data/unlit_panel.gltf";
const Vec3f kBase{0.9f, 0.5f, 0.2f};

std::string file_text() { return gltf_text::read(kFile); }

scenes::Scene load_text(const std::string& text) { return gltf_text::load(text, "unlit_panel.gltf"); }

void replace_all(std::string& s, const std::string& from, const std::string& to) {
    for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
        s.replace(at, from.size(), to);
}

uint32_t material_named(const scenes::Scene& s, const std::string& name) {
    for (uint32_t i = 0; i < s.materials.size(); ++i)
        if (s.materials[i].name == name) return i;
    ADD_FAILURE() << "no material " << name;
    return 0;
}

Estimate channel(World& w, const accel::Ray& ray, int c, int n = 4000) {
    return estimate(*w.integrator, *w.accel, ray, n, 7, c);
}

// From the file's camera at (0, 1, 4).
accel::Ray toward(const Vec3f& target, const Vec3f& from = Vec3f{0.0f, 1.0f, 4.0f}) {
    return accel::Ray{from, accel::normalize(target - from)};
}

}  // namespace

TEST(GltfUnlit, RequiredExtensionIsReadAndOnlyTheBaseColourKept) {
    const scenes::Scene s = scenes::load_scene(kFile);
    const scenes::Material& m = s.materials[material_named(s, "unlit")];
    EXPECT_TRUE(m.unlit);
    EXPECT_FALSE(m.is_emissive()) << "emissiveFactor is a fallback for viewers without the extension";
    EXPECT_EQ(m.bsdf, scenes::BsdfKind::Diffuse);
    EXPECT_FLOAT_EQ(m.albedo.x, kBase.x);
    EXPECT_FLOAT_EQ(m.albedo.y, kBase.y);
    EXPECT_FLOAT_EQ(m.albedo.z, kBase.z);
    EXPECT_FALSE(s.materials[material_named(s, "floor")].unlit);
    for (const std::string& n : s.notes) EXPECT_EQ(n.find("KHR_materials_unlit"), std::string::npos) << n;

    // Without the extension on the material, the fallback PBR material is what is read.
    std::string text = file_text();
    replace_all(text, "\"KHR_materials_unlit\": {}", "\"KHR_materials_other\": {}");
    replace_all(text, "\"extensionsRequired\"", "\"x_extensionsRequired\"");
    const scenes::Scene f = load_text(text);
    const scenes::Material& fb = f.materials[material_named(f, "unlit")];
    EXPECT_FALSE(fb.unlit);
    EXPECT_TRUE(fb.is_emissive());
    EXPECT_EQ(fb.bsdf, scenes::BsdfKind::MetallicRoughness);
}

// The image through the file's camera: the panel's pixels are the base colour, with the
// file's light, a light 100 times stronger, no light (the default white environment),
// and under -H; times the base colour texture when there is one.
TEST(GltfUnlit, CameraSeesTheBaseColourWhateverTheLights) {
    for (int variant = 0; variant < 5; ++variant) {
        SCOPED_TRACE("variant " + std::to_string(variant));
        World w;
        w.scene = scenes::load_scene(kFile);
        IntegratorSettings is;
        Vec3f expected = kBase;
        if (variant == 1) w.scene.lights[0].radiance = w.scene.lights[0].radiance * 100.0f;
        if (variant == 2) w.scene.lights.clear();
        if (variant == 3) is.hemisphere = true;
        if (variant == 4) {
            // A 1x1 texture: the mesh has no uvs, so every point reads that texel.
            w.scene.textures.push_back(scenes::Texture::from_rgb("t", 1, 1, {0.5f, 1.0f, 0.25f}));
            w.scene.materials[material_named(w.scene, "unlit")].albedo_texture = uint32_t(w.scene.textures.size() - 1);
            expected = kBase * Vec3f{0.5f, 1.0f, 0.25f};
        }
        w.build(is);
        const int W = 40, H = 40;
        Camera cam = make_camera(w.scene, CameraMode::Auto, W, H).camera;
        RenderSettings rs;
        rs.width = W;
        rs.height = H;
        rs.spp = 4;
        rs.threads = 1;
        rs.progress = false;
        const Image img = render(cam, *w.integrator, *w.accel, rs).image;
        // The panel covers about 30-74 % of the frame's height and 25-75 % of its
        // width: read the middle 35-65 %.
        double sum[3] = {0, 0, 0};
        int n = 0;
        for (int y = 7 * H / 20; y < 13 * H / 20; ++y)
            for (int x = 7 * W / 20; x < 13 * W / 20; ++x, ++n)
                for (int c = 0; c < 3; ++c) sum[c] += img.at(x, y)[kR + c];
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum[c] / n, expected[c], 1e-5) << "channel " << c;
        // And the floor below it is lit: the lights are there (without lights, the
        // default environment; -H cannot find a point light, so it stays dark there).
        if (variant != 3) {
            EXPECT_GT(img.at(W / 2, H - 2)[kG], 0.0f);
        }
    }
}

TEST(GltfUnlit, OneSidedUnlessDoubleSided) {
    for (bool two : {true, false}) {
        World w;
        w.scene = scenes::load_scene(kFile);
        w.scene.materials[material_named(w.scene, "unlit")].double_sided = two;
        w.build(IntegratorSettings{});
        // From behind the panel, looking at its back face.
        const Estimate back = channel(w, toward({0.0f, 1.0f, -1.0f}, {0.0f, 1.0f, -4.0f}), 0, 16);
        EXPECT_NEAR(back.mean, two ? kBase.x : 0.0f, 1e-6) << "doubleSided " << two;
    }
}

// The floor just in front of the panel: with the unlit panel, the same as with a black
// panel in its place (it reflects nothing, emits nothing to the floor), and clearly
// darker than with the panel as an emitter of the same colour (the region would show it).
TEST(GltfUnlit, LightsNothingAndReflectsNothing) {
    for (bool hemisphere : {false, true}) {
        SCOPED_TRACE(hemisphere ? "-H" : "light sampling");
        IntegratorSettings is;
        is.hemisphere = hemisphere;
        is.light_samples = 4;
        auto floor_mean = [&](int kind, int c) {
            World w;
            w.scene = scenes::load_scene(kFile);
            if (hemisphere) {
                // -H cannot find a point light: an environment lights the floor instead.
                w.scene.lights[0].type = scenes::LightType::Environment;
                w.scene.lights[0].radiance = Vec3f(0.5f);
            }
            scenes::Material& m = w.scene.materials[material_named(w.scene, "unlit")];
            if (kind == 1) {  // black diffuse
                m.unlit = false;
                m.albedo = Vec3f(0.0f);
            } else if (kind == 2) {  // emitter of the base colour
                m.unlit = false;
                m.albedo = Vec3f(0.0f);
                m.emission = kBase;
            }
            w.build(is);
            return channel(w, toward({0.0f, 0.0f, -0.6f}), c);
        };
        for (int c = 0; c < 3; ++c) {
            SCOPED_TRACE("channel " + std::to_string(c));
            const Estimate unlit = floor_mean(0, c), black = floor_mean(1, c), emitter = floor_mean(2, c);
            EXPECT_GT(unlit.mean, 0.0);
            EXPECT_NEAR(unlit.mean, black.mean, 4.0 * std::hypot(unlit.se, black.se) + 1e-6);
            EXPECT_GT(emitter.mean - unlit.mean, 5.0 * std::hypot(unlit.se, emitter.se));
        }
    }
}
