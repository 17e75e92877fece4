// Rebuilds what integrators need at a hit from the small Hit record and the scene.
#pragma once

#include "accel/ray.h"
#include "renderer/scene_geometry.h"
#include "renderer/spawn.h"
#include "renderer/texture.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec2f;
using accel::Vec3f;

struct Interaction {
    Vec3f p;        ///< hit point
    /// Conservative per-axis bound on |p - exact surface point| from floating-point
    /// rounding (pbrt-v4, "Physically Based Rendering" 4th ed., 6.8): spawned rays start
    /// outside this box (renderer/spawn.h).
    Vec3f p_error;
    Vec3f ng;       ///< unit geometric normal (triangle winding / sphere outward)
    Vec3f ns;       ///< unit shading normal: interpolated file normals, else ng
    Vec2f uv;       ///< texture coordinates if the mesh stores them
    /// The vertex colour at the hit (scenes::Mesh::colors, glTF COLOR_0), which multiplies
    /// the base colour; white where the mesh has none.
    Vec3f color{1.0f};
    /// d p / d u and d p / d v of the triangle's texture mapping, only for textured
    /// materials (a normal map's tangent frame; the texture footprint); zero otherwise.
    Vec3f dpdu{0.0f}, dpdv{0.0f};
    /// The pixel's footprint in uv and how to filter with it (set_texture_footprint);
    /// untextured hits keep the default, which no lookup reads.
    float lod = kNoFootprint;  ///< uv_lod of the footprint
    TextureFilter filter = TextureFilter::Nearest;
    uint32_t material = 0;
    float t = 0;
    bool sphere = false;  ///< analytic sphere (emits on both sides)
};

/// Texture value at uv (nearest texel, wrapping); white for kNoTexture. For points with
/// no footprint (a point sampled on an emitter).
Vec3f texel(const scenes::Scene& scene, uint32_t texture, const Vec2f& uv);

/// Texture channels R, G, B, A at a hit, filtered by its footprint (it.filter, it.lod);
/// white for kNoTexture.
Texel4 texel4(const scenes::Scene& scene, uint32_t texture, const Interaction& it);
inline Vec3f texel(const scenes::Scene& scene, uint32_t texture, const Interaction& it) {
    if (texture == scenes::kNoTexture) return Vec3f(1.0f);
    return texel4(scene, texture, it).rgb();
}

/// The base colour at a hit: the material's albedo times its texture and the vertex
/// colour (glTF 2.0, 3.9.2: baseColorFactor x baseColorTexture x COLOR_0). Every BSDF,
/// AOV and unlit surface that shows the base colour reads it here.
inline Vec3f base_colour(const scenes::Scene& scene, const scenes::Material& m, const Interaction& it) {
    return m.albedo * texel(scene, m.albedo_texture, it) * it.color;
}

/// Does material m read any texture?
inline bool is_textured(const scenes::Material& m) {
    return m.albedo_texture != scenes::kNoTexture || m.emission_texture != scenes::kNoTexture ||
           m.metallic_roughness_texture != scenes::kNoTexture || m.normal_texture != scenes::kNoTexture ||
           m.transmission_texture != scenes::kNoTexture;
}

/// Sets it.lod and it.filter for a hit on a textured triangle. `camera_ray`: the hit was
/// found by the camera ray with direction `dir` (its differentials are transferred
/// exactly); later hits use the approximate footprint (renderer/texture.h). Without a
/// valid spread the footprint stays a point (level 0).
void set_texture_footprint(Interaction& it, const PixelSpread& spread, TextureFilter filter, bool camera_ray,
                           const Vec3f& dir);

/// Hit point rebuilt from the barycentrics of triangle (p0, p1, p2), with its error
/// bound: pbrt-v4 Triangle::InteractionFromIntersection, p = b0 p0 + b1 p1 + b2 p2 and
/// p_error = gamma(7) (|b0 p0| + |b1 p1| + |b2 p2|). Rebuilding p from barycentrics
/// rather than org + t dir keeps the error independent of the ray's length (t's own
/// rounding error would otherwise scale with the distance travelled).
inline void triangle_point(const Vec3f& p0, const Vec3f& p1, const Vec3f& p2, float u, float v, Vec3f& p,
                           Vec3f& p_error) {
    const float b0 = 1.0f - u - v;
    const Vec3f a = p0 * b0, b = p1 * u, c = p2 * v;
    p = a + b + c;
    p_error = (accel::vabs(a) + accel::vabs(b) + accel::vabs(c)) * gamma_bound(7);
}

/// Hit point re-projected onto the sphere (centre c, radius r), with its error bound:
/// pbrt-v4 Sphere::InteractionFromIntersection re-projects pHit *= r / |pHit| in object
/// space, p_error = gamma(5) |pHit|; our spheres live in world space, so adding the
/// centre back costs one more rounding, bounded by gamma(1) (|c| + |pHit|).
void sphere_point(const Vec3f& c, float r, const Vec3f& p_hit, Vec3f& p, Vec3f& p_error);

/// An instance's object-to-world transform as hits and light samples on it need it: points
/// (with their rounding error), tangent vectors, and normals.
struct Placement {
    const accel::Affine3f& m;  ///< object to world: p' = L p + t
    /// N = sign(det L) cof(L) = |det L| L^-T, columns c1 x c2, c2 x c0, c0 x c1 of L's
    /// columns c0, c1, c2: normals transform by the inverse transpose (pbrt-v4, 4th ed.,
    /// 3.10.3 "Normals"), and the positive factor |det L| goes with the renormalisation.
    /// The sign makes a mirrored placement's normal that of its flattened copy, whose
    /// winding scenes::flatten_instances swaps (glTF 2.0, 3.7.4), i.e. the
    /// transformation of the object's normal, never its reversal.
    Vec3f n0, n1, n2;
    bool mirrors = false;  ///< det L < 0

    explicit Placement(const accel::Affine3f& object_to_world);
    Vec3f point(const Vec3f& p) const { return m.point(p); }
    Vec3f vector(const Vec3f& v) const { return m.vector(v); }
    /// N n, unnormalised (|det L| |L^-T n|).
    Vec3f normal(const Vec3f& n) const { return n0 * n.x + n1 * n.y + n2 * n.z; }
    /// A point with per-axis rounding bound `p_err` carried to world space, with the
    /// bound of the result: pbrt-v4's Transform::operator()(Point3fi) (Pharr, Jakob,
    /// Humphreys, "Physically Based Rendering", 4th ed., 6.8.6 "Transforming points with
    /// error bounds"): gamma(3) (|L| |p| + |t|) for the rounding of the transform itself
    /// plus (gamma(3) + 1) |L| p_err for the error the point already carried.
    void point(const Vec3f& p, const Vec3f& p_err, Vec3f& out, Vec3f& out_err) const;
};

Interaction make_interaction(const scenes::Scene& scene, const SceneGeometry& geometry,
                             const accel::Ray& ray, const accel::Hit& hit);
/// The same into an existing interaction, every field written: the path's vertex is
/// overwritten in place, where assigning the returned one cleared a temporary
/// (`rep stos`) and copied it (together 20 % of make_interaction's time on CBbunny).
void make_interaction(const scenes::Scene& scene, const SceneGeometry& geometry, const accel::Ray& ray,
                      const accel::Hit& hit, Interaction& it);

}  // namespace renderer
