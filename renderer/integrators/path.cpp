#include "renderer/integrators/path.h"

#include <cmath>

#include "renderer/bsdf/bsdf.h"
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
    return base_colour(scene, m, it);
}

bool is_unlit(const scenes::Scene& scene, const Interaction& it) {
    return it.material < scene.materials.size() && scene.materials[it.material].unlit;
}

bool is_black(const Vec3f& v) { return !(v.x > 0 || v.y > 0 || v.z > 0); }

/// The course's direct-light estimate: every light, -l samples each (one for delta
/// lights), averaged per light. `contribution(i, n, sample)` weighs one sample. The first
/// sample that reads numbers takes the vertex's light dimensions (renderer/sampler.h);
/// any further ones (more lights, -l > 1) are hashed independently.
template <class F>
Vec3f sum_light_samples(const LightSet& lights, int light_samples, const Interaction& it, int bounce,
                        SampleContext& ctx, F&& contribution) {
    Vec3f sum(0.0f);
    uint32_t drawn = 0;
    const uint32_t base = dims::bounce(bounce);
    for (size_t i = 0; i < lights.size(); ++i) {
        const int n = lights.is_delta(i) ? 1 : light_samples;
        Vec3f acc(0.0f);
        for (int k = 0; k < n; ++k) {
            float choice = 0.0f;
            Vec2f u;
            if (lights.uses_point(i)) {
                const uint32_t d = drawn == 0 ? base : dims::extra_light(bounce, drawn);
                if (lights.uses_choice(i)) choice = ctx.get1d(d + dims::kLightChoice);
                u = ctx.get2d(d + dims::kLightPoint);
                ++drawn;
            }
            LightSample ls;
            if (lights.sample(i, it.p, it.ns, choice, u, ls)) acc += contribution(i, n, ls);
        }
        sum += acc / float(n);
    }
    return sum;
}

/// Russian roulette on the throughput (pbrt-v4 PathIntegrator, after Arvo and Kirk 1990):
/// a path whose throughput has fallen below 1 survives with probability equal to it (its
/// largest channel, with refraction's 1/eta^2 undone by eta_scale), and survivors carry
/// 1/(1 - q). Unlike a fixed probability it never cuts a bright path through a mirror or
/// glass, and stops dim ones sooner. roulette_q is the chance to end; a path that goes
/// on (PathIntegrator::roulette) carries beta / (1 - q) from then on (roulette_reweigh),
/// which the integrator applies only after adding the light its bounce ray found (late
/// roulette).
float roulette_q(const Vec3f& beta, float eta_scale, bool sqrt_rule) {
    // Cycles' rule continues with sqrt of the throughput: dim paths live longer, so fewer
    // survivors carry large weights (the "sqrt roulette" row of renderer/README.md).
    const float m = accel::max_component(beta * eta_scale);
    return std::max(0.0f, 1.0f - (sqrt_rule ? std::sqrt(m) : m));
}

void roulette_reweigh(Vec3f& beta, float q) {
    if (q > 0.0f) beta = beta / (1.0f - q);
}

/// Veach's power heuristic (beta = 2; Veach 1997, 9.2.4): the weight of the strategy
/// with density `a` against one with density `b` (each already times its sample count).
float mis_weight(float a, float b) {
    const float a2 = a * a, b2 = b * b;
    return a2 + b2 > 0 ? a2 / (a2 + b2) : 0.0f;
}

}  // namespace

PathIntegrator::PathIntegrator(const scenes::Scene& scene, const SceneGeometry& geometry,
                               const LightSet& lights, const IntegratorSettings& settings)
    : scene_(scene), geometry_(geometry), lights_(lights), s_(settings) {
    const accel::Bounds3f b = scene.bounds();
    scale_ = b.empty() ? 1.0f : accel::max_component(b.diagonal());
    if (s_.name == "direct") s_.max_depth = std::min(s_.max_depth, 1);
    if (s_.only == "direct") counted_hi_ = 1;
    if (s_.only == "indirect") counted_lo_ = 2;
    if (!s_.accumulate) {  // -a off: only the light of exactly max_depth bounces
        counted_lo_ = std::max(counted_lo_, s_.max_depth);
        counted_hi_ = std::min(counted_hi_, s_.max_depth);
    }
    diffuse_mis_ = s_.strategy == IntegratorSettings::Strategy::Mis && lights_.model() == LightModel::Mesh &&
                   !s_.hemisphere;
    for (const scenes::Material& m : scene.materials) {
        unlit_ |= m.unlit;
        textured_ |= is_textured(m);
    }
}

void PathIntegrator::footprint(Interaction& it, bool camera, const Vec3f& dir) const {
    if (!textured_ || it.material >= scene_.materials.size() || !is_textured(scene_.materials[it.material])) return;
    set_texture_footprint(it, s_.pixel_spread, s_.texture_filter, camera, dir);
}

Vec3f PathIntegrator::li(const accel::Ray& camera_ray, SampleContext& ctx) const {
    accel::Hit hit;
    if (!ctx.accel.intersect(camera_ray, hit, ctx.stats))
        return counts(0) ? lights_.environment(accel::normalize(camera_ray.dir)) : Vec3f(0.0f);
    Interaction it = make_interaction(scene_, geometry_, camera_ray, hit);
    if (textured_) footprint(it, true, accel::normalize(camera_ray.dir));
    ctx.aov.normal = it.ns;
    ctx.aov.depth = it.t;
    // One of the two: each may read a texture.
    if (it.material < scene_.materials.size() && scene_.materials[it.material].bsdf != scenes::BsdfKind::Diffuse)
        ctx.aov.albedo = bsdf::aov_albedo(scene_, scene_.materials[it.material], it);
    else
        ctx.aov.albedo = reflectance(scene_, it);

    Vec3f L(0.0f);
    Vec3f wo = -accel::normalize(camera_ray.dir);
    if (unlit_ && is_unlit(scene_, it)) {
        // KHR_materials_unlit: the camera sees the base colour itself, as a viewer shows
        // it, from the front face only unless double-sided (glTF's culling).
        const scenes::Material& m = scene_.materials[it.material];
        if (!counts(0) || (!m.double_sided && accel::dot(it.ng, wo) <= 0)) return L;
        return base_colour(scene_, m, it);
    }
    if (counts(0)) L += lights_.emitted(it, wo);
    const int split = ctx.split > 0 ? ctx.split : s_.split;
    if (split > 1 && s_.max_depth >= 2)
        return L + split_at_camera_hit(it, wo, split, ctx);
    return L + walk(it, wo, VertexParts{}, ctx);
}

Vec3f PathIntegrator::split_at_camera_hit(const Interaction& it, const Vec3f& wo,
                                          int split, SampleContext& ctx) const {
    const float k = float(split);
    // The camera hit's direct light once, from the camera sample's numbers, each light
    // sample weighed against the k bounce samples; then k branches without it.
    Vec3f L(0.0f);
    if (counts(1)) L = walk(it, wo, VertexParts{true, false, k}, ctx);
    Vec3f branches(0.0f);
    for (int j = 0; j < split; ++j) {
        ctx.begin_branch(uint32_t(j));
        branches += walk(it, wo, VertexParts{false, true, k}, ctx);
    }
    return L + branches / k;
}

Vec3f PathIntegrator::walk(Interaction it, Vec3f wo, VertexParts first,
                           SampleContext& ctx) const {
    Vec3f L(0.0f);
    accel::Hit hit;
    Vec3f beta(1.0f);
    float eta_scale = 1.0f;  // product of eta^2 over the refractions so far
    for (int bounce = 1; bounce <= s_.max_depth; ++bounce) {
        // What this vertex does: the first as told (a split camera hit), the rest all.
        const VertexParts part = bounce == 1 ? first : VertexParts{};
        ctx.draw_vertex(bounce, part.draws());
        // Non-diffuse materials take the general BSDF path; diffuse ones keep the
        // Lambert-only loop below, so a diffuse scene costs what it did before.
        if (it.material < scene_.materials.size()) {
            const scenes::Material& m = scene_.materials[it.material];
            // Unlit surfaces are for camera rays only: black to every other ray, so they
            // neither reflect nor light anything (Blender's import likewise limits their
            // colour to camera rays).
            if (unlit_ && m.unlit) break;
            if (m.bsdf != scenes::BsdfKind::Diffuse) {
                if (m.is_emissive() && !m.emitter_reflects) break;
                // At the camera hit the albedo AOV is the glTF material's base colour
                // (aov_albedo), looked up already: one texture lookup less per sample.
                const bool aov_is_base = bounce == 1 && m.bsdf == scenes::BsdfKind::MetallicRoughness;
                if (!scatter(m, bounce, it, wo, beta, eta_scale, L, ctx,
                             aov_is_base ? &ctx.aov.albedo : nullptr, part))
                    break;
                continue;
            }
        }
        // At the camera hit, the albedo AOV is this very value.
        const Vec3f albedo = bounce == 1 ? ctx.aov.albedo : reflectance(scene_, it);
        if (is_black(albedo)) break;
        // Shade the side the ray arrived on (two-sided diffuse surfaces).
        if (accel::dot(it.ng, wo) < 0) it.ng = -it.ng;
        if (accel::dot(it.ns, it.ng) < 0) it.ns = -it.ns;

        // Light found by this vertex's bounce ray is weighed against its light samples
        // where both strategies run (diffuse_mis_); at the last vertex light sampling
        // alone carries it.
        const bool mis = diffuse_mis_ && bounce < s_.max_depth;
        if (counts(bounce) && part.direct)
            L += beta * (s_.hemisphere ? direct_hemisphere(it, bounce, albedo, ctx)
                                       : direct_lights(it, bounce, albedo, ctx, mis,
                                                       part.bsdf_count));
        if (bounce == s_.max_depth || !part.bounce) break;
        // The course's fixed-probability roulette from the second bounce on: unbiased,
        // since survivors are reweighted by 1/p.
        const uint32_t d = dims::bounce(bounce);
        if (!s_.throughput_roulette() && bounce >= 2 && s_.rr_continue < 1.0f) {
            if (ctx.get1d(d + dims::kRoulette) >= s_.rr_continue) break;
            beta = beta / s_.rr_continue;
        }
        // Cosine-weighted bounce: f * cos(wi) / pdf(wi) = (albedo/pi) * cos / (cos/pi) =
        // albedo. The cosine is that of the sampled INCOMING direction wi.
        const Vec2f u = ctx.get2d(d + dims::kBsdfDir);
        const Vec3f local = cosine_hemisphere(u.x, u.y);
        const Vec3f wi = to_world(local, it.ns);
        if (!(local.z > 0) || accel::dot(wi, it.ng) <= 0) break;
        beta *= albedo;
        // Throughput roulette weighs the throughput after this vertex's albedo. Where the
        // bounce ray's light counts (MIS), the path ends only after that light is added
        // ("late roulette" in renderer/README.md); else before the ray is traced, so a
        // path that ends costs no trace.
        const bool emission_counts = mis && counts(bounce);
        float q = 0.0f;
        bool goes_on = true;
        if (s_.throughput_roulette() && bounce >= 2) {
            goes_on = roulette(beta, eta_scale, d, ctx, q);
            if (!goes_on && !emission_counts) break;
        }
        const Vec3f p_here = it.p, n_here = it.ns;
        bool needed;
        const bool found = trace_bounce(it, wi, goes_on, hit, ctx, needed);
        // Without MIS, light that a bounce ray finds is not added: direct lighting counted
        // all of it at this vertex (under --lights=course a bounce is black to emission,
        // as in the course).
        if (emission_counts && (needed || !found)) {
            const float bsdf_pdf = part.bsdf_count * local.z * accel::kInvPi;
            L += beta * found_light(found ? &it : nullptr, hit, p_here, n_here, wi,
                                    [&](float light_pdf) { return mis_weight(bsdf_pdf, light_pdf); });
        }
        if (!found || !goes_on) break;
        roulette_reweigh(beta, q);
        wo = -wi;
    }
    return L;
}

bool PathIntegrator::scatter(const scenes::Material& m, int bounce, Interaction& it,
                             Vec3f& wo, Vec3f& beta, float& eta_scale, Vec3f& L,
                             SampleContext& ctx, const Vec3f* base_colour,
                             VertexParts part) const {
    // The local frame faces wo; `front` remembers which side of the surface that is, for
    // a dielectric's relative index.
    const bool front = accel::dot(it.ng, wo) > 0;
    it.ns = bsdf::mapped_normal(scene_, m, it);
    if (!front) it.ng = -it.ng;
    if (accel::dot(it.ns, it.ng) < 0) it.ns = -it.ns;
    const bsdf::Bsdf b = bsdf::make_bsdf(scene_, m, it, front, base_colour);
    Vec3f t, bt;
    onb(it.ns, t, bt);
    const Vec3f wo_l(accel::dot(wo, t), accel::dot(wo, bt), accel::dot(wo, it.ns));
    if (!(wo_l.z > 0)) return false;
    const bool delta = b.is_delta();
    using Strategy = IntegratorSettings::Strategy;
    // Under --lights=course a bounce never sees emission, so BSDF-only sampling would
    // lose the panel's light: there --strategy=bsdf falls back to MIS.
    const bool course = lights_.model() == LightModel::Course;
    const Strategy strategy = course && s_.strategy == Strategy::Bsdf ? Strategy::Mis : s_.strategy;
    if (!delta && counts(bounce) && strategy != Strategy::Bsdf && part.direct)
        L += beta * direct_bsdf(it, bounce, wo_l, t, bt, b, ctx, part.bsdf_count);
    if (!part.bounce) return false;
    // At the last vertex the BSDF sample still runs when its emission counts: it is the
    // other half of the MIS estimate of direct light (and all of it through delta lobes).
    const bool last = bounce == s_.max_depth;
    if (last && !counts(bounce)) return false;
    const uint32_t d = dims::bounce(bounce);
    if (!s_.throughput_roulette() && !last && bounce >= 2 && s_.rr_continue < 1.0f) {
        if (ctx.get1d(d + dims::kRoulette) >= s_.rr_continue) return false;
        beta = beta / s_.rr_continue;
    }
    bsdf::Sample bs;
    const Vec2f u = ctx.get2d(d + dims::kBsdfDir);
    const float uc = ctx.get1d(d + dims::kBsdfLobe);
    if (!b.sample(wo_l, u.x, u.y, uc, bs)) return false;
    // Weight of an emitter found by the BSDF sample, given the light strategy's density.
    const auto bsdf_weight = [&](float light_pdf) {
        if (delta || strategy == Strategy::Bsdf) return 1.0f;
        if (strategy == Strategy::Light) return light_pdf > 0 ? 0.0f : 1.0f;
        return mis_weight(part.bsdf_count * bs.pdf, light_pdf);
    };
    const Vec3f wi = t * bs.wi.x + bt * bs.wi.y + it.ns * bs.wi.z;
    // A direction on the other side of the geometric surface than its lobe says (shading
    // normals) would leak light through the surface.
    if ((accel::dot(wi, it.ng) > 0) != (bs.wi.z > 0)) return false;
    beta *= bs.weight;
    if (is_black(beta)) return false;
    eta_scale *= bs.eta * bs.eta;
    // Not at the last vertex: its BSDF sample only finds emission, and ends the path anyway.
    // Late where the ray's emission counts, as in the diffuse loop (li).
    const bool emission_counts = counts(bounce) && (delta || !course);
    float q = 0.0f;
    bool goes_on = true;
    if (s_.throughput_roulette() && !last && bounce >= 2) {
        goes_on = roulette(beta, eta_scale, d, ctx, q);
        if (!goes_on && !emission_counts) return false;
    }
    accel::Hit hit;
    const Vec3f n_here = it.ns, p_here = it.p;
    bool needed;
    const bool found = trace_bounce(it, wi, goes_on, hit, ctx, needed);
    // Through a delta lobe light sampling cannot find the emitter or the environment: all
    // of it is counted here, at the path length of the previous vertex's direct light.
    // Through a non-delta lobe it is weighted against light sampling of the same emitter
    // (Veach 1997, 9.2), except under --lights=course, where a bounce is black to emission
    // as in the course (its lights are the sampled library_lights; the panel is no light
    // there) but not to the environment. Through a mirror or glass the course's own 3-2
    // renderer shows the emitter, and so do we.
    if (counts(bounce) && (delta || !course || !found) && (needed || !found))
        L += beta * found_light(found ? &it : nullptr, hit, p_here, n_here, wi, bsdf_weight);
    if (!found || !goes_on) return false;
    roulette_reweigh(beta, q);
    wo = -wi;
    return !last;
}

bool PathIntegrator::roulette(const Vec3f& beta, float eta_scale, uint32_t d, SampleContext& ctx, float& q) const {
    q = roulette_q(beta, eta_scale, s_.sqrt_roulette());
    const float u = ctx.get1d(d + dims::kRoulette);  // drawn either way: streams stay in step
    return q <= 0.0f || !(u < q);
}

bool PathIntegrator::trace_bounce(Interaction& it, const Vec3f& wi, bool goes_on, accel::Hit& hit,
                                  SampleContext& ctx, bool& moved) const {
    const accel::Ray ray = spawn_unit_ray(it.p, it.p_error, it.ng, wi, scale_, s_.offset);
    // A path that ends here looks only for emission: none to find, no trace (the guard
    // says yes wherever an environment could answer a miss).
    if (!goes_on && !lights_.may_emit_toward(ray)) {
        moved = false;
        return false;
    }
    const bool found = ctx.accel.intersect(ray, hit, ctx.stats);
    // A path that ends here needs the hit only if it emits.
    moved = found && (goes_on || emissive(hit));
    if (moved) {
        make_interaction(scene_, geometry_, ray, hit, it);
        if (textured_) footprint(it, false, wi);
    }
    return found;
}

bool PathIntegrator::emissive(const accel::Hit& hit) const {
    const uint32_t m = geometry_.material(hit.geom_id, hit.prim_id);
    return m < scene_.materials.size() && scene_.materials[m].is_emissive();
}

template <class W>
Vec3f PathIntegrator::found_light(const Interaction* next, const accel::Hit& hit, const Vec3f& p, const Vec3f& n,
                                  const Vec3f& wi, W&& weight) const {
    const float samples = float(s_.light_samples);
    if (!next) {
        const int e = lights_.environment_index();
        if (e < 0) return Vec3f(0.0f);
        return lights_.environment(wi) * weight(samples * lights_.pdf(size_t(e), p, n, wi, 0.0f, Vec3f(0.0f)));
    }
    const Vec3f Le = lights_.emitted(*next, -wi);
    if (is_black(Le)) return Le;
    const GeomSource& src = geometry_.source(hit.geom_id);
    // An instanced emitter's light is that of its prototype mesh's placements.
    const int li = src.kind == GeomSource::Mesh ? lights_.light_of_mesh(src.mesh, hit.inst_id)
                                                : lights_.light_of_sphere(hit.prim_id);
    return Le * weight(li < 0 ? 0.0f
                              : samples * lights_.pdf(size_t(li), p, n, wi, next->t, next->ng, hit.prim_id,
                                                      hit.inst_id));
}

bool PathIntegrator::occluded(const Interaction& it, const LightSample& ls, SampleContext& ctx) const {
    const accel::Ray shadow = std::isfinite(ls.distance)
                                  ? spawn_segment(it.p, it.p_error, it.ng, ls.target, ls.target_error, scale_,
                                                  s_.offset, ls.normal)
                                  : spawn_ray(it.p, it.p_error, it.ng, ls.wi, scale_, s_.offset);
    return ctx.accel.occluded(shadow, ctx.stats);
}

Vec3f PathIntegrator::direct_bsdf(const Interaction& it, int bounce, const Vec3f& wo_l,
                                  const Vec3f& t, const Vec3f& bt, const bsdf::Bsdf& b,
                                  SampleContext& ctx, float bsdf_count) const {
    return sum_light_samples(lights_, s_.light_samples, it, bounce, ctx, [&](size_t i, int n, const LightSample& ls) {
        const Vec3f wi_l(accel::dot(ls.wi, t), accel::dot(ls.wi, bt), accel::dot(ls.wi, it.ns));
        if ((accel::dot(it.ng, ls.wi) > 0) != (wi_l.z > 0)) return Vec3f(0.0f);
        const Vec3f f = b.f(wo_l, wi_l);
        if (is_black(f)) return Vec3f(0.0f);
        // Lights a BSDF sample can also hit share the estimate by the power heuristic;
        // n light samples count n times in the light strategy's density.
        const float w =
            ls.delta || !lights_.hittable(i) ||
                    s_.strategy == IntegratorSettings::Strategy::Light
                ? 1.0f
                : mis_weight(float(n) * ls.pdf, bsdf_count * b.pdf(wo_l, wi_l));
        if (occluded(it, ls, ctx)) return Vec3f(0.0f);
        return ls.radiance * f * (std::abs(wi_l.z) * w / ls.pdf);
    });
}

Vec3f PathIntegrator::direct_lights(const Interaction& it, int bounce,
                                    const Vec3f& albedo, SampleContext& ctx, bool mis,
                                    float bsdf_count) const {
    const Vec3f f = albedo * accel::kInvPi;  // Lambert: R / pi
    return sum_light_samples(lights_, s_.light_samples, it, bounce, ctx, [&](size_t i, int n, const LightSample& ls) {
        const float cos_s = accel::dot(it.ns, ls.wi);
        if (!(cos_s > 0) || accel::dot(it.ng, ls.wi) <= 0) return Vec3f(0.0f);
        // The bounce's cosine sampling finds this direction with density cos / pi.
        const float w =
            mis && !ls.delta && lights_.hittable(i)
                ? mis_weight(float(n) * ls.pdf, bsdf_count * cos_s * accel::kInvPi)
                : 1.0f;
        if (!(w > 0) || occluded(it, ls, ctx)) return Vec3f(0.0f);
        return ls.radiance * f * (cos_s * w / ls.pdf);
    });
}

Vec3f PathIntegrator::direct_hemisphere(const Interaction& it, int bounce, const Vec3f& albedo,
                                        SampleContext& ctx) const {
    const Vec3f f = albedo * accel::kInvPi;
    Vec3f sum(0.0f);
    const int n = s_.light_samples;
    for (int k = 0; k < n; ++k) {
        const uint32_t d = k == 0 ? dims::bounce(bounce) : dims::extra_light(bounce, uint32_t(k));
        const Vec2f u = ctx.get2d(d + dims::kLightPoint);
        const Vec3f local = uniform_hemisphere(u.x, u.y);
        const Vec3f wi = to_world(local, it.ns);
        if (accel::dot(wi, it.ng) <= 0) continue;
        const accel::Ray ray = spawn_ray(it.p, it.p_error, it.ng, wi, scale_, s_.offset);
        accel::Hit hit;
        Vec3f Le;
        if (ctx.accel.intersect(ray, hit, ctx.stats)) {
            Interaction e = make_interaction(scene_, geometry_, ray, hit);
            if (textured_) footprint(e, false, wi);
            Le = lights_.emitted(e, -wi);
        }
        else
            Le = lights_.environment(wi);
        sum += Le * f * (local.z / kUniformHemispherePdf);
    }
    return sum / float(n);
}

}  // namespace renderer
