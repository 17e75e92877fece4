// Perfect specular reflection tinted by R: the CS184 `mirror` (a delta lobe, so light
// sampling is skipped for it; weight = R, no Fresnel, as the course defines it).
#pragma once

#include "renderer/bsdf/common.h"

namespace renderer::bsdf {

struct Mirror {
    Vec3f R;
    static constexpr bool kDelta = true;

    Vec3f f(const Vec3f&, const Vec3f&) const { return Vec3f(0.0f); }
    float pdf(const Vec3f&, const Vec3f&) const { return 0.0f; }
    bool sample(const Vec3f& wo, float, float, float, Sample& s) const {
        s.wi = reflect_z(wo);
        s.f = Vec3f(0.0f);
        s.pdf = 1.0f;
        s.delta = true;
        s.weight = R;
        return true;
    }
};

}  // namespace renderer::bsdf
