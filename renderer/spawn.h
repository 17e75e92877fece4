// The one place secondary rays leave surfaces, instead of epsilons scattered over the
// integrators.
//
// Two policies, selectable (IntegratorSettings::offset, `pathtracer --offset`):
//
//  - ErrorBound (default): pbrt-v4's approach (Pharr, Jakob, Humphreys, "Physically
//    Based Rendering", 4th ed., section 6.8 "Managing Rounding Error", OffsetRayOrigin
//    and SpawnRayTo). Every hit point carries a conservative per-axis bound `p_err` on
//    the distance between the computed point and the exact surface (see
//    renderer/interaction.cpp). The origin is pushed along the geometric normal by
//    dot(|n|, p_err): the projection of the error box onto the normal, so the whole box
//    and therefore the exact surface lies behind the new origin. The sum is then rounded
//    away from the surface with next_float_up/down so that the rounding of the sum
//    itself cannot put the origin back inside the box. The offset scales with the
//    actual error, which is what makes it work at 1e-6 as well as at 1e7 and far from
//    the origin, where a fixed epsilon is either far too big (light leaks through thin
//    walls) or far too small (acne).
//
//  - Epsilon: the previous plain scale-relative epsilon, kept to measure against
//    (benchmarks/extremes.cpp).
#pragma once

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "accel/ray.h"

namespace renderer {

using accel::Vec3f;

enum class OffsetMode : uint8_t { ErrorBound, Epsilon };

inline const char* offset_mode_name(OffsetMode m) {
    return m == OffsetMode::ErrorBound ? "error-bound" : "epsilon";
}

/// gamma(n) = n u / (1 - n u), u = 2^-24 the unit roundoff of float: bounds the relative
/// error of n successive floating-point operations (Higham 2002; pbrt-v4 6.8.1).
constexpr float gamma_bound(int n) {
    constexpr float u = std::numeric_limits<float>::epsilon() * 0.5f;
    return (float(n) * u) / (1.0f - float(n) * u);
}

/// Next representable float toward +inf / -inf (pbrt-v4 NextFloatUp/Down); -0 and +0
/// step to the smallest denormal, infinities and NaN stay.
/// Stepping the bit pattern (as pbrt-v4 does) instead of calling nextafter: every shadow
/// and bounce ray takes three to six, and libm's nextafterf is an out-of-line call. One
/// test filters infinities and NaN; zero is moved to the side it steps away from, so the
/// step itself is a select on the sign.
inline float next_float_up(float v) {
    if (!(v < std::numeric_limits<float>::infinity())) return v;  // +inf and NaN
    if (v == 0.0f) v = 0.0f;                                         // -0 steps up like +0
    const uint32_t b = std::bit_cast<uint32_t>(v);
    return std::bit_cast<float>(v >= 0.0f ? b + 1 : b - 1);
}
inline float next_float_down(float v) {
    if (!(v > -std::numeric_limits<float>::infinity())) return v;  // -inf and NaN
    if (v == 0.0f) v = -0.0f;
    const uint32_t b = std::bit_cast<uint32_t>(v);
    return std::bit_cast<float>(v <= 0.0f ? b + 1 : b - 1);
}

/// Plain epsilon: a few ulps of the hit point's largest coordinate (rounding of p grows
/// with |p|) plus a tiny fraction of the scene's size. The pre-issue-8 policy.
inline float spawn_offset(const Vec3f& p, float scene_scale) {
    const float m = accel::max_component(accel::vabs(p));
    return 0x1p-19f * m + 1e-6f * scene_scale;
}

/// pbrt-v4 OffsetRayOrigin: p moved along n, to the side w points into, by the
/// projection of the error box on n, each coordinate then rounded away from p.
/// `n` must be unit length (dot(|n|, p_err) is a distance only for unit n).
inline Vec3f offset_ray_origin(const Vec3f& p, const Vec3f& p_err, const Vec3f& n, const Vec3f& w) {
    const float d = accel::dot(accel::vabs(n), p_err);
    const Vec3f side = accel::dot(w, n) < 0.0f ? -n : n;
    Vec3f po = p + side * d;
    // Round away from p so the (rounded) addition cannot land back inside the box.
    // Unlike pbrt-v4 we step by the sign of the normal, not of the offset, so a point
    // with a zero bound (an exact point, e.g. on the plane z = 0 built from vertices
    // with z = 0) still moves one ulp off its surface: our intersectors accept t = 0,
    // where pbrt's triangle test rejects t <= its own error bound on t.
    for (int i = 0; i < 3; ++i) {
        if (side[i] > 0.0f)
            po[i] = next_float_up(po[i]);
        else if (side[i] < 0.0f)
            po[i] = next_float_down(po[i]);
    }
    return po;
}

/// Origin for a ray leaving surface point p (unit geometric normal ng, error bound p_err)
/// in direction d, under `mode`.
inline Vec3f spawn_origin(const Vec3f& p, const Vec3f& p_err, const Vec3f& ng, const Vec3f& d,
                          float scene_scale, OffsetMode mode) {
    if (mode == OffsetMode::ErrorBound) return offset_ray_origin(p, p_err, ng, d);
    const float off = spawn_offset(p, scene_scale);
    return p + ng * (accel::dot(ng, d) >= 0 ? off : -off);
}

/// t_min for a ray spawned from a point with error box p_err: hits closer to the origin
/// than the box's extent (|p_err|_1, at least its half-diagonal) are within the
/// uncertainty of the point itself and are rejected. This stands in for pbrt-v4's
/// conservative "t > deltaT" test inside its triangle intersector (6.8.6), which our
/// intersectors (accel/triangle.h) do not have: without it, a point on an edge between
/// two faces, offset along one face's normal, still sits on the other face's plane and
/// hits it at t ~ 0 (measured by benchmarks/extremes).
inline float spawn_t_min(const Vec3f& p_err, const Vec3f& d) {
    const float len = accel::length(d);
    const float t = (p_err.x + p_err.y + p_err.z) / len;
    return len > 0.0f && t >= 0.0f && std::isfinite(t) ? t : 0.0f;
}

/// The unbounded ray from spawn_origin along d, beginning at t_min.
inline accel::Ray spawn_from(const Vec3f& p, const Vec3f& p_err, const Vec3f& ng, const Vec3f& d,
                             float scene_scale, OffsetMode mode, float t_min) {
    accel::Ray r;
    r.org = spawn_origin(p, p_err, ng, d, scene_scale, mode);
    r.dir = d;
    r.t_min = t_min;
    r.t_max = accel::kInfinity;
    return r;
}

/// Ray from surface point p in direction d, starting on the side d leaves into.
inline accel::Ray spawn_ray(const Vec3f& p, const Vec3f& p_err, const Vec3f& ng, const Vec3f& d,
                            float scene_scale, OffsetMode mode) {
    return spawn_from(p, p_err, ng, d, scene_scale, mode,
                      mode == OffsetMode::ErrorBound ? spawn_t_min(p_err, d) : 0.0f);
}

/// spawn_ray for a direction of unit length up to rounding (a path's bounce directions):
/// t_min is then the error box's extent itself, without spawn_t_min's square root and
/// division, which were a third of a bounce ray's set-up on CBbunny ("unit bounce rays"
/// in renderer/README.md). The factor 1 + 2^-18 covers a length up to 3.8e-6 below 1
/// (the boxes' diffuse, mirror, glass and microfacet bounces measured within 1.1e-6).
inline accel::Ray spawn_unit_ray(const Vec3f& p, const Vec3f& p_err, const Vec3f& ng, const Vec3f& d,
                                 float scene_scale, OffsetMode mode) {
    const float t = (p_err.x + p_err.y + p_err.z) * (1.0f + 0x1p-18f);
    return spawn_from(p, p_err, ng, d, scene_scale, mode,
                      mode == OffsetMode::ErrorBound && t >= 0.0f && std::isfinite(t) ? t : 0.0f);
}

/// Relative shortening of every shadow segment (t runs 0..1): pbrt-v4's ShadowEpsilon.
/// Covers the rounding of t itself in the intersectors, which the point bounds do not,
/// and, when the target's normal is unknown, part of the grazing approach to the
/// target's surface. Scale-free, since t is relative to the segment.
inline constexpr float kShadowEpsilon = 1e-4f;

/// Shadow segment from surface point p toward `target` (a point on a light or another
/// surface, with its own error bound target_err). dir is unnormalised, t runs 0..1.
///
/// ErrorBound: pbrt-v4 SpawnRayTo. The origin is offset as for spawn_ray. The far end
/// must stop short of the target's error box too, or the segment may report the
/// light's own surface as the occluder: with the target's unit normal known
/// (target_n != 0) the end is first offset off that surface by OffsetRayOrigin, as
/// pbrt-v4 does; in every case the end then backs off along the segment by the box's
/// full extent (|err|_1, which covers the box whatever the segment's direction) and
/// keeps t <= 1 - kShadowEpsilon.
///
/// Epsilon: the previous behaviour (back off by twice the plain epsilon at the end).
inline accel::Ray spawn_segment(const Vec3f& p, const Vec3f& p_err, const Vec3f& ng, const Vec3f& target,
                                const Vec3f& target_err, float scene_scale, OffsetMode mode,
                                const Vec3f& target_n = Vec3f(0.0f)) {
    accel::Ray r;
    r.org = spawn_origin(p, p_err, ng, target - p, scene_scale, mode);
    r.t_min = 0.0f;
    if (mode == OffsetMode::Epsilon) {
        r.dir = target - r.org;
        const float len = accel::length(r.dir);
        const float end_off = spawn_offset(target, scene_scale);
        r.t_max = len > 0 ? std::max(0.0f, 1.0f - 2.0f * end_off / len) : 0.0f;
        return r;
    }
    const bool has_n = target_n.x != 0.0f || target_n.y != 0.0f || target_n.z != 0.0f;
    Vec3f end = target;
    if (has_n) {
        // The intersectors round relative to the segment's own extent too (vertices are
        // taken relative to the origin, Woop et al. 2013): a segment arriving at a
        // grazing angle meets the target's plane within about gamma(n) |segment| of its
        // end whatever the cosine, so the end must clear the plane by that much as well.
        // Measured in tests/stability (Lights.*): without it, 2,298 of 20,000 light
        // samples arriving at cosines down to 1e-5 were shadowed by the light itself.
        // The segment's 1-norm bounds its length from above (by at most sqrt 3) without
        // a square root.
        const Vec3f d = accel::vabs(target - r.org);
        const Vec3f grow(gamma_bound(8) * (d.x + d.y + d.z));
        end = offset_ray_origin(target, target_err + grow, target_n, r.org - target);
    }
    r.dir = end - r.org;
    // One square root and one division for both ends: t_min is spawn_t_min's, and the
    // far end backs off by the target's whole error box even when its normal moved the
    // end off the surface: the normal offset clears the target's own plane only, and a
    // target near an edge (within its box of the neighbouring face, as computed points on
    // convex corners often are) would otherwise be reached through that face. This is
    // the mirror of spawn_t_min at the near end.
    const float len = accel::length(r.dir);
    const float inv = len > 0.0f ? 1.0f / len : 0.0f;
    const float near = (p_err.x + p_err.y + p_err.z) * inv;
    r.t_min = near >= 0.0f && std::isfinite(near) ? near : 0.0f;
    const float back = target_err.x + target_err.y + target_err.z;
    r.t_max = len > 0 ? std::max(0.0f, 1.0f - kShadowEpsilon - back * inv) : 0.0f;
    if (!(r.t_max >= 0.0f)) r.t_max = 0.0f;  // NaN in, no hit out
    return r;
}

/// Pre-issue-8 signatures: plain epsilon, no error bounds.
inline accel::Ray spawn_ray(const Vec3f& p, const Vec3f& ng, const Vec3f& d, float scene_scale) {
    return spawn_ray(p, Vec3f(0.0f), ng, d, scene_scale, OffsetMode::Epsilon);
}
inline accel::Ray spawn_segment(const Vec3f& p, const Vec3f& ng, const Vec3f& target, float scene_scale) {
    return spawn_segment(p, Vec3f(0.0f), ng, target, Vec3f(0.0f), scene_scale, OffsetMode::Epsilon);
}

}  // namespace renderer
