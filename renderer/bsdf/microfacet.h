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
    /// pdf_m is exactly the density sample_m draws from.
    /// erfc is Abramowitz and Stegun's 7.1.26, P(t) exp(-a^2) with P a quintic in
    /// t = 1 / (1 + 0.3275911 a), absolute error 1.5e-7 (float's own), so lambda is one
    /// exp: it runs for every light sample's MIS weight at a rough conductor.
    float G1_exact(const Vec3f& w) const {
        const float t2 = tan2_theta(w);
        if (t2 == 0.0f) return 1.0f;
        if (!std::isfinite(t2)) return 0.0f;
        const float a = 1.0f / (alpha * std::sqrt(t2));
        const float t = 1.0f / (1.0f + 0.3275911f * a);
        const float p = t * (0.254829592f + t * (-0.284496736f + t * (1.421413741f + t * (-1.453152027f + t * 1.061405429f))));
        // lambda = -erfc(a) / 2 + exp(-a^2) / (2 a sqrt(pi))
        const float lambda = std::exp(-a * a) * (0.5f / (a * 1.7724538509f) - 0.5f * p);
        return 1.0f / (1.0f + std::max(0.0f, lambda));
    }
    /// A visible normal for wo (wo.z > 0): Heitz and d'Eon 2014, section 4: stretch wo to
    /// roughness 1, draw the slopes of the normals it sees, rotate back and unstretch.
    Vec3f sample_m(const Vec3f& wo, float u1, float u2) const {
        const Vec3f ws = accel::normalize(Vec3f(alpha * wo.x, alpha * wo.y, wo.z));
        const double sin_t = std::sqrt(std::max(0.0, 1.0 - double(ws.z) * double(ws.z)));
        double cos_phi = 1.0, sin_phi = 0.0;
        if (sin_t > 0) {
            cos_phi = double(ws.x) / sin_t;
            sin_phi = double(ws.y) / sin_t;
        }
        double sx, sy;
        visible_slopes(double(ws.z), sin_t, u1, u2, sx, sy);
        const double x = alpha * (cos_phi * sx - sin_phi * sy);
        const double y = alpha * (sin_phi * sx + cos_phi * sy);
        return accel::normalize(Vec3f(float(-x), float(-y), 1.0f));
    }
    /// Density of sample_m(wo) over microfacet normals: D_wo(m) = G1(wo) max(0, wo.m) D(m) / wo.z.
    float pdf_m(const Vec3f& wo, const Vec3f& m) const {
        return G1_exact(wo) * std::max(0.0f, accel::dot(wo, m)) * D(m) / std::abs(wo.z);
    }

private:
    /// Inverse error function: Winitzki's closed form (2008, "A handy approximation for the
    /// error function and its inverse"; relative error ~2e-3), then `newton` Newton steps
    /// on std::erf (each squares the error: one gives ~1e-6, below a float direction's
    /// resolution where it matters; none for a first guess that is refined anyway).
    static double erfinv(double z, int newton) {
        z = std::clamp(z, -1.0 + 1e-15, 1.0 - 1e-15);
        const double a = 0.147, l = std::log((1.0 - z) * (1.0 + z));
        const double b = 2.0 / (kPi * a) + 0.5 * l;
        double x = std::copysign(std::sqrt(std::sqrt(b * b - l / a) - b), z);
        for (int i = 0; i < newton; ++i) {
            const double err = std::erf(x) - z;
            x -= err / (2.0 / std::sqrt(double(kPi)) * std::exp(-x * x));
        }
        return x;
    }
    /// Slopes (sx, sy) of a visible normal of the roughness-1 Beckmann surface seen from
    /// polar angle theta with the azimuth along +x (Heitz and d'Eon 2014, appendix). sy is
    /// Gaussian with variance 1/2; sx has density proportional to (cot theta - sx)
    /// exp(-sx^2) on sx < cot theta, with the CDF
    ///   C(sx) = [cot theta sqrt(pi)/2 (1 + erf sx) + exp(-sx^2)/2] / C(cot theta),
    /// inverted by Newton's method safeguarded by bisection (the paper's closed-form fit
    /// is discontinuous, which hurts stratified samples; pbrt-v3 inverts numerically too).
    static void visible_slopes(double cos_t, double sin_t, float u1, float u2, double& sx, double& sy) {
        sy = erfinv(2.0 * std::clamp(double(u2), 1e-9, 1.0 - 1e-9) - 1.0, 1);
        const double u = std::clamp(double(u1), 1e-9, 1.0 - 1e-9);
        if (sin_t < 1e-7) {  // normal incidence: every normal is visible, sx is Gaussian too
            sx = erfinv(2.0 * u - 1.0, 1);
            return;
        }
        const double cot = cos_t / sin_t, k = 0.5 * cot * std::sqrt(double(kPi));
        // Start from pbrt-v3's fit of the inverse in the erf domain (a first guess only;
        // the root is found below to 1e-9 in u, far below what a float direction resolves).
        const double theta = std::acos(std::clamp(cos_t, -1.0, 1.0));
        const double fit = 1.0 + theta * (-0.876 + theta * (0.4265 - 0.0594 * theta));
        const double c = std::erf(cot);
        const double inv_total = 1.0 / (k * (1.0 + c) + 0.5 * std::exp(-cot * cot));  // 1 / C(cot)
        double x = erfinv(std::clamp(c - (1.0 + c) * std::pow(1.0 - u, fit), -1.0 + 1e-12, c), 0);
        double lo = -12.0, hi = cot;
        for (int i = 0; i < 60; ++i) {
            if (!(x > lo && x < hi)) x = 0.5 * (lo + hi);
            const double e = std::exp(-x * x);
            const double g = (k * std::erfc(-x) + 0.5 * e) * inv_total - u;
            if (std::abs(g) < 1e-9) break;
            if (g > 0) hi = x;
            else lo = x;
            const double density = (cot - x) * e * inv_total;
            x = density > 0 ? x - g / density : 0.5 * (lo + hi);
            if (hi - lo < 1e-13) break;
        }
        sx = std::clamp(x, lo, hi);
    }
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
