// Texture lookups filtered by the pixel's footprint, and the ray differentials that give
// that footprint.
//
// Filtering follows Williams, "Pyramidal parametrics" (SIGGRAPH 1983): a MIP pyramid built
// at load time (scenes/image/image.h) and a trilinear lookup whose level follows the
// log2 of the footprint's longer side in texels (the length rule of the OpenGL
// specification, 3.9.11 in 3.0, rather than pbrt-v4's max-component width), lowered by
// 0.79 so that the trilinear kernel's variance is the pixel box filter's (texture.cpp
// says why): the level is 0 up to 1.7 texels per pixel and 5.2 at 64.
// Levels are counted from the image's longer side, as pbrt-v4 does; a non-square image's
// shorter axis is then filtered as if it were as fine as the longer one.
//
// The footprint comes from ray differentials (Igehy, "Tracing ray differentials",
// SIGGRAPH 1999) as pbrt-v4 approximates them (Pharr, Jakob, Humphreys, "Physically Based
// Rendering" 4th ed., 5.2.4 and 10.1.1): exact transfer of the pinhole camera's
// differentials to a camera ray's hit, and Camera::Approximate_dp_dxy at every later hit
// (the footprint the camera's pixel would have at that point, seen from the camera), so
// no differential is carried through the BSDFs. Both shrink with the sample count by
// max(1/8, 1/sqrt(spp)), as pbrt-v4 does: the pixel's samples already average across the
// pixel, and a filter a whole pixel wide on top of that would blur.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "accel/math.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec2f;
using accel::Vec3f;

/// How textures are read: nearest texel of the full image (no filtering; the renderer's
/// behaviour before MIP maps), bilinear on the full image, or trilinear on the MIP pyramid
/// at the ray-differential footprint: Trilinear reads the two levels around it and blends
/// them (Williams 1983); Stochastic reads one of the two, chosen at random with the blend's
/// weight (texture.cpp, level_choice: the blend in expectation at half the memory traffic,
/// after Pharr et al. 2024), at the price of a little noise at low sample counts.
enum class TextureFilter : uint8_t { Nearest, Bilinear, Trilinear, Stochastic };
inline bool is_mip_filter(TextureFilter f) {
    return f == TextureFilter::Stochastic || f == TextureFilter::Trilinear;
}

/// "nearest" | "bilinear" | "trilinear" | "stochastic"; throws std::invalid_argument
/// naming the value.
TextureFilter parse_texture_filter(const std::string& name);
const char* texture_filter_name(TextureFilter f);

/// d(u, v)/dx and d(u, v)/dy at a hit: uv units per pixel step. All zero: a point.
struct UvFootprint {
    float dudx = 0, dvdx = 0, dudy = 0, dvdy = 0;
};

/// A texture's source channels R, G, B, A (linear; channels the texture does not store
/// read 0, alpha 1).
struct Texel4 {
    float r = 0, g = 0, b = 0, a = 1;
    Vec3f rgb() const { return {r, g, b}; }
};

/// log2 of the footprint's longer side in uv units (the length rule above); kNoFootprint
/// for a point. Computed once per hit: each texture's level is its pyramid height plus
/// this, so a lookup takes no logarithm.
inline constexpr float kNoFootprint = -1e30f;
float uv_lod(const UvFootprint& duv);

/// Filtered lookup at uv (wrapped by the texture's sampler, Texture::wrap_s / wrap_t) for
/// a footprint of `lod` (uv_lod). Nearest and bilinear read level 0 and ignore it, except
/// that a Texture::magnify_nearest texture reads its nearest texel wherever the footprint
/// is under a texel.
Texel4 lookup(const scenes::Texture& t, const Vec2f& uv, float lod, TextureFilter filter);
Texel4 lookup(const scenes::Texture& t, const Vec2f& uv, const UvFootprint& duv, TextureFilter filter);

/// lookup(t, uv, kNoFootprint, Bilinear).a, bit for bit, reading the alpha channel alone
/// (1 where the texture stores none): the alpha test of masked geometry, called per candidate hit
/// (renderer/scene_geometry.h), where decoding the colour channels too cost the time.
float lookup_alpha(const scenes::Texture& t, const Vec2f& uv);

/// Where a texture holds only zero texels, by 16x16-texel tiles of level 0: a
/// summed-area table (Crow, SIGGRAPH 1984) of the tiles with a nonzero texel, so any
/// rectangle is answered with four reads. A lookup whose support lies in zero tiles
/// returns exactly 0 (the pyramid's levels average level 0), so a glow map, black over
/// most of a model, is read only where it glows (the emission check of
/// LightSet::emitted; "zero tiles" in renderer/README.md).
class ZeroTiles {
public:
    ZeroTiles() = default;
    explicit ZeroTiles(const scenes::Texture& t);
    /// True when lookup(t, uv, lod, filter) reads only zero texels; false when it may
    /// not (and for a texture this was not built from).
    bool zero(const scenes::Texture& t, const Vec2f& uv, float lod, TextureFilter filter) const;
    bool built() const { return !sat_.empty(); }

private:
    static constexpr uint32_t kTile = 16;
    uint32_t tiles_x_ = 0, tiles_y_ = 0;
    std::vector<uint32_t> sat_;  ///< (tiles_x_ + 1) x (tiles_y_ + 1), row 0 and column 0 zero
};

/// One texel of one level, unfiltered (x < that level's width, y < its height).
Texel4 fetch(const scenes::Texture& t, uint32_t level, uint32_t x, uint32_t y);

/// The continuous MIP level (0 = full resolution) trilinear filtering reads for a
/// footprint, clamped to the pyramid: levels - 1 + lod, the longer side of the image
/// setting the scale (pbrt-v4 MIPMap::Filter does the same).
float mip_level(const scenes::Texture& t, float lod);
float mip_level(const scenes::Texture& t, const UvFootprint& duv);

/// 8-bit sRGB code to linear (IEC 61966-2-1), the 256-entry table lookups decode with.
const float* srgb8_to_linear_table();

/// The camera's per-pixel spread, for footprints (Camera::pixel_spread): the pinhole's
/// position and frame, and the change of the unnormalised direction (sensor at distance
/// 1 along `forward`) per pixel step in x and in y, already scaled for the sample count.
struct PixelSpread {
    Vec3f position, right, up, forward;
    float dx = 0, dy = 0;
    /// An orthographic camera's: every ray runs along `forward`, and dx, dy are the
    /// change of its origin along right and up per pixel step, in world units.
    bool orthographic = false;
    bool valid() const { return dx > 0 && dy > 0; }
};

/// dp/dx, dp/dy at the point p (plane normal n) hit by the camera ray with normalised
/// direction dir: Igehy's transfer of a pinhole's direction differentials to the tangent
/// plane at p (offset differentials are zero at a pinhole; a thin lens is treated as its
/// pinhole, as its blur dominates any texture filter).
void camera_dpdxy(const PixelSpread& s, const Vec3f& dir, const Vec3f& p, const Vec3f& n, Vec3f& dpdx,
                  Vec3f& dpdy);

/// pbrt-v4 Camera::Approximate_dp_dxy: the footprint at p of a camera pixel looking
/// straight at p from the camera's position, for hits of rays that carry no differentials.
void approximate_dpdxy(const PixelSpread& s, const Vec3f& p, const Vec3f& n, Vec3f& dpdx, Vec3f& dpdy);

/// uv derivatives from the surface's dp/du, dp/dv and dp/dx, dp/dy: the least-squares
/// solution of dp/dx = dp/du du/dx + dp/dv dv/dx (pbrt-v4
/// SurfaceInteraction::ComputeDifferentials), clamped so that a grazing hit gives a wide
/// but finite footprint.
UvFootprint uv_footprint(const Vec3f& dpdu, const Vec3f& dpdv, const Vec3f& dpdx, const Vec3f& dpdy);

}  // namespace renderer
