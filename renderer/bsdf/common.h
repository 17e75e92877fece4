// What every BSDF in renderer/bsdf/ shares: the local shading frame (z = shading normal,
// oriented toward wo, so wo.z > 0 always) and the sample record. Each BSDF is a small
// value type with f, pdf and sample (pbrt-v4 BxDF, "Physically Based Rendering" 4th ed.,
// 9.1); renderer/bsdf/bsdf.h dispatches on a tag, never through a virtual call.
#pragma once

#include <algorithm>
#include <cmath>

#include "accel/math.h"

namespace renderer::bsdf {

using accel::Vec3f;
using accel::kPi;
using accel::kInvPi;

inline float abs_cos(const Vec3f& w) { return std::abs(w.z); }
inline bool same_side(const Vec3f& a, const Vec3f& b) { return a.z * b.z > 0.0f; }
inline Vec3f reflect_z(const Vec3f& wo) { return {-wo.x, -wo.y, wo.z}; }
inline Vec3f reflect(const Vec3f& wo, const Vec3f& m) { return m * (2.0f * accel::dot(wo, m)) - wo; }
inline float sqr(float x) { return x * x; }
inline float luminance(const Vec3f& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

/// Refracts wo (pointing away from the surface, on m's side) through a surface with
/// normal m and relative index eta = eta_far / eta_near. False on total internal
/// reflection.
inline bool refract(const Vec3f& wo, const Vec3f& m, float eta, Vec3f& wt) {
    const float cos_i = accel::dot(m, wo);
    const float sin2_t = std::max(0.0f, 1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f) return false;
    const float cos_t = std::sqrt(1.0f - sin2_t);
    wt = -wo / eta + m * (cos_i / eta - cos_t);
    return true;
}

/// One sampled direction. For a non-delta lobe `pdf` is the solid-angle density of wi
/// and `f` the BSDF value; for a delta lobe `pdf` is the discrete probability of the lobe
/// chosen and `f` is zero. `weight` = f |cos wi| / pdf in both cases: what the path
/// throughput is multiplied by.
struct Sample {
    Vec3f wi;
    Vec3f f;
    Vec3f weight;
    float pdf = 0.0f;
    bool delta = false;
    /// For a transmitted wi, the relative index crossed (far side over wo's side), 1 for
    /// reflection: the path's radiance was scaled by 1/eta^2, which Russian roulette undoes
    /// (pbrt-v4 PathIntegrator's etaScale).
    float eta = 1.0f;
};

}  // namespace renderer::bsdf
