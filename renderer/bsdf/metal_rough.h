// glTF 2.0 metallic-roughness (glTF 2.0 specification, Appendix B): a GGX specular lobe
// (alpha = roughness^2, height-correlated Smith, Schlick Fresnel with F0 blended from
// the dielectric's ((ior-1)/(ior+1))^2 to the base colour by `metallic`) over a
// Lambertian base weighted by (1 - F), whose dielectric part is split by
// KHR_materials_transmission into a rough transmission lobe tinted by the base colour.
// Lobes are chosen in proportion to their estimated albedo; the pdf is the mixture.
#pragma once

#include "renderer/bsdf/rough_dielectric.h"
#include "renderer/sampling.h"

namespace renderer::bsdf {

struct MetalRough {
    Ggx dist;
    Vec3f base;
    float metallic = 0;
    float f0d = 0.04f;    ///< the dielectric's normal-incidence reflectance
    float diffuse_w = 0;  ///< (1 - metallic)(1 - transmission)
    float trans_w = 0;    ///< (1 - metallic) transmission
    float eta = 1.5f;     ///< far side over wo's side (transmission only)
    static constexpr bool kDelta = false;

    static MetalRough make(const Vec3f& base, float metallic, float roughness, float transmission,
                           float ior, bool front) {
        MetalRough b;
        b.dist.alpha = std::max(1e-3f, roughness * roughness);
        b.base = base;
        b.metallic = metallic;
        b.f0d = sqr((ior - 1.0f) / (ior + 1.0f));
        b.diffuse_w = (1.0f - metallic) * (1.0f - transmission);
        b.trans_w = (1.0f - metallic) * transmission;
        b.eta = front ? ior : 1.0f / ior;
        return b;
    }

    /// Fresnel of the dielectric part: Schlick as glTF specifies for opaque materials;
    /// the exact dielectric Fresnel when the material transmits, since light leaving the
    /// inside must be totally reflected beyond the critical angle (Schlick knows no TIR).
    float fresnel_d(float cos_i) const {
        if (trans_w > 0) return fresnel_dielectric(cos_i, eta);
        return fresnel_schlick(Vec3f(f0d), cos_i).x;
    }
    /// Reflectance of the specular lobe: conductor (Schlick on the base colour) and
    /// dielectric mixed by metallic.
    Vec3f fresnel(float cos_i) const {
        return fresnel_schlick(base, cos_i) * metallic + Vec3f(fresnel_d(cos_i) * (1.0f - metallic));
    }

    /// Lobe selection probabilities (specular, diffuse, transmission) for wo.
    void probabilities(const Vec3f& wo, float p[3]) const {
        const float fd = fresnel_d(wo.z);
        const float fs = luminance(fresnel(wo.z));
        const float lb = std::max(0.05f, luminance(base));
        p[0] = std::max(fs, 0.05f);
        p[1] = diffuse_w * lb * (1.0f - fd);
        p[2] = trans_w * lb * (1.0f - fd);
        const float sum = p[0] + p[1] + p[2];
        for (int i = 0; i < 3; ++i) p[i] /= sum;
    }

    Vec3f f(const Vec3f& wo, const Vec3f& wi) const {
        if (wo.z <= 0) return Vec3f(0.0f);
        if (wi.z > 0) {
            const Vec3f h = accel::normalize(wo + wi);
            const Vec3f spec = fresnel(accel::dot(wo, h)) * (dist.D(h) * dist.G(wo, wi) / (4.0f * wo.z * wi.z));
            // The base lies under the specular layer: it receives what the layer lets
            // through on the way in and on the way out. glTF writes (1 - F(v.h)); the
            // product of both directions' (1 - F) keeps f reciprocal and the white
            // furnace at most 1 at grazing angles, where glTF's form reflects more.
            if (diffuse_w <= 0) return spec;
            const float t = (1.0f - fresnel_d(wo.z)) * (1.0f - fresnel_d(wi.z));
            return spec + base * (diffuse_w * t * kInvPi);
        }
        if (trans_w <= 0 || wi.z == 0) return Vec3f(0.0f);
        const RoughTransmission t{dist, eta};
        Vec3f wm;
        if (!t.half(wo, wi, wm)) return Vec3f(0.0f);
        return base * (trans_w * (1.0f - fresnel_d(accel::dot(wo, wm))) * t.f(wo, wi));
    }
    float pdf(const Vec3f& wo, const Vec3f& wi) const {
        if (wo.z <= 0) return 0.0f;
        float p[3];
        probabilities(wo, p);
        if (wi.z > 0) {
            const Vec3f h = accel::normalize(wo + wi);
            return p[0] * dist.pdf_m(wo, h) / (4.0f * accel::dot(wo, h)) + p[1] * wi.z * kInvPi;
        }
        if (p[2] <= 0) return 0.0f;
        return p[2] * RoughTransmission{dist, eta}.pdf(wo, wi);
    }
    bool sample(const Vec3f& wo, float u1, float u2, float uc, Sample& s) const {
        if (wo.z <= 0) return false;
        float p[3];
        probabilities(wo, p);
        if (uc < p[0]) {
            s.wi = reflect(wo, dist.sample_m(wo, u1, u2));
            if (s.wi.z <= 0) return false;
        } else if (uc < p[0] + p[1]) {
            s.wi = cosine_hemisphere(u1, u2);
        } else if (!RoughTransmission{dist, eta}.sample(wo, u1, u2, s.wi)) {
            return false;
        }
        s.eta = s.wi.z < 0 ? eta : 1.0f;
        s.pdf = pdf(wo, s.wi);
        if (!(s.pdf > 0)) return false;
        s.f = f(wo, s.wi);
        s.weight = s.f * (abs_cos(s.wi) / s.pdf);
        return true;
    }
};

}  // namespace renderer::bsdf
