// Textures at their source's precision: 8-bit against float lookups, the sRGB decode
// against OpenColorIO's, the MIP level against the footprint, and a furnace through a
// textured material.
#include <gtest/gtest.h>

#include <OpenColorIO/OpenColorIO.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "renderer/camera.h"
#include "renderer/interaction.h"
#include "renderer/texture.h"
#include "scenes/image/image.h"
#include "../render/render_world.h"

using namespace renderer;
using scenes::TexelFormat;
using scenes::Texture;

namespace {

/// The same random image twice: 8-bit codes, and float holding what those codes mean
/// (code / 255, or the sRGB curve of it); each with its pyramid.
struct Pair {
    Texture u8, f32;
};

Pair random_pair(uint32_t w, uint32_t h, bool srgb, uint32_t seed) {
    std::mt19937 rng(seed);
    Pair p;
    p.u8 = Texture::make("u8", w, h, TexelFormat::U8, "RGBA");
    p.u8.srgb = srgb;
    p.f32 = Texture::make("f32", w, h, TexelFormat::F32, "RGBA");
    // Smooth blobs plus noise: the coarse levels see gradients, not only grey.
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x)
            for (int c = 0; c < 4; ++c) {
                const float smooth = 0.5f + 0.45f * std::sin(0.11f * float(x) * float(c + 1) + 0.07f * float(y));
                const int code = std::clamp(int(smooth * 255.0f) + int(rng() % 41) - 20, 0, 255);
                const size_t i = (size_t(y) * w + x) * 4 + size_t(c);
                p.u8.data[i] = uint8_t(code);
                const float v = srgb && c < 3 ? scenes::srgb_to_linear(float(code) / 255.0f)
                                              : float(code) / 255.0f;
                std::memcpy(&p.f32.data[i * 4], &v, 4);
            }
    scenes::image::build_mip_pyramid(p.u8);
    scenes::image::build_mip_pyramid(p.f32);
    return p;
}

float srgb_encode(float l) {
    l = std::clamp(l, 0.0f, 1.0f);
    return l <= 0.0031308f ? 12.92f * l : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
}

/// Random lookups over every filter and footprints from a point to the whole image.
template <class F>
void for_random_lookups(uint32_t seed, F&& f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    for (int i = 0; i < 4000; ++i) {
        const Vec2f uv{u01(rng) * 3.0f - 1.0f, u01(rng) * 3.0f - 1.0f};
        const float width = std::exp2(u01(rng) * 8.0f - 1.0f) / 64.0f;  // 0.5 to 128 texels of 64
        UvFootprint duv{width, 0.3f * width * (u01(rng) - 0.5f), 0.2f * width * (u01(rng) - 0.5f), width * u01(rng)};
        for (TextureFilter filter : {TextureFilter::Nearest, TextureFilter::Bilinear, TextureFilter::Stochastic,
                                     TextureFilter::Trilinear})
            f(uv, duv, filter);
    }
}

}  // namespace

TEST(Texture8Bit, LinearLookupsAgreeWithFloatWithin1Over255) {
    const Pair p = random_pair(64, 64, false, 1);
    ASSERT_EQ(p.u8.levels.size(), 7u);
    EXPECT_EQ(p.u8.data.size() * 4, p.f32.data.size()) << "a quarter of the bytes, pyramid included";
    double worst = 0;
    for_random_lookups(2, [&](const Vec2f& uv, const UvFootprint& duv, TextureFilter filter) {
        const Texel4 a = lookup(p.u8, uv, duv, filter), b = lookup(p.f32, uv, duv, filter);
        worst = std::max({worst, double(std::abs(a.r - b.r)), double(std::abs(a.g - b.g)), double(std::abs(a.b - b.b)),
                          double(std::abs(a.a - b.a))});
    });
    EXPECT_LE(worst, 1.0 / 255.0);
    EXPECT_GT(worst, 0.0) << "the 8-bit pyramid rounds, so some lookup must differ";
}

TEST(Texture8Bit, SrgbLookupsAgreeWithFloatWithin1Over255OfTheirCodes) {
    // An 8-bit sRGB texture's coarse levels are rounded to sRGB codes, so they agree with
    // the float pyramid to within a code where the codes live: after encoding. Level 0
    // decodes the very codes the float image was made from, so it agrees exactly.
    const Pair p = random_pair(64, 64, true, 3);
    double worst = 0, worst_level0 = 0;
    for_random_lookups(4, [&](const Vec2f& uv, const UvFootprint& duv, TextureFilter filter) {
        const Texel4 a = lookup(p.u8, uv, duv, filter), b = lookup(p.f32, uv, duv, filter);
        const double d = std::max({std::abs(srgb_encode(a.r) - srgb_encode(b.r)),
                                   std::abs(srgb_encode(a.g) - srgb_encode(b.g)),
                                   std::abs(srgb_encode(a.b) - srgb_encode(b.b)), std::abs(a.a - b.a)});
        worst = std::max(worst, d);
        if (!is_mip_filter(filter))
            worst_level0 = std::max({worst_level0, double(std::abs(a.r - b.r)), double(std::abs(a.g - b.g)),
                                     double(std::abs(a.b - b.b))});
    });
    EXPECT_LE(worst, 1.0 / 255.0);
    EXPECT_LE(worst_level0, 1e-6);
}

TEST(TextureSrgb, DecodeTableAgreesWithOpenColorIO) {
    // OCIO's own sRGB curve (the one our display transform encodes with, inverted):
    // ExponentWithLinear, gamma 2.4, offset 0.055, applied sRGB -> linear.
    namespace OCIO = OCIO_NAMESPACE;
    auto curve = OCIO::ExponentWithLinearTransform::Create();
    const double gamma[4] = {2.4, 2.4, 2.4, 1.0}, offset[4] = {0.055, 0.055, 0.055, 0.0};
    curve->setGamma(gamma);
    curve->setOffset(offset);
    curve->setDirection(OCIO::TRANSFORM_DIR_FORWARD);
    auto config = OCIO::Config::CreateRaw();
    auto cpu = config->getProcessor(curve)->getDefaultCPUProcessor();
    const float* table = srgb8_to_linear_table();
    double worst = 0;
    for (int i = 0; i < 256; ++i) {
        float rgb[3] = {float(i) / 255.0f, float(i) / 255.0f, float(i) / 255.0f};
        cpu->applyRGB(rgb);
        worst = std::max(worst, double(std::abs(table[i] - rgb[0])));
        ASSERT_NEAR(table[i], rgb[0], 2e-6f + 2e-6f * rgb[0]) << "code " << i;
    }
    EXPECT_EQ(table[0], 0.0f);
    EXPECT_EQ(table[255], 1.0f) << "white stays white, so a white texture loses no light";
    // And OCIO's direction really is decode: mid-grey code 128 is ~0.2159 linear.
    EXPECT_NEAR(table[128], 0.2158605f, 1e-6f);
    (void)worst;
}

namespace {

/// A camera looking down -z at a plane z = 0 from height `d`, and the MIP level a
/// 1024x1024 texture spread over `size` x `size` of that plane gets at the image centre,
/// by the camera ray's differentials and by the approximation later hits use.
struct LevelAt {
    float camera, approximate;
};

LevelAt level_on_plane(float size, int width, int spp) {
    const float d = 4.0f;
    const Camera cam(Vec3f(0, 0, d), Vec3f(0, 0, 0), Vec3f(0, 1, 0), 60.0f, 60.0f);
    const PixelSpread s = cam.pixel_spread(width, width, spp);
    const Texture tex = Texture::make("t", 1024, 1024, TexelFormat::U8, "R");
    Texture pyramid = tex;
    scenes::image::build_mip_pyramid(pyramid);
    const Vec3f p(0.01f, 0.02f, 0.0f), n(0, 0, 1);
    const Vec3f dpdu(size, 0, 0), dpdv(0, size, 0);
    Vec3f dpdx, dpdy;
    camera_dpdxy(s, accel::normalize(p - cam.position()), p, n, dpdx, dpdy);
    LevelAt out;
    out.camera = mip_level(pyramid, uv_footprint(dpdu, dpdv, dpdx, dpdy));
    approximate_dpdxy(s, p, n, dpdx, dpdy);
    out.approximate = mip_level(pyramid, uv_footprint(dpdu, dpdv, dpdx, dpdy));
    return out;
}

}  // namespace

TEST(TextureFootprint, MipLevelFollowsTexelsPerPixel) {
    // The visible width of the plane at the centre: 2 d tan(30 deg) over `width` pixels.
    const int width = 256;
    const float visible = 2.0f * 4.0f * std::tan(30.0f * accel::kPi / 180.0f);
    for (float texels_per_pixel : {1.0f, 64.0f}) {
        // size of the plane the texture covers, so that one pixel spans `texels_per_pixel`.
        const float size = 1024.0f / texels_per_pixel * visible / float(width);
        const LevelAt l = level_on_plane(size, width, 1);
        // log2 of the texels per pixel, less log2(2 / sqrt 12) = 0.79 (the kernel matched to
        // the pixel's box filter), at least 0.
        const float expected = std::max(0.0f, std::log2(texels_per_pixel) - 0.7924813f);
        EXPECT_NEAR(l.camera, expected, 0.05f) << texels_per_pixel << " texels per pixel";
        EXPECT_NEAR(l.approximate, expected, 0.05f) << texels_per_pixel << " texels per pixel, later hit";
    }
    // 16 samples per pixel: each sample's filter is a quarter pixel wide (two levels finer).
    const float size64 = 1024.0f / 64.0f * visible / float(width);
    EXPECT_NEAR(level_on_plane(size64, width, 16).camera, 4.0f - 0.7924813f, 0.05f);
}

TEST(TextureFootprint, LookupAtSixtyFourTexelsPerPixelAveragesTheCheckerboard) {
    // One-texel checks: a point lookup reads black or white, the footprint's level reads
    // their mean (sRGB decoded before averaging: half the light, not code 128).
    Texture t = Texture::make("checks", 256, 256, TexelFormat::U8, "RGB");
    t.srgb = true;
    for (uint32_t y = 0; y < 256; ++y)
        for (uint32_t x = 0; x < 256; ++x)
            for (int c = 0; c < 3; ++c) t.data[(size_t(y) * 256 + x) * 3 + size_t(c)] = ((x + y) & 1) ? 255 : 0;
    scenes::image::build_mip_pyramid(t);
    const UvFootprint wide{64.0f / 256.0f, 0, 0, 64.0f / 256.0f};
    EXPECT_NEAR(mip_level(t, wide), 6.0f - 0.7924813f, 1e-5f);
    const Vec2f uv{0.3f, 0.7f};
    EXPECT_NEAR(lookup(t, uv, wide, TextureFilter::Stochastic).g, 0.5f, 0.5f / 255.0f * 2.4f);
    const float point = lookup(t, uv, wide, TextureFilter::Nearest).g;
    EXPECT_TRUE(point == 0.0f || point == 1.0f);
    EXPECT_NEAR(lookup(t, uv, UvFootprint{}, TextureFilter::Stochastic).g,
                lookup(t, uv, UvFootprint{}, TextureFilter::Bilinear).g, 1e-7f)
        << "no footprint: the full image";
}


TEST(TextureFootprint, StochasticLevelChoiceAveragesToTheBlend) {
    // Level 0 black, level 1 white: the blend at level 0.3 is 0.3. Stochastic reads one
    // level per lookup, the upper one with probability 0.3 (its choice hashes uv), so its
    // mean over many points is 0.3; the blend filter gives 0.3 at every point.
    Texture t = Texture::make("two levels", 4, 4, TexelFormat::U8, "R");
    t.levels.push_back(Texture::Level{2, 2, t.data.size()});
    t.data.resize(t.data.size() + 4, 255);
    const float lod = 0.3f - 1.0f + 0.7924813f;
    ASSERT_NEAR(mip_level(t, lod), 0.3f, 1e-5f);
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uni(0.0f, 1.0f);
    const int n = 20000;
    double sum = 0;
    int both = 0;
    for (int i = 0; i < n; ++i) {
        const Vec2f uv{uni(rng), uni(rng)};
        const float r = lookup(t, uv, lod, TextureFilter::Stochastic).r;
        both += r > 1e-6f && r < 1.0f - 1e-6f;  // bilinear weights sum to 1 within rounding
        sum += r;
        ASSERT_NEAR(lookup(t, uv, lod, TextureFilter::Trilinear).r, 0.3f, 1e-6f);
    }
    EXPECT_EQ(both, 0) << "each lookup reads one level";
    // Binomial: standard deviation sqrt(0.3 * 0.7 / n) = 0.0032; 5 of them.
    EXPECT_NEAR(sum / n, 0.3, 0.016);
}

namespace {

/// A closed box [-1, 1]^3 with uvs tiled 3 times per face, inward-facing.
scenes::Mesh textured_box(uint32_t material) {
    scenes::Mesh m;
    m.material = material;
    const Vec3f c[8] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                        {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
    const int faces[6][4] = {{0, 1, 2, 3}, {4, 7, 6, 5}, {0, 4, 5, 1}, {3, 2, 6, 7}, {0, 3, 7, 4}, {1, 5, 6, 2}};
    for (const auto& f : faces) {
        const uint32_t base = uint32_t(m.positions.size());
        for (int k = 0; k < 4; ++k) m.positions.push_back(c[f[k]]);
        m.uvs.push_back({0, 0});
        m.uvs.push_back({3, 0});
        m.uvs.push_back({3, 3});
        m.uvs.push_back({0, 3});
        for (uint32_t i : {0u, 1u, 2u, 0u, 2u, 3u}) m.indices.push_back(base + i);
    }
    m.pad_positions();
    return m;
}

}  // namespace

TEST(TextureFurnace, TexturedEnclosureConvergesToLeOverOneMinusAlbedo) {
    // The furnace's albedo and emission come through 8-bit sRGB textures (constant, so
    // any filter must return the same value): radiance Le / (1 - a) with a the code's
    // linear value, whatever the filter and footprint.
    const uint8_t code = 188;
    const float a = srgb8_to_linear_table()[code];
    for (TextureFilter filter : {TextureFilter::Nearest, TextureFilter::Bilinear, TextureFilter::Trilinear, TextureFilter::Stochastic}) {
        World w;
        Texture albedo = Texture::make("albedo", 64, 64, TexelFormat::U8, "RGB");
        albedo.srgb = true;
        std::fill(albedo.data.begin(), albedo.data.end(), code);
        scenes::image::build_mip_pyramid(albedo);
        Texture white = Texture::make("white", 16, 16, TexelFormat::U8, "RGB");
        white.srgb = true;
        std::fill(white.data.begin(), white.data.end(), uint8_t(255));
        scenes::image::build_mip_pyramid(white);
        w.scene.textures = {albedo, white};
        scenes::Material m;
        m.albedo = Vec3f(1.0f);
        m.albedo_texture = 0;
        m.emission = Vec3f(1.0f);
        m.emission_texture = 1;
        m.emitter_reflects = true;
        w.scene.materials.push_back(m);
        w.scene.meshes.push_back(textured_box(0));
        IntegratorSettings is;
        is.max_depth = 60;
        is.rr_continue = 0.8f;
        is.texture_filter = filter;
        const Camera cam(Vec3f(0.1f, 0.2f, 0.0f), Vec3f(1, 0.3f, 0.2f), Vec3f(0, 1, 0), 60.0f, 60.0f);
        is.pixel_spread = cam.pixel_spread(32, 32, 1);
        w.build(is);
        const double expected = (1.0 - std::pow(double(a), 61)) / (1.0 - a);
        accel::Ray r;
        r.org = cam.position();
        r.dir = accel::normalize(Vec3f(1, 0.3f, 0.2f) - cam.position());
        const Estimate e = estimate(*w.integrator, *w.accel, r, 20000, 11);
        EXPECT_NEAR(e.mean, expected, 3.0 * e.se + 1e-4) << texture_filter_name(filter) << " se " << e.se;
    }
}

TEST(TextureFurnace, VertexColouredEnclosureConvergesToLeOverOneMinusColour) {
    // glTF's COLOR_0 multiplies the base colour: a white enclosure whose vertices are all
    // coloured c, emitting 1, has radiance Le / (1 - c) per channel (the furnace above with
    // the vertex colour for the texture), with a different c in each channel.
    const Vec3f c{0.3f, 0.6f, 0.8f};
    World w;
    scenes::Material m;
    m.albedo = Vec3f(1.0f);
    m.emission = Vec3f(1.0f);
    m.emitter_reflects = true;
    w.scene.materials.push_back(m);
    scenes::Mesh box = textured_box(0);
    box.uvs.clear();
    box.colors.assign(box.num_vertices(), c);
    w.scene.meshes.push_back(box);
    IntegratorSettings is;
    is.max_depth = 60;
    is.rr_continue = 0.8f;
    w.build(is);
    const accel::Ray r{Vec3f(0.1f, 0.2f, 0.0f), accel::normalize(Vec3f(0.9f, 0.1f, 0.2f)), 0.0f, 1e30f};
    const int n = 20000;
    for (int ch = 0; ch < 3; ++ch) {
        const float a = ch == 0 ? c.x : ch == 1 ? c.y : c.z;
        const double expected = (1.0 - std::pow(double(a), 61)) / (1.0 - a);
        const Estimate e = estimate(*w.integrator, *w.accel, r, n, 11, ch);
        EXPECT_NEAR(e.mean, expected, 3.0 * e.se + 1e-4) << "channel " << ch << " se " << e.se;
    }
}

// A glow map is black but for a few spots. Where ZeroTiles says a lookup reads only zero
// texels, the lookup is exactly zero, under every filter and footprint (its claim is
// what LightSet::emitted skips the lookup on); and it says so for most of the black.
namespace {

/// Texel index i of an axis of n texels as the sampler's wrap continues the image past
/// its edges, for a reference written from the definitions (glTF 2.0, 3.8.4.6): tiled,
/// edge texel stretched, or every other tile mirrored.
int wrapped_index(long i, int n, scenes::TextureWrap w) {
    switch (w) {
        case scenes::TextureWrap::Repeat: return int(((i % n) + n) % n);
        case scenes::TextureWrap::ClampToEdge: return int(std::clamp(i, 0L, long(n) - 1));
        case scenes::TextureWrap::MirroredRepeat: {
            const long m = ((i % (2L * n)) + 2L * n) % (2L * n);
            return int(m < n ? m : 2L * n - 1 - m);
        }
    }
    return 0;
}

/// The bilinear reconstruction of level 0 of a float R texture at an unwrapped uv, over
/// the infinite image the wraps make: the four texel centres around the point, each read
/// through wrapped_index.
float reference_bilinear(const Texture& t, float u, float v) {
    const double x = double(u) * t.width - 0.5, y = double(v) * t.height - 0.5;
    const double x0 = std::floor(x), y0 = std::floor(y), fx = x - x0, fy = y - y0;
    const auto at = [&](long i, long j) {
        float f;
        const size_t k = size_t(wrapped_index(j, int(t.height), t.wrap_t)) * t.width +
                         size_t(wrapped_index(i, int(t.width), t.wrap_s));
        std::memcpy(&f, &t.data[k * 4], 4);
        return double(f);
    };
    const long i = long(x0), j = long(y0);
    return float((1 - fx) * (1 - fy) * at(i, j) + fx * (1 - fy) * at(i + 1, j) + (1 - fx) * fy * at(i, j + 1) +
                 fx * fy * at(i + 1, j + 1));
}

}  // namespace

TEST(TextureWrapModes, BilinearLookupsFollowTheWrappedImage) {
    // Every pair of wraps, at points up to three tiles away: the lookup brings uv into the
    // image and takes its neighbours across an edge by the wrap; the reference reads the
    // infinite wrapped image directly.
    using scenes::TextureWrap;
    Texture t = Texture::make("wrapped", 7, 5, TexelFormat::F32, "R");
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    for (size_t k = 0; k < size_t(7 * 5); ++k) {
        const float f = u01(rng);
        std::memcpy(&t.data[k * 4], &f, 4);
    }
    const TextureWrap all[3] = {TextureWrap::Repeat, TextureWrap::ClampToEdge, TextureWrap::MirroredRepeat};
    for (TextureWrap ws : all)
        for (TextureWrap wt : all) {
            t.wrap_s = ws;
            t.wrap_t = wt;
            for (int i = 0; i < 4000; ++i) {
                const Vec2f uv{u01(rng) * 6.0f - 3.0f, u01(rng) * 6.0f - 3.0f};
                ASSERT_NEAR(lookup(t, uv, kNoFootprint, TextureFilter::Bilinear).r, reference_bilinear(t, uv.x, uv.y),
                            2e-5f)
                    << "wraps " << int(ws) << " " << int(wt) << " at uv " << uv.x << " " << uv.y;
                ASSERT_EQ(lookup_alpha(t, uv), 1.0f);
            }
            // On the edges and the tiles' seams themselves.
            for (float u : {-2.0f, -1.0f, -0.5f, 0.0f, 1.0f, 1.5f, 2.0f, 3.0f})
                for (float v : {-1.0f, 0.0f, 1.0f, 2.0f})
                    EXPECT_NEAR(lookup(t, {u, v}, kNoFootprint, TextureFilter::Bilinear).r, reference_bilinear(t, u, v),
                                2e-5f)
                        << "wraps " << int(ws) << " " << int(wt) << " at uv " << u << " " << v;
        }
    // The clamped edge is the edge texel alone; the repeating one blends the far edge in.
    t.wrap_s = t.wrap_t = TextureWrap::ClampToEdge;
    float corner;
    std::memcpy(&corner, &t.data[0], 4);
    EXPECT_EQ(lookup(t, {0.0f, 0.0f}, kNoFootprint, TextureFilter::Bilinear).r, corner);
    EXPECT_EQ(lookup(t, {-5.0f, -0.25f}, kNoFootprint, TextureFilter::Trilinear).r, corner);
    t.wrap_s = t.wrap_t = TextureWrap::Repeat;
    EXPECT_NE(lookup(t, {0.0f, 0.0f}, kNoFootprint, TextureFilter::Bilinear).r, corner);
}

TEST(TextureWrapModes, AlphaTestReadsTheWrappedTexel) {
    // lookup_alpha is the bilinear lookup's alpha bit for bit under every wrap, and the
    // nearest texel's under a NEAREST magnification filter.
    using scenes::TextureWrap;
    Pair p = random_pair(16, 8, true, 3);
    std::mt19937 rng(12);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    for (TextureWrap w : {TextureWrap::Repeat, TextureWrap::ClampToEdge, TextureWrap::MirroredRepeat})
        for (bool nearest : {false, true}) {
            p.u8.wrap_s = p.u8.wrap_t = w;
            p.u8.magnify_nearest = nearest;
            for (int i = 0; i < 2000; ++i) {
                const Vec2f uv{u01(rng) * 4.0f - 2.0f, u01(rng) * 4.0f - 2.0f};
                ASSERT_EQ(lookup_alpha(p.u8, uv), lookup(p.u8, uv, kNoFootprint, TextureFilter::Bilinear).a);
            }
        }
}

TEST(TextureWrapModes, NearestMagnificationReadsOneTexelUnderATexel) {
    // magFilter NEAREST: a footprint smaller than a texel reads the texel uv falls in,
    // with every filter; a footprint of many texels filters as before.
    Pair p = random_pair(32, 16, false, 4);
    Texture& t = p.f32;
    Texture plain = t;
    t.magnify_nearest = true;
    std::mt19937 rng(13);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    const float under = uv_lod(UvFootprint{0.5f / 32.0f, 0, 0, 0.5f / 32.0f});  // half a texel
    const float wide = uv_lod(UvFootprint{8.0f / 32.0f, 0, 0, 8.0f / 32.0f});   // 8 texels
    for (int i = 0; i < 2000; ++i) {
        const Vec2f uv{u01(rng), u01(rng)};
        const Texel4 texel = fetch(t, 0, std::min(31u, uint32_t(uv.x * 32.0f)), std::min(15u, uint32_t(uv.y * 16.0f)));
        for (TextureFilter f : {TextureFilter::Bilinear, TextureFilter::Trilinear, TextureFilter::Stochastic}) {
            ASSERT_EQ(lookup(t, uv, under, f).r, texel.r);
            ASSERT_EQ(lookup(t, uv, wide, f).g, lookup(plain, uv, wide, f).g);
        }
    }
    // And the plain texture blends neighbours under a texel.
    int blended = 0;
    for (int i = 0; i < 200; ++i) {
        const Vec2f uv{u01(rng), u01(rng)};
        const Texel4 texel = fetch(t, 0, std::min(31u, uint32_t(uv.x * 32.0f)), std::min(15u, uint32_t(uv.y * 16.0f)));
        blended += lookup(plain, uv, under, TextureFilter::Trilinear).r != texel.r;
    }
    EXPECT_GT(blended, 150);
}

TEST(TextureZeroTiles, ZeroOnlyWhereTheLookupIsZero) {
    // Not a multiple of the 16-texel tile, and not square.
    const uint32_t w = 250, h = 190;
    Texture t = Texture::make("glow", w, h, TexelFormat::U8, "RGB");
    t.srgb = true;
    auto light = [&](uint32_t x, uint32_t y) {
        for (int c = 0; c < 3; ++c) t.data[(size_t(y) * w + x) * 3 + size_t(c)] = uint8_t(60 + 60 * c);
    };
    for (uint32_t y = 100; y < 103; ++y)
        for (uint32_t x = 40; x < 43; ++x) light(x, y);
    light(200, 20);
    light(249, 189);  // a corner, so that wrapping supports meet it
    scenes::image::build_mip_pyramid(t);
    const ZeroTiles zt(t);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    int zero = 0, total = 0;
    const scenes::TextureWrap wraps[3] = {scenes::TextureWrap::Repeat, scenes::TextureWrap::ClampToEdge,
                                          scenes::TextureWrap::MirroredRepeat};
    for (int i = 0; i < 20000; ++i) {
        t.wrap_s = wraps[i % 3];
        t.wrap_t = wraps[(i / 3) % 3];
        const Vec2f uv{u01(rng) * 3.0f - 1.0f, u01(rng) * 3.0f - 1.0f};
        const float width = std::exp2(u01(rng) * 10.0f - 2.0f) / float(w);  // 1/4 to 256 texels
        const float lod = uv_lod(UvFootprint{width, 0.0f, 0.0f, width * u01(rng)});
        for (TextureFilter f : {TextureFilter::Nearest, TextureFilter::Bilinear, TextureFilter::Stochastic,
                                TextureFilter::Trilinear}) {
            const bool repeats = t.wrap_s == scenes::TextureWrap::Repeat && t.wrap_t == scenes::TextureWrap::Repeat;
            total += repeats;
            if (!zt.zero(t, uv, lod, f)) continue;
            zero += repeats;
            const Texel4 v = lookup(t, uv, lod, f);
            ASSERT_EQ(v.r + v.g + v.b, 0.0f) << "uv " << uv.x << " " << uv.y << " lod " << lod;
        }
    }
    // (Clamped uvs outside [0, 1] read the edges, where a support always meets one.)
    EXPECT_GT(zero, total / 2) << "zero tiles should answer for most of a black repeating texture";
    t.wrap_s = t.wrap_t = scenes::TextureWrap::Repeat;
    // On a spot, never.
    EXPECT_FALSE(zt.zero(t, {41.5f / float(w), 101.5f / float(h)}, kNoFootprint, TextureFilter::Nearest));
    EXPECT_FALSE(zt.zero(t, {200.5f / float(w), 20.5f / float(h)}, kNoFootprint, TextureFilter::Trilinear));
    // A ZeroTiles of another texture answers nothing.
    EXPECT_FALSE(ZeroTiles().zero(t, {0.5f, 0.5f}, kNoFootprint, TextureFilter::Nearest));
}
