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

/// erfc(z) for z >= 0 as Abramowitz and Stegun's 7.1.26 writes it, P(t) exp(-z^2) with P a
/// quintic in t = 1 / (1 + 0.3275911 z): absolute error 1.5e-7 (float's own), for one exp,
/// which the caller passes in as `gauss` = exp(-z^2) because it needs that term too.
inline float erfc_as(float z, float gauss) {
    const float t = 1.0f / (1.0f + 0.3275911f * z);
    return t * (0.254829592f + t * (-0.284496736f + t * (1.421413741f + t * (-1.453152027f + t * 1.061405429f)))) *
           gauss;
}

/// 1 + erf(x), for any x, by erfc_as: 2 - erfc(x) above 0 and erfc(-x) below, so the
/// left tail keeps its relative precision (1 + erf would cancel there).
inline float one_plus_erf(float x, float gauss) {
    return x >= 0.0f ? 2.0f - erfc_as(x, gauss) : erfc_as(-x, gauss);
}

/// The inverse error function in single precision (Giles 2012, "Approximating the erfinv
/// function", GPU Computing Gems Jade, ch. 10): a polynomial in w = -log(1 - x^2), one for
/// the centre and one in sqrt(w) for the tails; relative error a few float ulps for
/// |x| < 1 - 2^-24.
inline float erfinv(float x) {
    float w = -std::log((1.0f - x) * (1.0f + x));
    float p;
    if (w < 5.0f) {
        w -= 2.5f;
        p = 2.81022636e-08f;
        p = 3.43273939e-07f + p * w;
        p = -3.5233877e-06f + p * w;
        p = -4.39150654e-06f + p * w;
        p = 0.00021858087f + p * w;
        p = -0.00125372503f + p * w;
        p = -0.00417768164f + p * w;
        p = 0.246640727f + p * w;
        p = 1.50140941f + p * w;
    } else {
        w = std::sqrt(w) - 3.0f;
        p = -0.000200214257f;
        p = 0.000100950558f + p * w;
        p = 0.00134934322f + p * w;
        p = -0.00367342844f + p * w;
        p = 0.00573950773f + p * w;
        p = -0.0076224613f + p * w;
        p = 0.00943887047f + p * w;
        p = 1.00167406f + p * w;
        p = 2.83297682f + p * w;
    }
    return p * x;
}

/// Beckmann distribution (Walter et al. 2007, "Microfacet Models for Refraction through
/// Rough Surfaces"), the CS184 3-2 microfacet's, sampled by its visible normals (Heitz and
/// d'Eon 2014, "Importance Sampling Microfacet-Based BSDFs using the Distribution of
/// Visible Normals"): only normals that wo can see are drawn, so fewer samples land below
/// the horizon and the weight is F G / G1(wo), which stays near 1 at grazing angles where
/// sampling D(m) cos(m) gave large weights.
struct Beckmann {
    float alpha;

    float D(const Vec3f& m) const {
        if (m.z <= 0) return 0.0f;
        const float c2 = m.z * m.z;
        const float a2 = alpha * alpha;
        return std::exp(-tan2_theta(m) / a2) / (kPi * a2 * c2 * c2);
    }
    /// Smith Lambda, Walter et al.'s rational approximation (eq. 27): the course's G, used
    /// by f, so the expected image does not change.
    float lambda(const Vec3f& w) const {
        const float t2 = tan2_theta(w);
        if (t2 == 0.0f) return 0.0f;
        const float a = 1.0f / (alpha * std::sqrt(t2));
        if (a >= 1.6f) return 0.0f;
        return (1.0f - 1.259f * a + 0.396f * a * a) / (3.535f * a + 2.181f * a * a);
    }
    float G(const Vec3f& wo, const Vec3f& wi) const { return 1.0f / (1.0f + lambda(wo) + lambda(wi)); }
    /// Smith's exact G1 for Beckmann (Walter et al. eq. 25). The visible-normal density is
    /// normalised by it, not by the approximation (which is off by up to ~0.3 %), so that
    /// pdf_m is exactly the density sample_m draws from. erfc by erfc_as, so lambda costs
    /// one exp: it runs for every light sample's MIS weight at a rough conductor.
    float G1_exact(const Vec3f& w) const {
        const float t2 = tan2_theta(w);
        if (t2 == 0.0f) return 1.0f;
        if (!std::isfinite(t2)) return 0.0f;
        const float a = 1.0f / (alpha * std::sqrt(t2));
        const float gauss = std::exp(-a * a);
        // lambda = -erfc(a) / 2 + exp(-a^2) / (2 a sqrt(pi))
        const float lambda = 0.5f * gauss / (a * 1.7724538509f) - 0.5f * erfc_as(a, gauss);
        return 1.0f / (1.0f + std::max(0.0f, lambda));
    }
    /// A visible normal for wo (wo.z > 0): Heitz and d'Eon 2014, section 4: stretch wo to
    /// roughness 1, draw the slopes of the normals it sees, rotate back and unstretch.
    Vec3f sample_m(const Vec3f& wo, float u1, float u2) const {
        const Vec3f ws = accel::normalize(Vec3f(alpha * wo.x, alpha * wo.y, wo.z));
        // From x and y, not sqrt(1 - z^2), which loses half its digits near normal incidence.
        const float sin_t = std::sqrt(ws.x * ws.x + ws.y * ws.y);
        float cos_phi = 1.0f, sin_phi = 0.0f;
        if (sin_t > 0) {
            cos_phi = ws.x / sin_t;
            sin_phi = ws.y / sin_t;
        }
        float sx, sy;
        visible_slopes(ws.z, sin_t, u1, u2, sx, sy);
        const float x = alpha * (cos_phi * sx - sin_phi * sy);
        const float y = alpha * (sin_phi * sx + cos_phi * sy);
        return accel::normalize(Vec3f(-x, -y, 1.0f));
    }
    /// Density of sample_m(wo) over microfacet normals: D_wo(m) = G1(wo) max(0, wo.m) D(m) / wo.z.
    float pdf_m(const Vec3f& wo, const Vec3f& m) const {
        return G1_exact(wo) * std::max(0.0f, accel::dot(wo, m)) * D(m) / std::abs(wo.z);
    }

    /// Slopes (sx, sy) of a visible normal of the roughness-1 Beckmann surface seen from
    /// polar angle theta with the azimuth along +x (Heitz and d'Eon 2014, appendix). sy is
    /// Gaussian with variance 1/2; sx has density proportional to (cot theta - sx)
    /// exp(-sx^2) on sx < cot theta, with the CDF
    ///   C(sx) = [cot theta sqrt(pi)/2 (1 + erf sx) + exp(-sx^2)/2] / C(cot theta),
    /// inverted by Newton's method safeguarded by bisection (the paper's closed-form fit
    /// is discontinuous, which hurts stratified samples; pbrt-v3 and Mitsuba invert
    /// numerically too). In float, with erf by erfc_as and one exp per step: the root is
    /// found to kSlopeTolerance in u, where doubles and libm's erf cost 5 % of a render of
    /// the rough copper bunny ("Beckmann slopes in float", renderer/README.md).
    static void visible_slopes(float cos_t, float sin_t, float u1, float u2, float& sx, float& sy) {
        // The largest float below 1 and the least to_unit step: erfinv and the CDF stay finite.
        constexpr float kULo = 0x1p-24f, kUHi = 0x1.fffffep-1f;
        sy = erfinv(2.0f * std::clamp(u2, kULo, kUHi) - 1.0f);
        const float u = std::clamp(u1, kULo, kUHi);
        if (sin_t < 1e-7f) {  // normal incidence: every normal is visible, sx is Gaussian too
            sx = erfinv(2.0f * u - 1.0f);
            return;
        }
        const float cot = cos_t / sin_t, k = 0.5f * cot * 1.7724538509f;
        const float cot_gauss = std::exp(-cot * cot);
        const float c = one_plus_erf(cot, cot_gauss) - 1.0f;  // erf(cot)
        const float inv_total = 1.0f / (k * (1.0f + c) + 0.5f * cot_gauss);  // 1 / C(cot)
        // Start from pbrt-v3's fit of the inverse in the erf domain (a first guess only).
        const float theta = std::acos(std::clamp(cos_t, -1.0f, 1.0f));
        const float fit = 1.0f + theta * (-0.876f + theta * (0.4265f - 0.0594f * theta));
        float x = erfinv(std::clamp(c - (1.0f + c) * std::pow(1.0f - u, fit), -kUHi, c));
        // C(-6) / C(cot) < 1e-16 for every theta, far below the least u.
        float lo = -6.0f, hi = cot;
        for (int i = 0; i < 40; ++i) {
            if (!(x > lo && x < hi)) x = 0.5f * (lo + hi);
            const float e = std::exp(-x * x);
            const float g = (k * one_plus_erf(x, e) + 0.5f * e) * inv_total - u;
            if (std::abs(g) < kSlopeTolerance) break;
            if (g > 0) hi = x;
            else lo = x;
            const float density = (cot - x) * e * inv_total;
            x = density > 0 ? x - g / density : 0.5f * (lo + hi);
            if (!(hi - lo > 1e-6f * (1.0f + std::abs(x)))) break;
        }
        sx = std::clamp(x, lo, hi);
    }
    /// How far from u the slope CDF may be where visible_slopes stops: a few times the
    /// rounding of the CDF's float evaluation, and far below any stratum of the samples
    /// (16 bits of u at 65536 spp).
    static constexpr float kSlopeTolerance = 1e-6f;
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
