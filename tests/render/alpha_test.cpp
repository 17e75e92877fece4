// Alpha-tested (MASK) and blended (BLEND) geometry through every backend's hit filter
// (accel::GeometryView::filter, supplied by renderer::SceneGeometry).
//
// The scene: a white floor (y = 0, [-3, 3]^2), a quad at y = 1 over [-1, 1]^2 with uv
// ((x + 1) / 2, (z + 1) / 2), and a directional light straight down, so the quad's shadow
// is its alpha pattern projected onto the floor without magnification. A camera between
// quad and floor (height 0.5, looking down) sees the floor over [-1, 1]^2 and never the
// quad. With direct light only (max_depth 1) a floor point's radiance is albedo / pi
// where the light gets through, 0 where it does not.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>

#include "accel/accelerator.h"
#include "renderer/scene_geometry.h"
#include "renderer/texture.h"
#include "tests/render/render_world.h"

using namespace renderer;

namespace {

constexpr int kTexels = 4;  // checker texels per side
constexpr float kAlbedo = 0.5f;
constexpr float kLit = kAlbedo / 3.14159265f;  // floor radiance under full light

/// kTexels^2 RGBA texels, alpha 255 where (i + j) is odd, `low` elsewhere.
scenes::Texture checker(uint8_t low = 0) {
    scenes::Texture t = scenes::Texture::make("checker", kTexels, kTexels, scenes::TexelFormat::U8, "RGBA");
    for (int y = 0; y < kTexels; ++y)
        for (int x = 0; x < kTexels; ++x) {
            uint8_t* p = t.data.data() + (size_t(y) * kTexels + x) * 4;
            p[0] = p[1] = p[2] = 200;
            p[3] = (x + y) % 2 ? 255 : low;
        }
    return t;
}

/// Texel (i, j) of the checker stops light (alpha 255).
bool opaque_texel(int i, int j) { return (i + j) % 2 == 1; }

/// The floor, the quad (material 1: `mode`, base alpha `factor`, the checker texture
/// if `textured`) and the light.
scenes::Scene alpha_scene(scenes::AlphaMode mode, float factor, bool textured, uint8_t low = 0) {
    scenes::Scene s;
    scenes::Material floor;
    floor.albedo = Vec3f(kAlbedo);
    scenes::Material leaf;
    leaf.albedo = Vec3f(0.7f);
    leaf.alpha_mode = mode;
    leaf.base_alpha = factor;
    if (textured) {
        leaf.albedo_texture = 0;
        s.textures.push_back(checker(low));
    }
    s.materials = {floor, leaf};
    s.meshes.push_back(quad({-3, 0, 3}, {3, 0, 3}, {3, 0, -3}, {-3, 0, -3}, 0));
    scenes::Mesh q = quad({-1, 1, -1}, {1, 1, -1}, {1, 1, 1}, {-1, 1, 1}, 1);
    q.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    s.meshes.push_back(q);
    scenes::Light sun;
    sun.type = scenes::LightType::Directional;
    sun.direction = {0, -1, 0};
    sun.radiance = Vec3f(1.0f);
    s.lights.push_back(sun);
    return s;
}

/// The texel of the quad above floor point (x, z).
void texel_above(float x, float z, int& i, int& j) {
    i = std::clamp(int(std::floor((x + 1.0f) * 0.5f * kTexels)), 0, kTexels - 1);
    j = std::clamp(int(std::floor((z + 1.0f) * 0.5f * kTexels)), 0, kTexels - 1);
}

std::vector<std::string> backends() { return accel::available_backends(); }
bool has_embree() {
    for (const std::string& b : backends())
        if (b == "embree") return true;
    return false;
}

IntegratorSettings direct_only() {
    IntegratorSettings is;
    is.max_depth = 1;
    is.texture_filter = TextureFilter::Bilinear;
    return is;
}

Camera floor_camera() {
    // Height 0.5, half-angle atan(1 / 0.5): the floor's [-1, 1]^2 fills the image.
    const float fov = 2.0f * std::atan(2.0f) * 180.0f / 3.14159265f;
    return Camera({0, 0.5f, 0}, {0, 0, 0}, {0, 0, -1}, fov, fov);
}

RenderResult render_floor(World& w, int size, int spp, int threads, int tile = 32) {
    RenderSettings rs;
    rs.width = rs.height = size;
    rs.spp = spp;
    rs.threads = threads;
    rs.tile = tile;
    rs.progress = false;
    return render(floor_camera(), *w.integrator, *w.accel, rs);
}

/// The floor point seen through image point (x, y) in [0, 1]^2.
Vec3f floor_point(float x, float y) {
    const accel::Ray r = floor_camera().generate_ray(x, y);
    return r.org + r.dir * (-r.org.y / r.dir.y);
}

}  // namespace

// Shadow rays up from floor points under each texel, at its centre and around it (within
// 0.3 texel, away from the 0.5 contour that bilinear alpha puts on the texel edges), are
// occluded exactly where the texel is opaque; rays down from above hit the quad there and
// the floor elsewhere. Every backend, both triangle tests.
TEST(AlphaMask, CheckerCastsACheckeredShadowOnEveryBackend) {
    const scenes::Scene s = alpha_scene(scenes::AlphaMode::Mask, 1.0f, true);
    const SceneGeometry g(s);
    ASSERT_TRUE(g.views()[1].masked());
    ASSERT_FALSE(g.views()[0].masked());
    const float d = 2.0f / kTexels;  // texel size in world units
    for (const std::string& backend : backends())
        for (accel::TriangleTest test : {accel::TriangleTest::Fast, accel::TriangleTest::Watertight}) {
            accel::AccelOptions o;
            o.triangle = test;
            auto acc = accel::create_accelerator(backend, g.views(), o);
            accel::TraceStats st;
            int occluded = 0;
            for (int j = 0; j < kTexels; ++j)
                for (int i = 0; i < kTexels; ++i)
                    for (float ox : {-0.3f, 0.0f, 0.3f})
                        for (float oz : {-0.25f, 0.1f, 0.3f}) {
                            const float x = -1.0f + (float(i) + 0.5f + ox) * d, z = -1.0f + (float(j) + 0.5f + oz) * d;
                            const bool want = opaque_texel(i, j);
                            const accel::Ray up{Vec3f(x, 0.0f, z), Vec3f(0, 1, 0), 1e-4f, 10.0f};
                            const bool got = acc->occluded(up, st);
                            occluded += got;
                            EXPECT_EQ(got, want) << backend << " texel " << i << "," << j << " offset " << ox << "," << oz;
                            accel::Hit h;
                            const accel::Ray down{Vec3f(x, 5.0f, z), Vec3f(0, -1, 0)};
                            ASSERT_TRUE(acc->intersect(down, h, st));
                            EXPECT_EQ(h.geom_id, want ? 1u : 0u) << backend << " texel " << i << "," << j;
                            EXPECT_FLOAT_EQ(h.t, want ? 4.0f : 5.0f);
                        }
            EXPECT_EQ(occluded, kTexels * kTexels / 2 * 9) << backend;
        }
}

// The same shadow in a render: the floor's 4x4 regions under opaque texels are black
// (direct light only), the others lit at albedo / pi, on custom and Embree; and both
// backends' region means agree.
TEST(AlphaMask, RenderedShadowIsTheChecker) {
    std::vector<std::vector<Estimate>> regions;
    for (const std::string& backend : {std::string("custom"), std::string("embree")}) {
        if (backend == "embree" && !has_embree()) continue;
        World w;
        w.scene = alpha_scene(scenes::AlphaMode::Mask, 1.0f, true);
        w.build(direct_only(), backend);
        const RenderResult r = render_floor(w, 32, 8, 2);
        regions.push_back(region_means(r.image, kTexels));
        for (int ry = 0; ry < kTexels; ++ry)
            for (int rx = 0; rx < kTexels; ++rx) {
                const Vec3f p = floor_point((float(rx) + 0.5f) / kTexels, (float(ry) + 0.5f) / kTexels);
                int i, j;
                texel_above(p.x, p.z, i, j);
                const double m = regions.back()[size_t(ry * kTexels + rx)].mean;
                if (opaque_texel(i, j))
                    EXPECT_LT(m, 1e-6) << backend << " region " << rx << "," << ry << " should be in shadow";
                else
                    EXPECT_NEAR(m, kLit, 0.01 * kLit) << backend << " region " << rx << "," << ry << " should be lit";
            }
    }
    if (regions.size() == 2) {
        for (size_t k = 0; k < regions[0].size(); ++k)
            EXPECT_NEAR(regions[0][k].mean, regions[1][k].mean, 1e-4) << "region " << k;
    }
}

// BLEND at alpha 0.5 lets half the light through: shadow rays from 20000 floor points
// under the quad are occluded with frequency 0.5 (within 5 standard errors, 0.018), on
// every backend; alpha 0.25 lets 0.75 through.
TEST(AlphaBlend, HalfAlphaStopsHalfTheShadowRays) {
    for (float alpha : {0.5f, 0.25f}) {
        const scenes::Scene s = alpha_scene(scenes::AlphaMode::Blend, alpha, false);
        const SceneGeometry g(s);
        ASSERT_TRUE(g.views()[1].masked());
        for (const std::string& backend : backends()) {
            auto acc = accel::create_accelerator(backend, g.views(), {});
            constexpr int kRays = 20000;
            const double se = std::sqrt(alpha * (1.0 - alpha) / kRays);
            EXPECT_NEAR(fraction_blocked_upward(*acc, kRays), alpha, 5 * se) << backend << " alpha " << alpha;
        }
    }
}

// The same in a render: the floor under a BLEND quad of alpha 0.5 has half the radiance
// of a fully lit one, within 4 standard errors of the image mean, on custom and Embree.
TEST(AlphaBlend, HalfAlphaHalvesTheLightInARender) {
    for (const std::string& backend : {std::string("custom"), std::string("embree")}) {
        if (backend == "embree" && !has_embree()) continue;
        World w;
        w.scene = alpha_scene(scenes::AlphaMode::Blend, 0.5f, false);
        w.build(direct_only(), backend);
        const RenderResult r = render_floor(w, 24, 16, 2);
        const Estimate all = region_means(r.image, 1)[0];
        EXPECT_NEAR(all.mean, 0.5 * kLit, 4 * all.se + 1e-6) << backend;
        EXPECT_GT(all.se, 0.0) << "a stochastic pass-through has variance";
    }
}

// Vertex alpha (glTF COLOR_0's fourth component) multiplies the base alpha: with alpha 0
// at the quad's x = -1 edge and 1 at x = +1, alpha is (x + 1) / 2 over both triangles, so
// a MASK cutoff of 0.5 keeps the half x > 0; shadow rays up from the floor are stopped
// there and pass elsewhere (away from the contour), on every backend. Under BLEND a ray
// is stopped with probability (x + 1) / 2: a ray under x in [-0.95, 0.95] on average
// half the time, and near the opaque edge nearly always.
TEST(AlphaVertex, VertexAlphaCutsAndBlendsTheQuad) {
    for (scenes::AlphaMode mode : {scenes::AlphaMode::Mask, scenes::AlphaMode::Blend}) {
        scenes::Scene s = alpha_scene(mode, 1.0f, false);
        s.meshes[1].alphas = {0.0f, 1.0f, 1.0f, 0.0f};
        const SceneGeometry g(s);
        ASSERT_TRUE(g.views()[1].masked()) << "vertex alpha alone makes the quad masked";
        for (const std::string& backend : backends()) {
            auto acc = accel::create_accelerator(backend, g.views(), {});
            accel::TraceStats st;
            std::mt19937 rng(3);
            std::uniform_real_distribution<float> pos(-0.95f, 0.95f);
            int blocked = 0, near_opaque = 0, near_opaque_blocked = 0;
            constexpr int kRays = 20000;
            for (int k = 0; k < kRays; ++k) {
                const float x = pos(rng);
                const bool hit = acc->occluded(accel::Ray{Vec3f(x, 0.0f, pos(rng)), Vec3f(0, 1, 0), 1e-4f, 10.0f}, st);
                blocked += hit;
                if (mode == scenes::AlphaMode::Mask && std::abs(x) > 0.02f) {
                    ASSERT_EQ(hit, x > 0.0f) << backend << " x " << x;
                }
                if (x > 0.8f) ++near_opaque, near_opaque_blocked += hit;
            }
            const double se = std::sqrt(0.25 / kRays);
            EXPECT_NEAR(double(blocked) / kRays, 0.5, 5 * se) << backend;
            // Under x > 0.8, alpha > 0.9.
            EXPECT_GT(double(near_opaque_blocked) / near_opaque, 0.88) << backend;
        }
    }
}

// Stochastic transparency decides by a hash of the ray, not by a stream of its own: a
// render is bit-identical at 1 and 2 threads and at any tile size.
TEST(AlphaBlend, RenderIsBitIdenticalForAnyThreadsAndTiles) {
    World w;
    w.scene = alpha_scene(scenes::AlphaMode::Blend, 0.5f, true, 128);
    w.build(IntegratorSettings{}, "custom");
    const RenderResult a = render_floor(w, 16, 4, 1, 32);
    const RenderResult b = render_floor(w, 16, 4, 2, 4);
    ASSERT_EQ(a.image.pixels.size(), b.image.pixels.size());
    EXPECT_EQ(std::memcmp(a.image.pixels.data(), b.image.pixels.data(), a.image.pixels.size() * sizeof(float)), 0);
}

// A MASK material whose alpha never falls below the cutoff (stored alpha 200 and 255,
// cutoff 0.5) is filtered (its view is masked, the custom BVH runs its masked kernel)
// and yet renders bit for bit as the same material OPAQUE, on custom and Embree.
TEST(AlphaMask, AlphaAboveTheCutoffEverywhereRendersAsOpaque) {
    for (const std::string& backend : {std::string("custom"), std::string("embree")}) {
        if (backend == "embree" && !has_embree()) continue;
        World masked, opaque;
        masked.scene = alpha_scene(scenes::AlphaMode::Mask, 1.0f, true, 200);
        opaque.scene = alpha_scene(scenes::AlphaMode::Opaque, 1.0f, true, 200);
        IntegratorSettings is;
        is.texture_filter = TextureFilter::Bilinear;
        masked.build(is, backend);
        opaque.build(is, backend);
        ASSERT_TRUE(masked.geometry->views()[1].masked());
        ASSERT_FALSE(opaque.geometry->views()[1].masked());
        if (backend == "custom") {
            EXPECT_NE(masked.accel->info().backend.find("masked"), std::string::npos);
        }
        // A camera that sees the quad's top and the floor around it.
        RenderSettings rs;
        rs.width = rs.height = 16;
        rs.spp = 4;
        rs.threads = 2;
        rs.progress = false;
        const Camera cam({0.5f, 3.0f, 2.5f}, {0, 0.5f, 0}, {0, 1, 0}, 60.0f, 60.0f);
        const RenderResult a = render(cam, *masked.integrator, *masked.accel, rs);
        const RenderResult b = render(cam, *opaque.integrator, *opaque.accel, rs);
        ASSERT_EQ(a.image.pixels.size(), b.image.pixels.size());
        EXPECT_EQ(std::memcmp(a.image.pixels.data(), b.image.pixels.data(), a.image.pixels.size() * sizeof(float)), 0)
            << backend;
    }
}

// xcheck on a masked scene: the checker quad (MASK) under a BLEND quad of alpha 0.5 at
// y = 2, 20000 rays from above through both. Custom, Embree's counting mode and naive
// agree bit for bit (same arithmetic, same filter input) on closest hits and occlusion,
// in both triangle tests;
// Embree agrees on what is hit and where, for rays that cross the checker within 0.3
// texel of a texel centre (its barycentrics round differently, which could move a hit
// across the alpha contour on the texel edges).
TEST(AlphaXcheck, CustomEmbreeAndNaiveAgreeThroughMaskedQuads) {
    scenes::Scene s = alpha_scene(scenes::AlphaMode::Mask, 1.0f, true);
    scenes::Material veil;
    veil.alpha_mode = scenes::AlphaMode::Blend;
    veil.base_alpha = 0.5f;
    s.materials.push_back(veil);
    s.meshes.push_back(quad({-2, 2, -2}, {2, 2, -2}, {2, 2, 2}, {-2, 2, 2}, 2));
    const SceneGeometry g(s);
    ASSERT_TRUE(g.views()[2].masked());
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> texel(0, kTexels - 1);
    std::uniform_real_distribution<float> jitter(-0.3f, 0.3f), slope(-0.3f, 0.3f), height(0.5f, 2.0f);
    const float d = 2.0f / kTexels;
    std::vector<accel::Ray> rays;
    for (int k = 0; k < 20000; ++k) {
        // Through a point near a texel centre of the checker, off the quad's diagonal.
        const int i = texel(rng), j = texel(rng);
        const Vec3f at(-1.0f + (float(i) + 0.5f + 0.15f + jitter(rng) * 0.5f) * d, 1.0f,
                       -1.0f + (float(j) + 0.5f - 0.15f + jitter(rng) * 0.5f) * d);
        const Vec3f dir = accel::normalize(Vec3f(slope(rng), -1.0f, slope(rng)));
        rays.push_back({at - dir * (1.0f + height(rng)), dir, 0.0f, 10.0f});
    }
    for (accel::TriangleTest test : {accel::TriangleTest::Fast, accel::TriangleTest::Watertight}) {
        accel::AccelOptions o;
        o.triangle = test;
        auto naive = accel::create_accelerator("naive", g.views(), o);
        std::vector<std::unique_ptr<accel::Accelerator>> others;
        others.push_back(accel::create_accelerator("custom", g.views(), o));
        if (has_embree()) {
            others.push_back(accel::create_accelerator("embree", g.views(), o));
            // The counting mode: our triangle test inside Embree's user geometry, which
            // calls the filter itself; its arithmetic is naive's, so it must match exactly.
            accel::AccelOptions c = o;
            c.embree_count = true;
            others.push_back(accel::create_accelerator("embree", g.views(), c));
        }
        accel::TraceStats st;
        int floor_hits = 0, checker_hits = 0, veil_hits = 0;
        for (const auto& acc : others) {
            const std::string name = acc->info().backend;
            const bool exact = name.rfind("custom", 0) == 0 || name.rfind("embree(count", 0) == 0;
            int disagree = 0;
            for (const accel::Ray& r : rays) {
                accel::Hit a, b;
                const bool ha = naive->intersect(r, a, st), hb = acc->intersect(r, b, st);
                const bool oa = naive->occluded(r, st), ob = acc->occluded(r, st);
                bool same = ha == hb && oa == ob && a.geom_id == b.geom_id;
                if (exact) same = same && a.t == b.t && a.prim_id == b.prim_id && a.u == b.u && a.v == b.v;
                else same = same && std::abs(a.t - b.t) <= 1e-5f * a.t;
                disagree += !same;
                if (name.rfind("custom", 0) == 0)
                    floor_hits += a.geom_id == 0, checker_hits += a.geom_id == 1, veil_hits += a.geom_id == 2;
            }
            EXPECT_EQ(disagree, 0) << acc->info().backend;
        }
        // The rays really exercise all three layers: about half pass the veil, and of
        // those half stop on the checker.
        EXPECT_NEAR(veil_hits, 10000, 500);
        EXPECT_NEAR(checker_hits, 5000, 400);
        EXPECT_NEAR(floor_hits, 5000, 400);
    }
}

// The plugin ABI has no hit filter: masked geometry is refused, naming the reason, not
// drawn opaque.
TEST(AlphaPlugin, MaskedGeometryIsRefusedByPlugins) {
    const scenes::Scene s = alpha_scene(scenes::AlphaMode::Mask, 1.0f, true);
    const SceneGeometry g(s);
    try {
        accel::create_accelerator("plugin:/nonexistent/libwhatever.so", g.views(), {});
        ADD_FAILURE() << "accepted";
    } catch (const accel::AccelError& e) {
        EXPECT_NE(std::string(e.what()).find("masked"), std::string::npos) << e.what();
    }
}

// The alpha test reads the alpha channel alone (lookup_alpha); it must be the bilinear
// lookup's alpha bit for bit, in every texel format and for uv outside [0, 1] (wrapped),
// and 1 for a texture that stores no alpha.
TEST(AlphaLookup, AlphaAloneIsTheBilinearLookupsAlpha) {
    std::mt19937 rng(5);
    std::uniform_int_distribution<int> byte(0, 255);
    std::uniform_real_distribution<float> coord(-1.5f, 2.5f);
    for (scenes::TexelFormat f : {scenes::TexelFormat::U8, scenes::TexelFormat::U16, scenes::TexelFormat::F16,
                                  scenes::TexelFormat::F32})
        for (const char* channels : {"RGBA", "GA", "A"}) {
            scenes::Texture t = scenes::Texture::make("t", 7, 5, f, channels);
            t.srgb = f == scenes::TexelFormat::U8;
            for (uint8_t& b : t.data) b = uint8_t(byte(rng));
            if (f == scenes::TexelFormat::F16 || f == scenes::TexelFormat::F32)  // finite values in [0, 1]
                for (size_t k = 0; k < t.data.size() / scenes::texel_format_bytes(f); ++k) {
                    const float x = float(byte(rng)) / 255.0f;
                    if (f == scenes::TexelFormat::F32) std::memcpy(t.data.data() + 4 * k, &x, 4);
                    else {
                        const uint16_t h = scenes::float_to_half(x);
                        std::memcpy(t.data.data() + 2 * k, &h, 2);
                    }
                }
            for (int k = 0; k < 500; ++k) {
                const Vec2f uv{coord(rng), coord(rng)};
                const float want = lookup(t, uv, kNoFootprint, TextureFilter::Bilinear).a;
                const float got = lookup_alpha(t, uv);
                ASSERT_EQ(std::memcmp(&want, &got, 4), 0) << channels << " format " << int(f) << " uv " << uv.x << "," << uv.y
                                                          << ": " << got << " vs " << want;
            }
        }
    const scenes::Texture rgb = scenes::Texture::from_rgb("rgb", 2, 2, std::vector<float>(12, 0.25f));
    EXPECT_EQ(lookup_alpha(rgb, Vec2f{0.3f, 0.6f}), 1.0f);
}
