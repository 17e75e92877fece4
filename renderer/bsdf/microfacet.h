// Fresnel terms and microfacet distributions shared by the BSDFs that use them (kept
// apart from the BSDFs as pbrt-v4 util/scattering.h does). Directions are in the local
// shading frame, z = macro-surface normal.
#pragma once

#include "renderer/bsdf/common.h"

namespace renderer::bsdf {

/// Unpolarised Fresnel reflectance of a smooth dielectric boundary. cos_i is measured on
/// the incident side's normal; eta = eta_transmitted / eta_incident. Returns 1 on total
/// internal reflection. (pbrt-v4 FrDielectric.)
inline float fresnel_dielectric(float cos_i, float eta) {
    cos_i = std::clamp(cos_i, -1.0f, 1.0f);
    if (cos_i < 0) {
        eta = 1.0f / eta;
        cos_i = -cos_i;
    }
    const float sin2_t = (1.0f - cos_i * cos_i) / (eta * eta);
    if (sin2_t >= 1.0f) return 1.0f;
    const float cos_t = std::sqrt(std::max(0.0f, 1.0f - sin2_t));
    const float r_par = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    const float r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    return 0.5f * (r_par * r_par + r_perp * r_perp);
}

/// Conductor Fresnel reflectance for one channel with complex index eta + i k, in the
/// form the CS184 3-2 microfacet uses (the common approximation of Rs and Rp for an
/// air-conductor interface, as pbrt-v2 FrCond); stays within [0, 1].
inline float fresnel_conductor_channel(float cos_i, float eta, float k) {
    const float c = std::clamp(std::abs(cos_i), 0.0f, 1.0f);
    const float e2k2 = eta * eta + k * k;
    const float two_ec = 2.0f * eta * c;
    const float rs = (e2k2 - two_ec + c * c) / (e2k2 + two_ec + c * c);
    const float rp = (e2k2 * c * c - two_ec + 1.0f) / (e2k2 * c * c + two_ec + 1.0f);
    return 0.5f * (rs + rp);
}
inline Vec3f fresnel_conductor(float cos_i, const Vec3f& eta, const Vec3f& k) {
    return {fresnel_conductor_channel(cos_i, eta.x, k.x), fresnel_conductor_channel(cos_i, eta.y, k.y),
            fresnel_conductor_channel(cos_i, eta.z, k.z)};
}

/// Schlick's approximation (Schlick 1994), as glTF 2.0's metallic-roughness model uses.
inline Vec3f fresnel_schlick(const Vec3f& f0, float cos_i) {
    const float m = std::clamp(1.0f - std::abs(cos_i), 0.0f, 1.0f);
    const float m5 = (m * m) * (m * m) * m;
    return f0 + (Vec3f(1.0f) - f0) * m5;
}

inline float tan2_theta(const Vec3f& w) {
    const float c2 = w.z * w.z;
    return std::max(0.0f, 1.0f - c2) / c2;
}

/// Beckmann distribution (Walter et al. 2007, "Microfacet Models for Refraction through
/// Rough Surfaces"), the CS184 3-2 microfacet's. Sampled proportionally to D(m) cos(m).
struct Beckmann {
    float alpha;

    float D(const Vec3f& m) const {
        if (m.z <= 0) return 0.0f;
        const float c2 = m.z * m.z;
        const float a2 = alpha * alpha;
        return std::exp(-tan2_theta(m) / a2) / (kPi * a2 * c2 * c2);
    }
    /// Smith Lambda, Walter et al.'s rational approximation (eq. 27).
    float lambda(const Vec3f& w) const {
        const float t2 = tan2_theta(w);
        if (t2 == 0.0f) return 0.0f;
        const float a = 1.0f / (alpha * std::sqrt(t2));
        if (a >= 1.6f) return 0.0f;
        return (1.0f - 1.259f * a + 0.396f * a * a) / (3.535f * a + 2.181f * a * a);
    }
    float G(const Vec3f& wo, const Vec3f& wi) const { return 1.0f / (1.0f + lambda(wo) + lambda(wi)); }
    Vec3f sample_m(float u1, float u2) const {
        const float t2 = -alpha * alpha * std::log(std::max(1e-30f, 1.0f - u1));
        const float cos_t = 1.0f / std::sqrt(1.0f + t2);
        const float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t));
        const float phi = 2.0f * kPi * u2;
        return {sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
    }
    /// Density of sample_m over microfacet normals (solid angle).
    float pdf_m(const Vec3f&, const Vec3f& m) const { return D(m) * std::abs(m.z); }
};

/// GGX / Trowbridge-Reitz (Walter et al. 2007) with height-correlated Smith masking-
/// shadowing (Heitz 2014, "Understanding the Masking-Shadowing Function"), sampled by its
/// visible normals (Heitz 2018, "Sampling the GGX Distribution of Visible Normals").
struct Ggx {
    float alpha;

    float D(const Vec3f& m) const {
        if (m.z <= 0) return 0.0f;
        const float a2 = alpha * alpha;
        const float d = m.z * m.z * (a2 - 1.0f) + 1.0f;
        return a2 / (kPi * d * d);
    }
    float lambda(const Vec3f& w) const {
        const float t2 = tan2_theta(w);
        if (!std::isfinite(t2)) return 1e30f;
        return 0.5f * (std::sqrt(1.0f + alpha * alpha * t2) - 1.0f);
    }
    float G1(const Vec3f& w) const { return 1.0f / (1.0f + lambda(w)); }
    float G(const Vec3f& wo, const Vec3f& wi) const { return 1.0f / (1.0f + lambda(wo) + lambda(wi)); }
    /// A visible normal for wo (wo.z > 0).
    Vec3f sample_m(const Vec3f& wo, float u1, float u2) const {
        const Vec3f vh = accel::normalize(Vec3f(alpha * wo.x, alpha * wo.y, wo.z));
        const float lensq = vh.x * vh.x + vh.y * vh.y;
        const Vec3f t1 = lensq > 0 ? Vec3f(-vh.y, vh.x, 0.0f) / std::sqrt(lensq) : Vec3f(1.0f, 0.0f, 0.0f);
        const Vec3f t2v = accel::cross(vh, t1);
        const float r = std::sqrt(u1);
        const float phi = 2.0f * kPi * u2;
        const float p1 = r * std::cos(phi);
        float p2 = r * std::sin(phi);
        const float s = 0.5f * (1.0f + vh.z);
        p2 = (1.0f - s) * std::sqrt(std::max(0.0f, 1.0f - p1 * p1)) + s * p2;
        const Vec3f nh = t1 * p1 + t2v * p2 + vh * std::sqrt(std::max(0.0f, 1.0f - p1 * p1 - p2 * p2));
        return accel::normalize(Vec3f(alpha * nh.x, alpha * nh.y, std::max(1e-7f, nh.z)));
    }
    /// Density of sample_m(wo) over microfacet normals: D_wo(m) = G1(wo) max(0, wo.m) D(m) / wo.z.
    float pdf_m(const Vec3f& wo, const Vec3f& m) const {
        return G1(wo) * std::max(0.0f, accel::dot(wo, m)) * D(m) / std::abs(wo.z);
    }
};

}  // namespace renderer::bsdf
