#include "renderer/integrators/path.h"

#include <cmath>

#include "renderer/interaction.h"
#include "renderer/sampling.h"
#include "renderer/spawn.h"

namespace renderer {

namespace {

/// Diffuse reflectance at a hit; emitters do not reflect (a course trap) unless the
/// material says it does both.
Vec3f reflectance(const scenes::Scene& scene, const Interaction& it) {
    if (it.material >= scene.materials.size()) return Vec3f(0.8f);
    const scenes::Material& m = scene.materials[it.material];
    if (m.is_emissive() && !m.emitter_reflects) return Vec3f(0.0f);
    return m.albedo * texel(scene, m.albedo_texture, it.uv);
}

bool is_black(const Vec3f& v) { return !(v.x > 0 || v.y > 0 || v.z > 0); }

}  // namespace

PathIntegrator::PathIntegrator(const scenes::Scene& scene, const SceneGeometry& geometry,
                               const LightSet& lights, const IntegratorSettings& settings)
    : scene_(scene), geometry_(geometry), lights_(lights), s_(settings) {
    const accel::Bounds3f b = scene.bounds();
    scale_ = b.empty() ? 1.0f : accel::max_component(b.diagonal());
    if (s_.name == "direct") s_.max_depth = std::min(s_.max_depth, 1);
}

bool PathIntegrator::counts(int bounce) const {
    if (!s_.accumulate && bounce != s_.max_depth) return false;
    if (s_.only == "direct") return bounce <= 1;
    if (s_.only == "indirect") return bounce >= 2;
    return true;
}

Vec3f PathIntegrator::li(const accel::Ray& camera_ray, SampleContext& ctx) const {
    accel::Hit hit;
    if (!ctx.accel.intersect(camera_ray, hit, ctx.stats))
        return counts(0) ? lights_.environment() : Vec3f(0.0f);
    Interaction it = make_interaction(scene_, geometry_, camera_ray, hit);
    ctx.aov.normal = it.ns;
    ctx.aov.depth = it.t;
    ctx.aov.albedo = reflectance(scene_, it);

    Vec3f L(0.0f);
    Vec3f wo = -accel::normalize(camera_ray.dir);
    if (counts(0)) L += lights_.emitted(it, wo);
    Vec3f beta(1.0f);
    for (int bounce = 1; bounce <= s_.max_depth; ++bounce) {
        const Vec3f albedo = reflectance(scene_, it);
        if (is_black(albedo)) break;
        // Shade the side the ray arrived on (two-sided diffuse surfaces).
        if (accel::dot(it.ng, wo) < 0) it.ng = -it.ng;
        if (accel::dot(it.ns, it.ng) < 0) it.ns = -it.ns;

        if (counts(bounce)) L += beta * direct(it, wo, albedo, ctx);
        if (bounce == s_.max_depth) break;
        // Russian roulette from the second bounce on: unbiased, since survivors are
        // reweighted by 1/p.
        if (bounce >= 2 && s_.rr_continue < 1.0f) {
            if (ctx.rng.next_float() >= s_.rr_continue) break;
            beta = beta / s_.rr_continue;
        }
        // Cosine-weighted bounce: f * cos(wi) / pdf(wi) = (albedo/pi) * cos / (cos/pi) =
        // albedo. The cosine is that of the sampled INCOMING direction wi.
        const Vec3f local = cosine_hemisphere(ctx.rng.next_float(), ctx.rng.next_float());
        const Vec3f wi = to_world(local, it.ns);
        if (!(local.z > 0) || accel::dot(wi, it.ng) <= 0) break;
        beta *= albedo;
        const accel::Ray ray = spawn_ray(it.p, it.p_error, it.ng, wi, scale_, s_.offset);
        if (!ctx.accel.intersect(ray, hit, ctx.stats)) break;  // environment: counted by direct()
        it = make_interaction(scene_, geometry_, ray, hit);
        wo = -wi;
        // Emission found by a bounce ray is not added (LightSet::emitted): under
        // --lights=mesh direct() counted it at the previous vertex; under course it is
        // black, as the course's bounce adds only the light sampled at the next vertex.
    }
    return L;
}

Vec3f PathIntegrator::direct(const Interaction& it, const Vec3f& wo, const Vec3f& albedo,
                             SampleContext& ctx) const {
    (void)wo;
    return s_.hemisphere ? direct_hemisphere(it, albedo, ctx) : direct_lights(it, albedo, ctx);
}

Vec3f PathIntegrator::direct_lights(const Interaction& it, const Vec3f& albedo, SampleContext& ctx) const {
    const Vec3f f = albedo * accel::kInvPi;  // Lambert: R / pi
    Vec3f sum(0.0f);
    for (size_t i = 0; i < lights_.size(); ++i) {
        const int n = lights_.is_delta(i) ? 1 : s_.light_samples;
        Vec3f acc(0.0f);
        for (int k = 0; k < n; ++k) {
            LightSample ls;
            if (!lights_.sample(i, it.p, it.ns, ctx.rng, ls)) continue;
            const float cos_s = accel::dot(it.ns, ls.wi);
            if (!(cos_s > 0) || accel::dot(it.ng, ls.wi) <= 0) continue;
            const accel::Ray shadow = std::isfinite(ls.distance)
                                          ? spawn_segment(it.p, it.p_error, it.ng, ls.target, ls.target_error,
                                                          scale_, s_.offset, ls.normal)
                                          : spawn_ray(it.p, it.p_error, it.ng, ls.wi, scale_, s_.offset);
            if (ctx.accel.occluded(shadow, ctx.stats)) continue;
            acc += ls.radiance * f * (cos_s / ls.pdf);
        }
        sum += acc / float(n);
    }
    return sum;
}

Vec3f PathIntegrator::direct_hemisphere(const Interaction& it, const Vec3f& albedo, SampleContext& ctx) const {
    const Vec3f f = albedo * accel::kInvPi;
    Vec3f sum(0.0f);
    const int n = s_.light_samples;
    for (int k = 0; k < n; ++k) {
        const Vec3f local = uniform_hemisphere(ctx.rng.next_float(), ctx.rng.next_float());
        const Vec3f wi = to_world(local, it.ns);
        if (accel::dot(wi, it.ng) <= 0) continue;
        const accel::Ray ray = spawn_ray(it.p, it.p_error, it.ng, wi, scale_, s_.offset);
        accel::Hit hit;
        Vec3f Le;
        if (ctx.accel.intersect(ray, hit, ctx.stats))
            Le = lights_.emitted(make_interaction(scene_, geometry_, ray, hit), -wi);
        else
            Le = lights_.environment();
        sum += Le * f * (local.z / kUniformHemispherePdf);
    }
    return sum / float(n);
}

}  // namespace renderer
