#include "renderer/bsdf/bsdf.h"

#include <algorithm>
#include <cmath>

#include "renderer/interaction.h"

namespace renderer::bsdf {

Bsdf make_bsdf(const scenes::Scene& scene, const scenes::Material& m, const Interaction& it, bool front,
               const Vec3f* base_colour) {
    using scenes::BsdfKind;
    switch (m.bsdf) {
        case BsdfKind::Diffuse:
            return Bsdf(Lambert{renderer::base_colour(scene, m, it)});
        case BsdfKind::Mirror:
            return Bsdf(Mirror{m.reflectance});
        case BsdfKind::Glass:
            return Bsdf(SmoothDielectric{m.reflectance, m.transmittance, front ? m.ior : 1.0f / m.ior});
        case BsdfKind::Microfacet:
            return Bsdf(RoughConductor{Beckmann{std::max(1e-3f, m.alpha)}, m.eta, m.k});
        case BsdfKind::MetallicRoughness: {
            const Vec3f base = base_colour ? *base_colour : renderer::base_colour(scene, m, it);
            float metallic = m.metallic, roughness = m.roughness, transmission = m.transmission;
            if (m.metallic_roughness_texture != scenes::kNoTexture) {
                const Texel4 mr = texel4(scene, m.metallic_roughness_texture, it);
                roughness *= mr.g;
                metallic *= mr.b;
            }
            if (m.transmission_texture != scenes::kNoTexture)
                transmission *= texel4(scene, m.transmission_texture, it).r;
            return Bsdf(MetalRough::make(base, std::clamp(metallic, 0.0f, 1.0f), std::clamp(roughness, 0.0f, 1.0f),
                                         std::clamp(transmission, 0.0f, 1.0f), m.ior, front));
        }
    }
    return Bsdf();
}

Vec3f mapped_normal(const scenes::Scene& scene, const scenes::Material& m, const Interaction& it) {
    if (m.normal_texture == scenes::kNoTexture || !(accel::dot(it.dpdu, it.dpdu) > 0)) return it.ns;
    // Only X and Y are stored (a unit normal's Z is implied; filtering shortens X and Y,
    // which the implied Z turns into a flatter normal, as a wider footprint should).
    const Texel4 tex = texel4(scene, m.normal_texture, it);
    const float nx = 2.0f * tex.r - 1.0f, ny = 2.0f * tex.g - 1.0f;
    const Vec3f tn{nx * m.normal_scale, ny * m.normal_scale, std::sqrt(std::max(0.0f, 1.0f - nx * nx - ny * ny))};
    Vec3f t = it.dpdu - it.ns * accel::dot(it.ns, it.dpdu);
    const float tl = accel::length(t);
    if (!(tl > 0)) return it.ns;
    t = t / tl;
    const Vec3f b = accel::cross(it.ns, t);
    const Vec3f n = t * tn.x + b * tn.y + it.ns * tn.z;
    const float nl = accel::length(n);
    if (!(nl > 0) || !std::isfinite(nl)) return it.ns;
    const Vec3f out = n / nl;
    return accel::dot(out, it.ng) * accel::dot(it.ns, it.ng) > 0 ? out : it.ns;
}

Vec3f aov_albedo(const scenes::Scene& scene, const scenes::Material& m, const Interaction& it) {
    using scenes::BsdfKind;
    switch (m.bsdf) {
        case BsdfKind::Mirror: return m.reflectance;
        case BsdfKind::Glass: return m.transmittance;
        case BsdfKind::Microfacet: return fresnel_conductor(1.0f, m.eta, m.k);
        default: return base_colour(scene, m, it);
    }
}

}  // namespace renderer::bsdf
