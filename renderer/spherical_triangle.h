// Uniform sampling of the solid angle a triangle subtends (Arvo 1995, "Stratified Sampling
// of Spherical Triangles", SIGGRAPH '95). Emissive triangles close to the point they light
// (the CS184 panel's upper side, 1 cm below the ceiling) make area sampling heavy-tailed:
// its density in solid angle goes as cos / r^2, so the estimate carries 1/r^2 spikes. With
// a uniform density over the spherical triangle only the receiver's cosine varies.
#pragma once

#include "accel/math.h"

namespace renderer {

/// The spherical triangle of a planar triangle seen from a point: unit directions to its
/// vertices, the interior angle at the first and its area (the solid angle). Computed
/// in double: the sampler subtracts angles of similar size when the triangle is small.
class SphericalTriangle {
public:
    /// `valid()` is false when the point lies in the triangle's plane or on a vertex
    /// (no solid angle to sample).
    /// Invalid: nothing to sample. User-provided, so that `return {}` (the far case of
    /// every light sample, LightSet::near_triangle) leaves the vectors unset instead of
    /// clearing 128 bytes, which was half of that function's time.
    SphericalTriangle() {}
    SphericalTriangle(const accel::Vec3f& p, const accel::Vec3f& v0, const accel::Vec3f& v1, const accel::Vec3f& v2);

    bool valid() const { return valid_; }
    /// Solid angle in steradians.
    float solid_angle() const { return float(area_); }
    /// A unit direction, uniform over the spherical triangle for (u1, u2) uniform on
    /// [0,1)^2: u1 picks the area of the sub-triangle A B C' (C' on arc AC), u2 the
    /// point on arc B C' (Arvo's construction, with the cosine of the arc from B to the
    /// sample uniform in [cos(B C'), 1]).
    accel::Vec3f sample(float u1, float u2) const;

private:
    double a_[3], b_[3], c_[3];
    double tc_[3];  ///< unit tangent at A of the arc toward C
    double cos_alpha_ = 1, sin_alpha_ = 0;  ///< the interior angle at A
    double area_ = 0;
    bool valid_ = false;
};

/// Barycentrics (b1 along e1 = v1 - v0, b2 along e2 = v2 - v0) of the point where the
/// ray from p in direction w meets the triangle's plane, clamped into the triangle against
/// rounding (a sampled direction lies inside it up to that); false when the ray is parallel
/// to the plane or leaves it behind.
bool barycentrics_toward(const accel::Vec3f& p, const accel::Vec3f& w, const accel::Vec3f& v0,
                         const accel::Vec3f& e1, const accel::Vec3f& e2, float& b1, float& b2);

}  // namespace renderer
