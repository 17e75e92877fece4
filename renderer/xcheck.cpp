#include "renderer/xcheck.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <cmath>

#include "accel/primitive.h"

namespace renderer {

const char* verdict_name(Verdict v) {
    switch (v) {
        case Verdict::Agree: return "agree";
        case Verdict::Tie: return "tie";
        case Verdict::Numerical: return "numerical";
        case Verdict::Real: return "real";
    }
    return "?";
}

namespace {
/// trace_set_into for a backend with batched entry points: the same chunks of 1024 rays,
/// each traced by one batched call.
void trace_batches(const accel::Accelerator& accel, const RaySet& set, bool any_hit,
                   tbb::enumerable_thread_specific<accel::TraceStats>& local, std::vector<RayOutcome>& out) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, set.rays.size(), 1024), [&](const tbb::blocked_range<size_t>& r) {
        accel::TraceStats& st = local.local();
        const std::span<const accel::Ray> rays(set.rays.data() + r.begin(), r.size());
        if (any_hit) {
            std::vector<uint8_t> occluded(r.size());
            accel.occluded_batch(rays, occluded.data(), st);
            for (size_t i = 0; i < r.size(); ++i) {
                out[r.begin() + i] = RayOutcome{};
                out[r.begin() + i].hit = occluded[i] != 0;
            }
            return;
        }
        std::vector<accel::Hit> hits(r.size());
        accel.intersect_batch(rays, hits.data(), st);
        for (size_t i = 0; i < r.size(); ++i) {
            const accel::Hit& h = hits[i];
            out[r.begin() + i] = h.valid() ? RayOutcome{true, h.t, h.u, h.v, h.geom_id, h.prim_id, h.ng, h.inst_id} : RayOutcome{};
        }
    });
}
}  // namespace

void trace_set_into(const accel::Accelerator& accel, const RaySet& set, accel::TraceStats& stats,
                    std::vector<RayOutcome>& out, bool closest_for_shadow) {
    out.resize(set.rays.size());
    accel::TraceStats proto;
    proto.counting = stats.counting;  // uncounted traces run the backend's lean path
    tbb::enumerable_thread_specific<accel::TraceStats> local(proto);
    const bool any_hit = set.occlusion() && !closest_for_shadow;
    if (accel.has_batches()) {
        trace_batches(accel, set, any_hit, local, out);
        for (const accel::TraceStats& s : local) stats += s;
        return;
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, set.rays.size(), 1024),
                      [&](const tbb::blocked_range<size_t>& r) {
                          accel::TraceStats& st = local.local();
                          for (size_t i = r.begin(); i != r.end(); ++i) {
                              RayOutcome& o = out[i];
                              if (any_hit) {
                                  o = RayOutcome{};
                                  o.hit = accel.occluded(set.rays[i], st);
                                  continue;
                              }
                              accel::Hit h;
                              if (accel.intersect(set.rays[i], h, st))
                                  o = {true, h.t, h.u, h.v, h.geom_id, h.prim_id, h.ng, h.inst_id};
                              else
                                  o = RayOutcome{};
                          }
                      });
    for (const accel::TraceStats& s : local) stats += s;
}

std::vector<RayOutcome> trace_set(const accel::Accelerator& accel, const RaySet& set,
                                  accel::TraceStats& stats, bool closest_for_shadow) {
    std::vector<RayOutcome> out;
    trace_set_into(accel, set, stats, out, closest_for_shadow);
    return out;
}

namespace {

bool same_position(const accel::Vec3f& a, const accel::Vec3f& b) { return a == b; }

/// The hit triangle where the hit's placement puts it: a prototype's triangles are in
/// object space.
void hit_triangle(const SceneGeometry& g, const RayOutcome& o, accel::Vec3f p[3]) {
    accel::triangle_vertices(g.views()[o.geom], o.prim, p[0], p[1], p[2]);
    if (o.inst == accel::kInvalidId) return;
    const accel::Affine3f& m = g.instances().instances[o.inst].object_to_world;
    for (int k = 0; k < 3; ++k) p[k] = m.point(p[k]);
}

/// Do two triangles share a vertex position (and so possibly the edge the ray hit)?
bool share_vertex(const SceneGeometry& g, const RayOutcome& a, const RayOutcome& b) {
    if (g.views()[a.geom].type != accel::GeometryType::Triangles ||
        g.views()[b.geom].type != accel::GeometryType::Triangles)
        return false;
    accel::Vec3f pa[3], pb[3];
    hit_triangle(g, a, pa);
    hit_triangle(g, b, pb);
    for (const auto& x : pa)
        for (const auto& y : pb)
            if (same_position(x, y)) return true;
    return false;
}

/// Is a single hit within rounding of the primitive's boundary, or ill-conditioned?
bool hit_is_marginal(const accel::Ray& ray, const RayOutcome& h, const SceneGeometry& g) {
    const auto& view = g.views()[h.geom];
    const float rel = 1e-4f;
    // Segment ends: a hit right at t_min or t_max may fall either side.
    if (std::abs(h.t - ray.t_max) <= rel * std::max(std::abs(ray.t_max), 1e-30f)) return true;
    if (std::abs(h.t - ray.t_min) <= rel * std::max(std::abs(h.t), 1e-30f) + 1e-30f) return true;
    const accel::Vec3f dn = accel::normalize(ray.dir);
    if (view.type == accel::GeometryType::Triangles) {
        const float w = 1.0f - h.u - h.v;
        if (std::min({w, h.u, h.v}) < rel) return true;  // at an edge or vertex
        // A cut-out's contour: where the alpha is within rounding of the cutoff, a
        // barycentric a few ulps off (another backend's arithmetic, an instance's
        // transform) keeps or drops the hit. Bound: the hit point's rounding (8 ulps of
        // its magnitude: the copy's rounded vertices, the ray's and an instance
        // transform's few operations, each within an ulp or two) over the
        // triangle's smallest height moves the barycentrics, times the uvs' span moves
        // uv, and a bilinear alpha changes by at most 1 per texel. Blended surfaces decide
        // by a hash of the ray and the hit's ids, which an instance and its flattened copy
        // name apart: any blended hit is marginal between the two.
        if (view.masked() && view.filter == alpha_filter) {
            const AlphaTest& a = *static_cast<const AlphaTest*>(view.filter_user);
            if (a.mode == scenes::AlphaMode::Blend) return true;
            if (a.mode == scenes::AlphaMode::Mask) {
                float slack = 1e-3f;
                const bool textured = a.texture && !a.mesh->uvs.empty();
                if (textured || !a.mesh->alphas.empty()) {
                    // In world space, as the hit point below is.
                    accel::Vec3f v[3];
                    hit_triangle(g, h, v);
                    const float area2 = accel::length(accel::cross(v[1] - v[0], v[2] - v[0]));
                    const float longest =
                        std::max({accel::length(v[1] - v[0]), accel::length(v[2] - v[1]), accel::length(v[0] - v[2])});
                    const accel::Vec3f p = ray.org + ray.dir * h.t;
                    const float mag = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
                    const float d_bary = 8.0f * 0x1p-24f * mag * longest / std::max(area2, 1e-30f);
                    const uint32_t* idx = &a.mesh->indices[3 * size_t(h.prim)];
                    if (textured) {
                        float span = 0;
                        for (int k = 1; k < 3; ++k) {
                            const accel::Vec2f q = a.mesh->uvs[idx[k]], o = a.mesh->uvs[idx[0]];
                            span = std::max({span, std::abs(q.x - o.x), std::abs(q.y - o.y)});
                        }
                        slack += d_bary * span * float(std::max(a.texture->width, a.texture->height));
                    }
                    // Vertex alpha (COLOR_0's) changes by at most its span over the triangle.
                    if (!a.mesh->alphas.empty())
                        slack += d_bary * std::max({std::abs(a.mesh->alphas[idx[1]] - a.mesh->alphas[idx[0]]),
                                                    std::abs(a.mesh->alphas[idx[2]] - a.mesh->alphas[idx[0]])});
                }
                if (std::abs(surface_alpha(a, h.prim, h.u, h.v) - a.cutoff) < slack) return true;
            }
        }
        // Grazing: the hit position along the ray is ill-conditioned.
        const accel::Vec3f n = accel::normalize(h.ng);
        if (std::abs(accel::dot(n, dn)) < 1e-3f) return true;
        return false;
    }
    // Spheres: near the silhouette the two roots merge.
    const accel::Vec3f c = accel::sphere_center(view, h.prim);
    const float r = accel::sphere_radius(view, h.prim);
    const accel::Vec3f f = ray.org - c;
    const accel::Vec3f perp = f - dn * accel::dot(f, dn);
    return std::abs(accel::length(perp) - r) <= 1e-3f * r;
}

}  // namespace

Verdict classify(const accel::Ray& ray, bool occlusion, const RayOutcome& ref, const RayOutcome& other,
                 const RayOutcome& ref_c, const RayOutcome& other_c, const SceneGeometry& g,
                 float scale) {
    if (occlusion) {
        if (ref.hit == other.hit) return Verdict::Agree;
        // One backend saw an occluder the other did not: judge by the closest hits.
        const RayOutcome& seen = ref.hit ? ref_c : other_c;
        if (!seen.hit) return Verdict::Real;  // occluded() and intersect() disagree
        return hit_is_marginal(ray, seen, g) ? Verdict::Numerical : Verdict::Real;
    }
    (void)ref_c;
    (void)other_c;
    if (!ref.hit && !other.hit) return Verdict::Agree;
    if (ref.hit && other.hit) {
        if (ref.geom == other.geom && ref.prim == other.prim && ref.inst == other.inst) return Verdict::Agree;
        const float dt = std::abs(ref.t - other.t);
        const float tt = std::max(std::abs(ref.t), std::abs(other.t));
        const float dlen = accel::length(ray.dir);
        const bool same_t = dt <= 1e-4f * tt || dt * dlen <= 1e-6f * scale;
        if (same_t && share_vertex(g, ref, other)) return Verdict::Tie;
        // Coincident or coplanar surfaces (a light panel on a ceiling) or a marginal hit.
        if (dt <= 1e-3f * tt || hit_is_marginal(ray, ref, g) || hit_is_marginal(ray, other, g))
            return Verdict::Numerical;
        return Verdict::Real;
    }
    const RayOutcome& seen = ref.hit ? ref : other;
    return hit_is_marginal(ray, seen, g) ? Verdict::Numerical : Verdict::Real;
}

KindReport compare_backends(const accel::Accelerator& ref, const std::string& ref_label,
                            const accel::Accelerator& other, const std::string& other_label,
                            const RaySet& set, const SceneGeometry& geometry,
                            std::vector<Disagreement>* out, size_t keep) {
    KindReport rep;
    rep.kind = set.kind;
    rep.reference = ref_label;
    rep.backend = other_label;
    rep.rays = set.rays.size();
    accel::TraceStats ref_stats;
    std::vector<RayOutcome> a = trace_set(ref, set, ref_stats);
    std::vector<RayOutcome> b = trace_set(other, set, rep.stats);
    std::vector<RayOutcome> ac, bc;
    if (set.occlusion()) {
        accel::TraceStats ignore;
        ac = trace_set(ref, set, ignore, true);
        bc = trace_set(other, set, ignore, true);
    }
    const accel::Bounds3f bounds = ref.bounds();
    const float scale = bounds.empty() ? 1.0f : std::max(1e-30f, accel::max_component(bounds.diagonal()));
    const RayOutcome none;
    for (size_t i = 0; i < set.rays.size(); ++i) {
        const bool same_hit = a[i].hit == b[i].hit;
        rep.hit_agree += same_hit;
        const bool same_prim =
            same_hit && (set.occlusion() || !a[i].hit || (a[i].geom == b[i].geom && a[i].prim == b[i].prim && a[i].inst == b[i].inst));
        rep.prim_agree += same_prim;
        if (!set.occlusion() && a[i].hit && same_prim) {
            const double dt = std::abs(double(a[i].t) - double(b[i].t)) /
                              std::max(std::abs(double(a[i].t)), 1e-30);
            rep.max_rel_dt = std::max(rep.max_rel_dt, dt);
        }
        if (same_prim) continue;
        const Verdict v = classify(set.rays[i], set.occlusion(), a[i], b[i],
                                   set.occlusion() ? ac[i] : none, set.occlusion() ? bc[i] : none,
                                   geometry, scale);
        if (v == Verdict::Tie) ++rep.ties;
        else if (v == Verdict::Numerical) ++rep.numerical;
        else if (v == Verdict::Real) ++rep.real;
        if (out && out->size() < keep && v != Verdict::Agree)
            out->push_back({set.kind, other_label, set.rays[i], v,
                            set.occlusion() ? ac[i] : a[i], set.occlusion() ? bc[i] : b[i]});
    }
    return rep;
}

}  // namespace renderer
