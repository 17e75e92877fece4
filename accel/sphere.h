// Ray-sphere intersector shared by our backends (and Embree's user geometry).
#pragma once

#include <cmath>

#include "accel/math.h"
#include "accel/ray.h"

namespace accel {

/// Unnormalised outward normal at the point the ray reaches at t: what every backend
/// reports for a sphere hit, from the scene's arrays or from a leaf block alike.
inline Vec3f sphere_normal(const Ray& ray, float t, const Vec3f& center) { return (ray.org + ray.dir * t) - center; }

/// Nearest root of |org + t dir - c|^2 = r^2 with t in [ray.t_min, t_max]; when the ray
/// starts inside the sphere the near root is behind it and the far root is returned.
///
/// Numerically stable form (Haines, Günther, Akenine-Möller, "Precision Improvements for
/// Ray/Sphere Intersection", Ray Tracing Gems 2019, ch. 7): the discriminant is computed
/// from the perpendicular offset of the centre from the ray, not as b^2 - 4ac, and the
/// two roots come from q = -(b + sign(b) sqrt(disc)) so neither suffers cancellation.
inline bool intersect_sphere(const Ray& ray, const Vec3f& center, float radius, float t_max,
                             float& t_out) {
    const Vec3f f = ray.org - center;
    const float a = dot(ray.dir, ray.dir);
    const float b = dot(f, ray.dir);  // half of the usual b
    const float c = dot(f, f) - radius * radius;
    const Vec3f perp = f - ray.dir * (b / a);
    const float disc = a * (radius * radius - dot(perp, perp));
    if (!(disc >= 0.0f)) return false;  // also rejects NaN
    const float q = -(b + std::copysign(std::sqrt(disc), b));
    float t0, t1;
    if (q == 0.0f) {
        t0 = t1 = 0.0f;  // tangent ray whose origin lies on the sphere
    } else {
        t0 = c / q;
        t1 = q / a;
        if (t0 > t1) std::swap(t0, t1);
    }
    if (t0 >= ray.t_min && t0 <= t_max) {
        t_out = t0;
        return true;
    }
    if (t1 >= ray.t_min && t1 <= t_max) {
        t_out = t1;
        return true;
    }
    return false;
}

inline Bounds3f sphere_bounds(const Vec3f& center, float radius) {
    return {center - Vec3f(radius), center + Vec3f(radius)};
}

}  // namespace accel
