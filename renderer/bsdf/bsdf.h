// A material's BSDF at one hit: exactly one of the BSDF value types, chosen by a tag
// (std::variant; one switch per call, no virtual dispatch), built per hit from the
// scene's plain material data by make_bsdf. Diffuse surfaces never come here: the path
// integrator keeps its Lambert-only loop for them, so a diffuse scene pays nothing.
#pragma once

#include <variant>

#include "renderer/bsdf/conductor.h"
#include "renderer/bsdf/dielectric.h"
#include "renderer/bsdf/lambert.h"
#include "renderer/bsdf/metal_rough.h"
#include "renderer/bsdf/mirror.h"
#include "scenes/scene.h"

namespace renderer {
struct Interaction;
}

namespace renderer::bsdf {

class Bsdf {
public:
    using Lobes = std::variant<Lambert, Mirror, SmoothDielectric, RoughConductor, MetalRough>;
    Bsdf() : lobes_(Lambert{Vec3f(0.0f)}) {}
    template <class T>
    explicit Bsdf(const T& b) : lobes_(b) {}

    /// All functions take directions in the local frame with wo.z > 0.
    Vec3f f(const Vec3f& wo, const Vec3f& wi) const {
        return std::visit([&](const auto& b) { return b.f(wo, wi); }, lobes_);
    }
    float pdf(const Vec3f& wo, const Vec3f& wi) const {
        return std::visit([&](const auto& b) { return b.pdf(wo, wi); }, lobes_);
    }
    bool sample(const Vec3f& wo, float u1, float u2, float uc, Sample& s) const {
        return std::visit([&](const auto& b) { return b.sample(wo, u1, u2, uc, s); }, lobes_);
    }
    /// True when every lobe is a delta (light sampling is then useless and skipped).
    bool is_delta() const {
        return std::visit([](const auto& b) { return std::decay_t<decltype(b)>::kDelta; }, lobes_);
    }

private:
    Lobes lobes_;
};

/// The BSDF of material `m` at hit `it` (textures looked up at its uv). `front`: wo lies on
/// the side the geometric normal points to (outside, for a dielectric's index).
/// `base_colour`, when given, is the material's albedo times its texture at `it`, already
/// looked up (the camera hit's albedo AOV), and is not read again.
Bsdf make_bsdf(const scenes::Scene& scene, const scenes::Material& m, const Interaction& it, bool front,
               const Vec3f* base_colour = nullptr);

/// The shading normal `it.ns` perturbed by the material's tangent-space normal map
/// (glTF normalTexture: RG in [0,1] -> [-1,1], z = sqrt(1 - x^2 - y^2), x and y scaled
/// by normal_scale, tangent from the uv mapping, bitangent = n x t). Returns it.ns when
/// there is no map or no tangent, or when the result would face away from the geometric
/// normal.
Vec3f mapped_normal(const scenes::Scene& scene, const scenes::Material& m, const Interaction& it);

/// What the albedo AOV reports for a material (its diffuse colour, or its tint).
Vec3f aov_albedo(const scenes::Scene& scene, const scenes::Material& m, const Interaction& it);

}  // namespace renderer::bsdf
