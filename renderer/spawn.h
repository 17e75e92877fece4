// The one place secondary rays leave surfaces, instead of epsilons scattered over the
// integrators.
#pragma once

#include <algorithm>
#include <cmath>

#include "accel/ray.h"

namespace renderer {

using accel::Vec3f;

/// Offset of a spawned origin along the geometric normal: a few ulps of the hit point's
/// largest coordinate (rounding of p grows with |p|) plus a tiny fraction of the scene's
/// size, so it works at any scale and far from the origin.
inline float spawn_offset(const Vec3f& p, float scene_scale) {
    const float m = accel::max_component(accel::vabs(p));
    return 0x1p-19f * m + 1e-6f * scene_scale;
}

/// Ray from surface point p (geometric normal ng) in direction d, starting on the side d
/// leaves into.
inline accel::Ray spawn_ray(const Vec3f& p, const Vec3f& ng, const Vec3f& d, float scene_scale) {
    const float off = spawn_offset(p, scene_scale);
    accel::Ray r;
    r.org = p + ng * (accel::dot(ng, d) >= 0 ? off : -off);
    r.dir = d;
    r.t_min = 0.0f;
    r.t_max = accel::kInfinity;
    return r;
}

/// Shadow segment from p toward `target` (a point on a light), stopping just short of it;
/// dir is unnormalised, so t runs 0..1.
inline accel::Ray spawn_segment(const Vec3f& p, const Vec3f& ng, const Vec3f& target, float scene_scale) {
    accel::Ray r = spawn_ray(p, ng, target - p, scene_scale);
    r.dir = target - r.org;
    const float len = accel::length(r.dir);
    const float end_off = spawn_offset(target, scene_scale);
    r.t_max = len > 0 ? std::max(0.0f, 1.0f - 2.0f * end_off / len) : 0.0f;
    return r;
}

}  // namespace renderer
