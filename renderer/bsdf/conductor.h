// The CS184 3-2 `microfacet` BSDF: a rough conductor, f = F(wi.h) G(wo, wi) D(h) /
// (4 cos wo cos wi) with a Beckmann D of roughness alpha and conductor Fresnel from the
// per-channel eta and k. The course samples D(h) cos(h) (Walter et al. 2007); we sample
// the normals wo sees (Heitz and d'Eon 2014, microfacet.h): same f, less noise.
#pragma once

#include "renderer/bsdf/microfacet.h"

namespace renderer::bsdf {

struct RoughConductor {
    Beckmann dist;
    Vec3f eta, k;
    static constexpr bool kDelta = false;

    Vec3f f(const Vec3f& wo, const Vec3f& wi) const {
        if (wo.z <= 0 || wi.z <= 0) return Vec3f(0.0f);
        const Vec3f h = accel::normalize(wo + wi);
        const float d = dist.D(h);
        if (!(d > 0)) return Vec3f(0.0f);
        return fresnel_conductor(accel::dot(wi, h), eta, k) * (d * dist.G(wo, wi) / (4.0f * wo.z * wi.z));
    }
    float pdf(const Vec3f& wo, const Vec3f& wi) const {
        if (wo.z <= 0 || wi.z <= 0) return 0.0f;
        const Vec3f h = accel::normalize(wo + wi);
        return dist.pdf_m(wo, h) / (4.0f * accel::dot(wo, h));
    }
    bool sample(const Vec3f& wo, float u1, float u2, float, Sample& s) const {
        if (wo.z <= 0) return false;
        const Vec3f m = dist.sample_m(wo, u1, u2);
        s.wi = reflect(wo, m);
        if (s.wi.z <= 0 || accel::dot(wo, m) <= 0) return false;
        s.pdf = pdf(wo, s.wi);
        s.f = f(wo, s.wi);
        if (!(s.pdf > 0)) return false;
        s.weight = s.f * (s.wi.z / s.pdf);
        return true;
    }
};

}  // namespace renderer::bsdf
