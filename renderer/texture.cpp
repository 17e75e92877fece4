#include "renderer/texture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace renderer {

TextureFilter parse_texture_filter(const std::string& name) {
    if (name == "nearest") return TextureFilter::Nearest;
    if (name == "bilinear") return TextureFilter::Bilinear;
    if (name == "trilinear") return TextureFilter::Trilinear;
    if (name == "stochastic") return TextureFilter::Stochastic;
    throw std::invalid_argument("unknown texture filter '" + name + "' (expected nearest, bilinear, trilinear or stochastic)");
}

const char* texture_filter_name(TextureFilter f) {
    switch (f) {
        case TextureFilter::Nearest: return "nearest";
        case TextureFilter::Bilinear: return "bilinear";
        case TextureFilter::Trilinear: return "trilinear";
        case TextureFilter::Stochastic: return "stochastic";
    }
    return "?";
}

namespace {
// Bound before main: lookups read the table without a guard.
const std::array<float, 256>& kSrgb8 = scenes::srgb8_to_linear();
}  // namespace

const float* srgb8_to_linear_table() { return kSrgb8.data(); }

namespace {

using scenes::Texture;
using scenes::TexelFormat;

/// uv wrapped into [0, 1]; a non-finite coordinate reads the origin.
inline float wrap01(float x) {
    const float f = x - std::floor(x);
    return std::isfinite(f) ? f : 0.0f;
}

/// Stored channels of one texel, weighted, added to acc. The first NCOL stored channels
/// are sRGB-encoded (decoded before filtering: filtering averages light, not codes).
template <TexelFormat F, int NC, int NCOL>
inline void add_texel(const uint8_t* p, float w, float* acc) {
    for (int c = 0; c < NC; ++c) {
        float v;
        if constexpr (F == TexelFormat::U8) {
            v = c < NCOL ? kSrgb8[p[c]] : float(p[c]) * (1.0f / 255.0f);
        } else if constexpr (F == TexelFormat::U16) {
            uint16_t u;
            std::memcpy(&u, p + 2 * c, 2);
            v = float(u) * (1.0f / 65535.0f);
        } else if constexpr (F == TexelFormat::F16) {
            uint16_t u;
            std::memcpy(&u, p + 2 * c, 2);
            v = scenes::half_to_float(u);
        } else {
            std::memcpy(&v, p + 4 * c, 4);
        }
        acc[c] += w * v;
    }
}

constexpr size_t kBytes(TexelFormat f) { return scenes::texel_format_bytes(f); }

/// The texel uv falls in, as the renderer always read textures: x = floor(u w).
template <TexelFormat F, int NC, int NCOL>
inline void nearest(const Texture& t, uint32_t level, float u, float v, float w, float* acc) {
    const Texture::Level& l = t.levels[level];
    const uint32_t x = std::min(l.width - 1, uint32_t(u * float(l.width)));
    const uint32_t y = std::min(l.height - 1, uint32_t(v * float(l.height)));
    add_texel<F, NC, NCOL>(t.data.data() + l.offset + (size_t(y) * l.width + x) * (NC * kBytes(F)), w, acc);
}

/// The four texel centres around uv in a level, wrapping at the edges, and uv's place
/// between them.
struct Corners {
    int x0, y0, x1, y1;
    float fx, fy;
};
inline Corners corners(const Texture::Level& l, float u, float v) {
    const float x = u * float(l.width) - 0.5f, y = v * float(l.height) - 0.5f;
    const float x0f = std::floor(x), y0f = std::floor(y);
    Corners c{int(x0f), int(y0f), 0, 0, x - x0f, y - y0f};
    // u in [0, 1] puts x0 in [-1, width - 1].
    if (c.x0 < 0) c.x0 += int(l.width);
    if (c.y0 < 0) c.y0 += int(l.height);
    c.x0 = std::min(c.x0, int(l.width) - 1);
    c.y0 = std::min(c.y0, int(l.height) - 1);
    c.x1 = c.x0 + 1 == int(l.width) ? 0 : c.x0 + 1;
    c.y1 = c.y0 + 1 == int(l.height) ? 0 : c.y0 + 1;
    return c;
}

/// Bilinear between the four texel centres around uv, wrapping at the edges.
template <TexelFormat F, int NC, int NCOL>
inline void bilinear(const Texture& t, uint32_t level, float u, float v, float w, float* acc) {
    constexpr size_t tb = NC * kBytes(F);
    const Texture::Level& l = t.levels[level];
    const Corners c = corners(l, u, v);
    const uint8_t* base = t.data.data() + l.offset;
    const size_t row = size_t(l.width) * tb;
    const uint8_t* r0 = base + size_t(c.y0) * row;
    const uint8_t* r1 = base + size_t(c.y1) * row;
    add_texel<F, NC, NCOL>(r0 + size_t(c.x0) * tb, w * (1 - c.fx) * (1 - c.fy), acc);
    add_texel<F, NC, NCOL>(r0 + size_t(c.x1) * tb, w * c.fx * (1 - c.fy), acc);
    add_texel<F, NC, NCOL>(r1 + size_t(c.x0) * tb, w * (1 - c.fx) * c.fy, acc);
    add_texel<F, NC, NCOL>(r1 + size_t(c.x1) * tb, w * c.fx * c.fy, acc);
}

/// A random number in [0, 1) for stochastic texture filtering (Pharr, Wronski, Salvi,
/// Fajardo, "Filtering After Shading With Stochastic Texture Filtering", I3D 2024,
/// section 3) that picks one of the two levels a trilinear lookup blends, l0 + 1
/// with probability d. The expected value is the blend, while a lookup reads four texels
/// instead of eight: on a large image every level is a separate cache miss, and the
/// second one made trilinear slower than the nearest-texel lookups it replaced.
/// The number hashes the lookup's uv bits (an LCG step and xorshift mixing, after pcg2d
/// in Jarzynski and Olano, "Hash Functions for GPU Rendering", JCGT 2020): the samples
/// of a pixel hit different points and so draw independently, the textures of one hit
/// make the same choice, and a render stays deterministic.
inline float level_choice(float u, float v) {
    uint32_t a, b;
    std::memcpy(&a, &u, 4);
    std::memcpy(&b, &v, 4);
    a = a * 1664525u + 1013904223u;
    b = b * 1664525u + 1013904223u;
    a += b * 1664525u;
    b += a * 1664525u;
    a ^= a >> 16;
    b ^= b >> 16;
    return float(a >> 8) * 0x1p-24f;
}

template <TexelFormat F, int NC, int NCOL>
void filter(const Texture& t, float u, float v, float lod, TextureFilter f, float* acc) {
    switch (f) {
        case TextureFilter::Nearest: nearest<F, NC, NCOL>(t, 0, u, v, 1.0f, acc); return;
        case TextureFilter::Bilinear: bilinear<F, NC, NCOL>(t, 0, u, v, 1.0f, acc); return;
        case TextureFilter::Stochastic: {
            const float level = mip_level(t, lod);
            const uint32_t l0 = uint32_t(level);
            const float d = level - float(l0);
            if (d <= 0.0f || l0 + 1 >= t.levels.size())
                bilinear<F, NC, NCOL>(t, std::min<uint32_t>(l0, uint32_t(t.levels.size() - 1)), u, v, 1.0f, acc);
            else
                bilinear<F, NC, NCOL>(t, level_choice(u, v) < d ? l0 + 1 : l0, u, v, 1.0f, acc);
            return;
        }
        case TextureFilter::Trilinear: {
            const float level = mip_level(t, lod);
            const uint32_t l0 = uint32_t(level);
            const float d = level - float(l0);
            if (d <= 0.0f || l0 + 1 >= t.levels.size()) {
                bilinear<F, NC, NCOL>(t, std::min<uint32_t>(l0, uint32_t(t.levels.size() - 1)), u, v, 1.0f, acc);
            } else {
                bilinear<F, NC, NCOL>(t, l0, u, v, 1.0f - d, acc);
                bilinear<F, NC, NCOL>(t, l0 + 1, u, v, d, acc);
            }
            return;
        }
    }
}

using FilterFn = void (*)(const Texture&, float, float, float, TextureFilter, float*);
using FetchFn = void (*)(const uint8_t*, float, float*);

struct Kernels {
    FilterFn filter = nullptr;
    FetchFn fetch = nullptr;
};

template <TexelFormat F, int NC, int NCOL>
constexpr Kernels kernels() {
    return {filter<F, NC, NCOL>, add_texel<F, NC, NCOL>};
}

/// One instance per (format, stored channels, sRGB channels): the inner loops unroll and
/// the sRGB test leaves them.
template <TexelFormat F>
Kernels pick_kernels(int nc, int ncol) {
    switch (nc * 8 + ncol) {
        case 1 * 8 + 0: return kernels<F, 1, 0>();
        case 2 * 8 + 0: return kernels<F, 2, 0>();
        case 3 * 8 + 0: return kernels<F, 3, 0>();
        case 4 * 8 + 0: return kernels<F, 4, 0>();
        case 1 * 8 + 1: return kernels<F, 1, 1>();
        case 2 * 8 + 1: return kernels<F, 2, 1>();
        case 2 * 8 + 2: return kernels<F, 2, 2>();
        case 3 * 8 + 2: return kernels<F, 3, 2>();
        case 3 * 8 + 3: return kernels<F, 3, 3>();
        case 4 * 8 + 3: return kernels<F, 4, 3>();
        default: return {};
    }
}

int srgb_channels(const Texture& t) { return t.srgb ? (t.slot[3] >= 0 ? t.channels - 1 : t.channels) : 0; }

Kernels pick(const Texture& t) {
    // sRGB applies to 8-bit texels only (decode_texture decodes wider ones at load).
    const int ncol = t.format == TexelFormat::U8 ? srgb_channels(t) : 0;
    switch (t.format) {
        case TexelFormat::U8: return pick_kernels<TexelFormat::U8>(t.channels, ncol);
        case TexelFormat::U16: return pick_kernels<TexelFormat::U16>(t.channels, ncol);
        case TexelFormat::F16: return pick_kernels<TexelFormat::F16>(t.channels, ncol);
        case TexelFormat::F32: return pick_kernels<TexelFormat::F32>(t.channels, ncol);
    }
    return {};
}

Texel4 to_source_channels(const Texture& t, const float* acc) {
    Texel4 out;
    if (t.slot[0] >= 0) out.r = acc[t.slot[0]];
    if (t.slot[1] >= 0) out.g = acc[t.slot[1]];
    if (t.slot[2] >= 0) out.b = acc[t.slot[2]];
    if (t.slot[3] >= 0) out.a = acc[t.slot[3]];
    return out;
}

}  // namespace

// The level whose trilinear kernel has the variance of the pixel's box filter. A level-L
// texel is a box of 2^L texels and bilinear reconstruction adds a tent of half-width 2^L:
// variance (2^L)^2 (1/12 + 1/6) = (2^L)^2 / 4. The box over a pixel of rho texels has
// rho^2 / 12. Equal when 2^L = rho (2 / sqrt 12): L = log2 rho - 0.79. Reading level
// log2 rho instead (OpenGL's rule) filters with twice the pixel's spread and visibly
// blurs where a texel is about a pixel wide.
constexpr float kBoxMatch = -0.7924813f;  // log2(2 / sqrt(12))

float uv_lod(const UvFootprint& duv) {
    const float rho2 = std::max(duv.dudx * duv.dudx + duv.dvdx * duv.dvdx, duv.dudy * duv.dudy + duv.dvdy * duv.dvdy);
    if (!(rho2 > 0.0f)) return kNoFootprint;
    if (!std::isfinite(rho2)) return 1e30f;
    return 0.5f * std::log2(rho2);
}

float mip_level(const Texture& t, float lod) {
    if (t.levels.size() <= 1) return 0.0f;
    // The pyramid's top level is 1 texel across the image's longer side: levels - 1 is
    // log2 of that side (of the power of two below it, for other sizes), as pbrt-v4's
    // MIPMap::Filter counts levels.
    const float top = float(t.levels.size() - 1);
    const float level = top + lod + kBoxMatch;
    return level > 0.0f ? std::min(top, level) : 0.0f;
}

float mip_level(const Texture& t, const UvFootprint& duv) { return mip_level(t, uv_lod(duv)); }

Texel4 fetch(const Texture& t, uint32_t level, uint32_t x, uint32_t y) {
    const Kernels k = pick(t);
    if (!k.fetch) return Texel4{1.0f, 1.0f, 1.0f, 1.0f};
    float acc[4] = {0, 0, 0, 0};
    k.fetch(t.texel(level, x, y), 1.0f, acc);
    return to_source_channels(t, acc);
}

Texel4 lookup(const Texture& t, const Vec2f& uv, float lod, TextureFilter filter) {
    if (t.empty()) return Texel4{1.0f, 1.0f, 1.0f, 1.0f};
    const Kernels k = pick(t);
    if (!k.filter) return Texel4{1.0f, 1.0f, 1.0f, 1.0f};
    float acc[4] = {0, 0, 0, 0};
    k.filter(t, wrap01(uv.x), wrap01(uv.y), lod, filter, acc);
    return to_source_channels(t, acc);
}

Texel4 lookup(const Texture& t, const Vec2f& uv, const UvFootprint& duv, TextureFilter filter) {
    return lookup(t, uv, uv_lod(duv), filter);
}

namespace {
/// Starts loading the 2x2 texels a bilinear lookup at (u, v) reads from `level`.
inline void prefetch_level(const Texture& t, uint32_t level, float u, float v) {
    const Texture::Level& l = t.levels[level];
    const size_t tb = t.texel_bytes();
    const Corners c = corners(l, u, v);
    const uint8_t* base = t.data.data() + l.offset;
    const size_t row = size_t(l.width) * tb;
    for (const size_t r : {size_t(c.y0) * row, size_t(c.y1) * row}) {
        __builtin_prefetch(base + r + size_t(c.x0) * tb);
        // The texel's last byte: the pair may straddle a cache line.
        __builtin_prefetch(base + r + size_t(c.x1) * tb + tb - 1);
    }
}
}  // namespace

void prefetch(const Texture& t, const Vec2f& uv, float lod, TextureFilter filter) {
    if (t.empty()) return;
    const float u = wrap01(uv.x), v = wrap01(uv.y);
    if (filter == TextureFilter::Nearest || filter == TextureFilter::Bilinear) {
        prefetch_level(t, 0, u, v);
        return;
    }
    const float level = mip_level(t, lod);
    const uint32_t l0 = std::min<uint32_t>(uint32_t(level), uint32_t(t.levels.size() - 1));
    const float d = level - float(l0);
    const bool two = d > 0.0f && l0 + 1 < t.levels.size();
    if (!two) {
        prefetch_level(t, l0, u, v);
    } else if (filter == TextureFilter::Trilinear) {
        prefetch_level(t, l0, u, v);
        prefetch_level(t, l0 + 1, u, v);
    } else {
        prefetch_level(t, level_choice(u, v) < d ? l0 + 1 : l0, u, v);
    }
}

namespace {
/// The change of the hit point on the plane (p, n) when the ray's direction D (any
/// length, from the camera) changes by dD, to first order (Igehy 1999, eq. 10 with a zero
/// offset differential): t dD minus its part along D that leaves the plane.
Vec3f transfer(const Vec3f& D, float t, const Vec3f& dD, const Vec3f& n) {
    const float dn = accel::dot(D, n);
    if (!(std::abs(dn) > 0.0f)) return Vec3f(0.0f);
    return (dD - D * (accel::dot(dD, n) / dn)) * t;
}
}  // namespace

void camera_dpdxy(const PixelSpread& s, const Vec3f& dir, const Vec3f& p, const Vec3f& n, Vec3f& dpdx,
                  Vec3f& dpdy) {
    // The camera's unnormalised direction has unit length along `forward`; t scales it
    // to the hit.
    const float along = accel::dot(dir, s.forward);
    if (!(along > 0.0f)) {
        dpdx = dpdy = Vec3f(0.0f);
        return;
    }
    const Vec3f D = dir / along;
    const float t = accel::dot(p - s.position, s.forward);
    dpdx = transfer(D, t, s.right * s.dx, n);
    dpdy = transfer(D, t, s.up * s.dy, n);
}

void approximate_dpdxy(const PixelSpread& s, const Vec3f& p, const Vec3f& n, Vec3f& dpdx, Vec3f& dpdy) {
    const Vec3f to = p - s.position;
    const float dist = accel::length(to);
    if (!(dist > 0.0f) || !std::isfinite(dist)) {
        dpdx = dpdy = Vec3f(0.0f);
        return;
    }
    const Vec3f dir = to / dist;
    // The camera's axes turned to look at p: right made perpendicular to the new view
    // direction (pbrt-v4 rotates the camera frame the same way, RotateFromTo).
    Vec3f ex = s.right - dir * accel::dot(s.right, dir);
    float len = accel::length(ex);
    if (!(len > 1e-4f)) {
        ex = s.up - dir * accel::dot(s.up, dir);
        len = accel::length(ex);
        if (!(len > 0.0f)) {
            dpdx = dpdy = Vec3f(0.0f);
            return;
        }
    }
    ex = ex / len;
    const Vec3f ey = accel::cross(dir, ex);
    dpdx = transfer(dir, dist, ex * s.dx, n);
    dpdy = transfer(dir, dist, ey * s.dy, n);
}

UvFootprint uv_footprint(const Vec3f& dpdu, const Vec3f& dpdv, const Vec3f& dpdx, const Vec3f& dpdy) {
    const float a00 = accel::dot(dpdu, dpdu), a01 = accel::dot(dpdu, dpdv), a11 = accel::dot(dpdv, dpdv);
    float inv = 1.0f / (a00 * a11 - a01 * a01);
    if (!std::isfinite(inv)) inv = 0.0f;
    const float bx0 = accel::dot(dpdu, dpdx), bx1 = accel::dot(dpdv, dpdx);
    const float by0 = accel::dot(dpdu, dpdy), by1 = accel::dot(dpdv, dpdy);
    auto clamp = [](float x) { return std::isfinite(x) ? std::clamp(x, -1e8f, 1e8f) : 0.0f; };
    UvFootprint f;
    f.dudx = clamp((a11 * bx0 - a01 * bx1) * inv);
    f.dvdx = clamp((a00 * bx1 - a01 * bx0) * inv);
    f.dudy = clamp((a11 * by0 - a01 * by1) * inv);
    f.dvdy = clamp((a00 * by1 - a01 * by0) * inv);
    return f;
}

}  // namespace renderer
