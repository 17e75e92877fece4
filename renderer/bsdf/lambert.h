// Lambertian reflection: f = R / pi, sampled by a cosine-weighted hemisphere (Malley).
#pragma once

#include "renderer/bsdf/common.h"
#include "renderer/sampling.h"

namespace renderer::bsdf {

struct Lambert {
    Vec3f R;
    static constexpr bool kDelta = false;

    Vec3f f(const Vec3f& wo, const Vec3f& wi) const {
        return same_side(wo, wi) ? R * kInvPi : Vec3f(0.0f);
    }
    float pdf(const Vec3f& wo, const Vec3f& wi) const {
        return same_side(wo, wi) ? abs_cos(wi) * kInvPi : 0.0f;
    }
    bool sample(const Vec3f& wo, float u1, float u2, float, Sample& s) const {
        s.wi = cosine_hemisphere(u1, u2);
        if (wo.z < 0) s.wi.z = -s.wi.z;
        s.pdf = abs_cos(s.wi) * kInvPi;
        if (!(s.pdf > 0)) return false;
        s.f = R * kInvPi;
        s.weight = R;
        return true;
    }
};

}  // namespace renderer::bsdf
