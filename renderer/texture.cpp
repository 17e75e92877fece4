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

using scenes::TextureWrap;

/// A uv coordinate brought into [0, 1] by the sampler's wrap (glTF 2.0, 3.8.4.6, after
/// OpenGL's REPEAT, CLAMP_TO_EDGE and MIRRORED_REPEAT); a non-finite coordinate reads the
/// origin.
inline float wrap_coord(float x, TextureWrap w) {
    if (w == TextureWrap::Repeat) [[likely]] {
        const float f = x - std::floor(x);
        return std::isfinite(f) ? f : 0.0f;
    }
    if (!std::isfinite(x)) return 0.0f;
    if (w == TextureWrap::ClampToEdge) return std::clamp(x, 0.0f, 1.0f);
    // Period 2: [0, 1] as it is, [1, 2] reflected.
    const float f = x - 2.0f * std::floor(0.5f * x);
    return f <= 1.0f ? f : std::max(0.0f, 2.0f - f);
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
struct TexelIndex {
    uint32_t x, y;
};
inline TexelIndex nearest_texel(const Texture::Level& l, float u, float v) {
    return {std::min(l.width - 1, uint32_t(u * float(l.width))), std::min(l.height - 1, uint32_t(v * float(l.height)))};
}
template <TexelFormat F, int NC, int NCOL>
inline void nearest(const Texture& t, uint32_t level, float u, float v, float w, float* acc) {
    const Texture::Level& l = t.levels[level];
    const auto [x, y] = nearest_texel(l, u, v);
    add_texel<F, NC, NCOL>(t.data.data() + l.offset + (size_t(y) * l.width + x) * (NC * kBytes(F)), w, acc);
}

/// The four texel centres around uv in a level, and uv's place between them. Across an
/// edge the neighbour is the opposite edge's texel for a repeating axis and the edge
/// texel itself for a clamped or mirrored one (the mirror image of the texel beside the
/// edge is that texel).
struct Corners {
    int x0, y0, x1, y1;
    float fx, fy;
};
/// One axis: i0 in [-1, n - 1] (from a coordinate in [0, 1]) to the pair of texels.
[[gnu::always_inline]] inline void edge_pair(int& i0, int& i1, int n, TextureWrap w) {
    i0 = std::min(i0, n - 1);
    if (w == TextureWrap::Repeat) [[likely]] {
        i1 = i0 + 1 == n ? 0 : i0 + 1;
        if (i0 < 0) i0 += n;
    } else {
        i1 = std::min(i0 + 1, n - 1);
        i0 = std::max(i0, 0);
    }
}
[[gnu::always_inline]] inline Corners corners(const Texture& t, const Texture::Level& l, float u, float v) {
    const float x = u * float(l.width) - 0.5f, y = v * float(l.height) - 0.5f;
    const float x0f = std::floor(x), y0f = std::floor(y);
    Corners c{int(x0f), int(y0f), 0, 0, x - x0f, y - y0f};
    edge_pair(c.x0, c.x1, int(l.width), t.wrap_s);
    edge_pair(c.y0, c.y1, int(l.height), t.wrap_t);
    return c;
}

/// Bilinear between the four texel centres around uv, wrapping at the edges. Inlined
/// into every kernel, so that a trilinear lookup is one call with one accumulator.
template <TexelFormat F, int NC, int NCOL>
[[gnu::always_inline]] inline void bilinear(const Texture& t, uint32_t level, float u, float v, float w, float* acc) {
    constexpr size_t tb = NC * kBytes(F);
    const Texture::Level& l = t.levels[level];
    const Corners c = corners(t, l, u, v);
    const uint8_t* base = t.data.data() + l.offset;
    const size_t row = size_t(l.width) * tb;
    const uint8_t* r0 = base + size_t(c.y0) * row;
    const uint8_t* r1 = base + size_t(c.y1) * row;
    const float wx1 = c.fx, wx0 = 1.0f - c.fx, wy1 = w * c.fy, wy0 = w - wy1;
    add_texel<F, NC, NCOL>(r0 + size_t(c.x0) * tb, wx0 * wy0, acc);
    add_texel<F, NC, NCOL>(r0 + size_t(c.x1) * tb, wx1 * wy0, acc);
    add_texel<F, NC, NCOL>(r1 + size_t(c.x0) * tb, wx0 * wy1, acc);
    add_texel<F, NC, NCOL>(r1 + size_t(c.x1) * tb, wx1 * wy1, acc);
}

/// A random number in [0, 1) for stochastic texture filtering (Pharr, Wronski, Salvi,
/// Fajardo, "Filtering After Shading With Stochastic Texture Filtering", I3D 2024,
/// section 3) that picks one of the two levels a trilinear lookup blends, l0 + 1
/// with probability d. The expected value is the blend, while a lookup reads four texels
/// instead of eight.
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

/// Whether a footprint of `lod` (uv_lod) covers less than a texel of level 0 along the
/// image's longer side: OpenGL's magnification (lambda <= 0, the specification's 3.9.11),
/// where a magFilter NEAREST sampler reads one texel. A lookup without a footprint
/// (kNoFootprint) is a point, and so magnified.
inline bool magnified(const Texture& t, float lod) {
    const Texture::Level& l = t.levels[0];
    // floor(log2) of the longer side, as mip_level counts a pyramid's levels.
    return lod + float(31 - __builtin_clz(std::max(l.width, l.height) | 1u)) <= 0.0f;
}

/// One filtered lookup at wrapped (u, v), with the texel layout known at compile time.
template <TexelFormat F, int NC, int NCOL>
[[gnu::always_inline]] inline void filter(const Texture& t, float u, float v, float lod, TextureFilter f, float* acc) {
    if (f == TextureFilter::Nearest || (t.magnify_nearest && magnified(t, lod))) {
        nearest<F, NC, NCOL>(t, 0, u, v, 1.0f, acc);
        return;
    }
    if (f == TextureFilter::Bilinear) {
        bilinear<F, NC, NCOL>(t, 0, u, v, 1.0f, acc);
        return;
    }
    const float level = mip_level(t, lod);
    const uint32_t l0 = uint32_t(level);
    const float d = level - float(l0);
    // mip_level clamps to the top level, so l0 + 1 exists whenever d > 0.
    if (!(d > 0.0f)) {
        bilinear<F, NC, NCOL>(t, l0, u, v, 1.0f, acc);
    } else if (f == TextureFilter::Stochastic) {
        bilinear<F, NC, NCOL>(t, level_choice(u, v) < d ? l0 + 1 : l0, u, v, 1.0f, acc);
    } else {
        bilinear<F, NC, NCOL>(t, l0, u, v, 1.0f - d, acc);
        bilinear<F, NC, NCOL>(t, l0 + 1, u, v, d, acc);
    }
}

int srgb_channels(const Texture& t) { return t.srgb ? (t.slot[3] >= 0 ? t.channels - 1 : t.channels) : 0; }

/// The kernel a texture's layout selects: format, stored channels and sRGB channels
/// (sRGB applies to 8-bit texels only; decode_texture decodes wider ones at load).
constexpr int kernel_key(TexelFormat f, int nc, int ncol) { return (int(f) * 8 + nc) * 8 + ncol; }
inline int kernel_key(const Texture& t) {
    return kernel_key(t.format, t.channels, t.format == TexelFormat::U8 ? srgb_channels(t) : 0);
}

/// Calls body.template operator()<F, NC, NCOL>() for the texture's layout: one switch
/// per lookup, each instance with its channel loop unrolled and no sRGB test. False for
/// a layout no loader makes.
template <class Body>
[[gnu::always_inline]] inline bool dispatch(const Texture& t, Body&& body) {
#define PT_TEXEL_KERNEL(F, NC, NCOL)                          \
    case kernel_key(TexelFormat::F, NC, NCOL):                \
        body.template operator()<TexelFormat::F, NC, NCOL>(); \
        return true;
#define PT_TEXEL_KERNELS(F) \
    PT_TEXEL_KERNEL(F, 1, 0) PT_TEXEL_KERNEL(F, 2, 0) PT_TEXEL_KERNEL(F, 3, 0) PT_TEXEL_KERNEL(F, 4, 0)
    switch (kernel_key(t)) {
        PT_TEXEL_KERNELS(U8)
        PT_TEXEL_KERNELS(U16)
        PT_TEXEL_KERNELS(F16)
        PT_TEXEL_KERNELS(F32)
        PT_TEXEL_KERNEL(U8, 1, 1)
        PT_TEXEL_KERNEL(U8, 2, 1)
        PT_TEXEL_KERNEL(U8, 2, 2)
        PT_TEXEL_KERNEL(U8, 3, 2)
        PT_TEXEL_KERNEL(U8, 3, 3)
        PT_TEXEL_KERNEL(U8, 4, 3)
        default: return false;
    }
#undef PT_TEXEL_KERNELS
#undef PT_TEXEL_KERNEL
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
    float acc[4] = {0, 0, 0, 0};
    const uint8_t* p = t.texel(level, x, y);
    if (!dispatch(t, [&]<TexelFormat F, int NC, int NCOL>() { add_texel<F, NC, NCOL>(p, 1.0f, acc); }))
        return Texel4{1.0f, 1.0f, 1.0f, 1.0f};
    return to_source_channels(t, acc);
}

Texel4 lookup(const Texture& t, const Vec2f& uv, float lod, TextureFilter f) {
    if (t.empty()) return Texel4{1.0f, 1.0f, 1.0f, 1.0f};
    float acc[4] = {0, 0, 0, 0};
    const float u = wrap_coord(uv.x, t.wrap_s), v = wrap_coord(uv.y, t.wrap_t);
    if (!dispatch(t, [&]<TexelFormat F, int NC, int NCOL>() { filter<F, NC, NCOL>(t, u, v, lod, f, acc); }))
        return Texel4{1.0f, 1.0f, 1.0f, 1.0f};
    return to_source_channels(t, acc);
}

float lookup_alpha(const Texture& t, const Vec2f& uv) {
    if (t.empty() || t.slot[3] < 0) return 1.0f;
    const Texture::Level& l = t.levels[0];
    const float u = wrap_coord(uv.x, t.wrap_s), v = wrap_coord(uv.y, t.wrap_t);
    if (t.magnify_nearest) [[unlikely]] {
        // nearest()'s texel, as a NEAREST sampler's colour reads it at magnification.
        const auto [x, y] = nearest_texel(l, u, v);
        return fetch(t, 0, x, y).a;
    }
    const Corners c = corners(t, l, u, v);
    const size_t tb = t.texel_bytes(), at = size_t(t.slot[3]) * scenes::texel_format_bytes(t.format);
    const uint8_t* base = t.data.data() + l.offset + at;
    const auto alpha = [&](int x, int y) -> float {
        const uint8_t* p = base + (size_t(y) * l.width + size_t(x)) * tb;
        switch (t.format) {
            case TexelFormat::U8: return float(p[0]) * (1.0f / 255.0f);
            case TexelFormat::U16: {
                uint16_t u;
                std::memcpy(&u, p, 2);
                return float(u) * (1.0f / 65535.0f);
            }
            case TexelFormat::F16: {
                uint16_t u;
                std::memcpy(&u, p, 2);
                return scenes::half_to_float(u);
            }
            case TexelFormat::F32: {
                float f;
                std::memcpy(&f, p, 4);
                return f;
            }
        }
        return 1.0f;
    };
    // bilinear's weights, products and order of additions, so the value is its bits.
    const float wx1 = c.fx, wx0 = 1.0f - c.fx, wy1 = c.fy, wy0 = 1.0f - wy1;
    float a = 0.0f;
    a += wx0 * wy0 * alpha(c.x0, c.y0);
    a += wx1 * wy0 * alpha(c.x1, c.y0);
    a += wx0 * wy1 * alpha(c.x0, c.y1);
    a += wx1 * wy1 * alpha(c.x1, c.y1);
    return a;
}

ZeroTiles::ZeroTiles(const Texture& t) {
    if (t.empty()) return;
    const Texture::Level& l = t.levels[0];
    tiles_x_ = (l.width + kTile - 1) / kTile;
    tiles_y_ = (l.height + kTile - 1) / kTile;
    const size_t row = size_t(tiles_x_) + 1;
    sat_.assign(row * (size_t(tiles_y_) + 1), 0);
    const size_t tb = t.texel_bytes();
    std::vector<uint8_t> nonzero(size_t(tiles_x_) * tiles_y_, 0);
    for (uint32_t y = 0; y < l.height; ++y) {
        const uint8_t* p = t.data.data() + l.offset + size_t(y) * l.width * tb;
        for (uint32_t x = 0; x < l.width; ++x, p += tb)
            for (size_t b = 0; b < tb; ++b)
                if (p[b]) {
                    nonzero[size_t(y / kTile) * tiles_x_ + x / kTile] = 1;
                    break;
                }
    }
    for (uint32_t y = 0; y < tiles_y_; ++y)
        for (uint32_t x = 0; x < tiles_x_; ++x)
            sat_[(y + 1) * row + x + 1] = nonzero[size_t(y) * tiles_x_ + x] + sat_[y * row + x + 1] +
                                          sat_[(y + 1) * row + x] - sat_[y * row + x];
}

bool ZeroTiles::zero(const Texture& t, const Vec2f& uv, float lod, TextureFilter f) const {
    if (sat_.empty() || t.empty()) return false;
    const Texture::Level& l = t.levels[0];
    if ((l.width + kTile - 1) / kTile != tiles_x_ || (l.height + kTile - 1) / kTile != tiles_y_) return false;
    // The coarsest level the filter reads. A texel of level k averages the 2^k x 2^k
    // texels of level 0 under it (scenes/image/image.cpp), and the texels around uv at level k
    // lie within 2.5 of its texels of uv: so within 2.5 * 2^k + 1 texels of level 0
    // (the rounding of a level's size down only moves them toward uv).
    const float level = is_mip_filter(f) ? mip_level(t, lod) : 0.0f;
    const float reach = 2.5f * float(1u << std::min(30, int(std::ceil(level)))) + 1.0f;
    const float cx = wrap_coord(uv.x, t.wrap_s) * float(l.width), cy = wrap_coord(uv.y, t.wrap_t) * float(l.height);
    const float x0 = cx - reach, x1 = cx + reach, y0 = cy - reach, y1 = cy + reach;
    // A support that wraps round an edge: not worth the split.
    if (!(x0 >= 0.0f && y0 >= 0.0f && x1 < float(l.width) && y1 < float(l.height))) return false;
    const size_t row = size_t(tiles_x_) + 1;
    const uint32_t tx0 = uint32_t(x0) / kTile, tx1 = uint32_t(x1) / kTile + 1;
    const uint32_t ty0 = uint32_t(y0) / kTile, ty1 = uint32_t(y1) / kTile + 1;
    return sat_[ty1 * row + tx1] - sat_[ty0 * row + tx1] - sat_[ty1 * row + tx0] + sat_[ty0 * row + tx0] == 0;
}

Texel4 lookup(const Texture& t, const Vec2f& uv, const UvFootprint& duv, TextureFilter filter) {
    return lookup(t, uv, uv_lod(duv), filter);
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
    if (s.orthographic) {
        // Parallel rays: an offset differential and no direction one (Igehy's eq. 10 with
        // dD = 0), the origin's step carried along the ray onto the plane.
        dpdx = transfer(s.forward, 1.0f, s.right * s.dx, n);
        dpdy = transfer(s.forward, 1.0f, s.up * s.dy, n);
        return;
    }
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
    // An orthographic camera's pixel has the same footprint everywhere along its ray.
    if (s.orthographic) return camera_dpdxy(s, s.forward, p, n, dpdx, dpdy);
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
