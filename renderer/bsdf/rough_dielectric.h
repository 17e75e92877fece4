// Transmission through a rough dielectric boundary: Walter et al. 2007 ("Microfacet
// Models for Refraction through Rough Surfaces", eqs. 21 and 38-41) with a GGX
// distribution sampled by visible normals, in pbrt-v4's form (DielectricBxDF). Only the
// transmitted half lives here, without its (1 - F) factor: the glTF model
// (metal_rough.h) combines it with its own reflection lobe.
#pragma once

#include "renderer/bsdf/microfacet.h"

namespace renderer::bsdf {

struct RoughTransmission {
    Ggx dist;
    float eta;  ///< far side over wo's side; wo.z > 0

    /// Generalised half vector of a transmission pair, on wo's side; false if wo, wi
    /// are not a valid refraction pair.
    bool half(const Vec3f& wo, const Vec3f& wi, Vec3f& wm) const {
        if (wo.z <= 0 || wi.z >= 0) return false;
        wm = wi * eta + wo;
        const float l2 = accel::dot(wm, wm);
        if (!(l2 > 0)) return false;
        wm = wm / std::sqrt(l2);
        if (wm.z < 0) wm = -wm;
        // Microfacets seen from behind by either direction carry nothing.
        return accel::dot(wm, wi) < 0 && accel::dot(wm, wo) > 0;
    }
    /// BTDF without the Fresnel factor, scaled by 1/eta^2 for radiance.
    float f(const Vec3f& wo, const Vec3f& wi) const {
        Vec3f wm;
        if (!half(wo, wi, wm)) return 0.0f;
        const float dwi = accel::dot(wi, wm), dwo = accel::dot(wo, wm);
        const float denom = sqr(dwi + dwo / eta) * wi.z * wo.z;
        return std::abs(dist.D(wm) * dist.G(wo, wi) * dwi * dwo / denom) / (eta * eta);
    }
    float pdf(const Vec3f& wo, const Vec3f& wi) const {
        Vec3f wm;
        if (!half(wo, wi, wm)) return 0.0f;
        const float dwi = accel::dot(wi, wm), dwo = accel::dot(wo, wm);
        return dist.pdf_m(wo, wm) * std::abs(dwi) / sqr(dwi + dwo / eta);
    }
    bool sample(const Vec3f& wo, float u1, float u2, Vec3f& wi) const {
        const Vec3f m = dist.sample_m(wo, u1, u2);
        return refract(wo, m, eta, wi) && wi.z < 0;
    }
};

}  // namespace renderer::bsdf
