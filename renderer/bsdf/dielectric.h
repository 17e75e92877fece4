// Smooth dielectric (glass): exact Fresnel reflection and refraction with total internal
// reflection; the CS184 `glass` (reflectance and transmittance tints, ior) and
// `refraction` (reflectance 0). Both lobes are delta. Radiance crossing the boundary is
// scaled by 1/eta^2 (Veach 1997, 5.2: the camera path carries radiance, not importance),
// as pbrt-v4 and Mitsuba do.
#pragma once

#include "renderer/bsdf/microfacet.h"

namespace renderer::bsdf {

struct SmoothDielectric {
    Vec3f R, T;
    float eta;  ///< index of the side wo does NOT lie on over the index of wo's side
    static constexpr bool kDelta = true;

    Vec3f f(const Vec3f&, const Vec3f&) const { return Vec3f(0.0f); }
    float pdf(const Vec3f&, const Vec3f&) const { return 0.0f; }
    bool sample(const Vec3f& wo, float, float, float uc, Sample& s) const {
        const float F = fresnel_dielectric(wo.z, eta);
        // Choose the lobe by Fresnel; a black tint on one side makes it the only lobe.
        const bool has_r = accel::max_component(R) > 0, has_t = accel::max_component(T) > 0;
        const float pr = !has_t ? 1.0f : !has_r ? (F < 1.0f ? 0.0f : 1.0f) : F;
        s.f = Vec3f(0.0f);
        s.delta = true;
        if (uc < pr) {
            s.wi = reflect_z(wo);
            s.pdf = pr;
            s.weight = R * (F / pr);
        } else {
            if (!refract(wo, Vec3f(0.0f, 0.0f, 1.0f), eta, s.wi)) return false;
            s.pdf = 1.0f - pr;
            s.weight = T * ((1.0f - F) / (s.pdf * eta * eta));
            s.eta = eta;
        }
        return s.pdf > 0;
    }
};

}  // namespace renderer::bsdf
