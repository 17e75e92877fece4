// Warps from the unit square to directions, with their densities (solid angle).
#pragma once

#include <algorithm>
#include <cmath>

#include "accel/math.h"

namespace renderer {

using accel::Vec3f;

/// Orthonormal basis around unit n (Duff et al. 2017, "Building an Orthonormal Basis,
/// Revisited"): branch-free and stable for every n, including n = -z.
inline void onb(const Vec3f& n, Vec3f& t, Vec3f& b) {
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z);
    const float c = n.x * n.y * a;
    t = {1.0f + sign * n.x * n.x * a, sign * c, -sign * n.x};
    b = {c, sign + n.y * n.y * a, -n.y};
}

inline Vec3f to_world(const Vec3f& local, const Vec3f& n) {
    Vec3f t, b;
    onb(n, t, b);
    return t * local.x + b * local.y + n * local.z;
}

inline Vec3f uniform_sphere(float u1, float u2) {
    const float z = 1.0f - 2.0f * u1;
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    const float phi = 2.0f * accel::kPi * u2;
    return {r * std::cos(phi), r * std::sin(phi), z};
}

/// Uniform over the hemisphere around +z; pdf = 1 / (2 pi).
inline Vec3f uniform_hemisphere(float u1, float u2) {
    const float z = u1;
    const float r = std::sqrt(std::max(0.0f, 1.0f - z * z));
    const float phi = 2.0f * accel::kPi * u2;
    return {r * std::cos(phi), r * std::sin(phi), z};
}
inline constexpr float kUniformHemispherePdf = 1.0f / (2.0f * accel::kPi);

/// Cosine-weighted around +z (Malley's method); pdf = cos(theta) / pi.
inline Vec3f cosine_hemisphere(float u1, float u2) {
    const float r = std::sqrt(u1);
    const float phi = 2.0f * accel::kPi * u2;
    return {r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - u1))};
}

/// Uniform barycentrics (b1, b2) of a triangle from the unit square by Heitz's
/// low-distortion map (Heitz 2019, "A Low-Distortion Map Between Triangle and Square"):
/// it shears the square onto the triangle instead of folding its upper half over, so
/// neighbouring sample points stay neighbours and a stratified set stays stratified
/// (the fold overlays two half sets; "Area-sampled light triangles" in renderer/README.md).
inline void uniform_triangle(float u1, float u2, float& b1, float& b2) {
    if (u2 > u1) {
        b1 = 0.5f * u1;
        b2 = u2 - b1;
    } else {
        b2 = 0.5f * u2;
        b1 = u1 - b2;
    }
}

}  // namespace renderer
