#include "renderer/lights.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "renderer/interaction.h"
#include "renderer/sampling.h"
#include "renderer/spawn.h"

namespace renderer {

using accel::Vec2f;

namespace {

/// Does the rectangle light `l` describe the same emitter as emissive mesh `m`?
bool duplicates_mesh(const scenes::Light& l, const scenes::Mesh& m, const scenes::Material& mat) {
    const Vec3f n = accel::cross(l.edge_u, l.edge_v);
    const float rect_area = accel::length(n);
    if (!(rect_area > 0)) return false;
    const Vec3f un = n / rect_area;
    float mesh_area = 0;
    accel::Bounds3f b;
    for (uint32_t t = 0; t < m.num_triangles(); ++t) {
        const Vec3f a = m.positions[m.indices[3 * t]], c = m.positions[m.indices[3 * t + 1]],
                    d = m.positions[m.indices[3 * t + 2]];
        mesh_area += 0.5f * accel::length(accel::cross(c - a, d - a));
        b.extend(a); b.extend(c); b.extend(d);
        // Every vertex within 1 % of the rectangle's size of its plane.
        for (const Vec3f& v : {a, c, d})
            if (std::abs(accel::dot(v - l.position, un)) > 0.01f * std::sqrt(rect_area)) return false;
    }
    if (!(mesh_area > 0) || std::abs(mesh_area - rect_area) > 0.05f * rect_area) return false;
    if (accel::length(b.center() - l.position) > 0.25f * std::sqrt(rect_area)) return false;
    const Vec3f d = mat.emission - l.radiance;
    return accel::max_component(accel::vabs(d)) <= 0.01f * accel::max_component(l.radiance);
}

Vec3f radiance_of(const scenes::Material& m) { return m.emission; }

/// Solid-angle sampling (Arvo's trigonometry, about the cost of tracing a ray in the
/// course's boxes) is spent only on triangles nearer than kNearReach times their largest
/// centroid-to-vertex distance R. Beyond it the distances to the triangle's points differ
/// by at most a factor (k + 1) / (k - 1) (6 at k = 1.4), which area sampling's density
/// follows squared; with the light point's strata kept (uniform_triangle) that costs
/// almost no noise, and the trigonometry it saves does ("near reach" in
/// renderer/README.md: 1.4 against 2).
constexpr float kNearReach = 1.4f;

/// Is an emissive triangle sampled by solid angle from this point? Only where Arvo's
/// construction is well conditioned: below 3e-4 sr (a far or tiny triangle, where area
/// sampling's density is nearly uniform in solid angle anyway) its angle differences
/// lose their digits, and near a full hemisphere (6.22 sr) its arcs degenerate. The
/// same thresholds as pbrt-v4's Triangle::Sample. sample() and pdf() both ask this
/// with the same point, so the two always agree on the density.
bool solid_angle_sampled(const SphericalTriangle& st) {
    return st.valid() && st.solid_angle() >= 3e-4f && st.solid_angle() <= 6.22f;
}

/// A light sample's radiance times the emission texture at barycentrics (a, b) of
/// triangle `index` of `mesh` (its uvs interpolated as a hit's); false when nothing is
/// left. Shared by the world-space and the instanced triangles of mesh lights.
bool textured_emission(const scenes::Scene& scene, uint32_t texture, const scenes::Mesh& m, uint32_t index, float a,
                       float b, Vec3f& radiance) {
    const uint32_t* idx = &m.indices[3 * size_t(index)];
    const Vec2f u0 = m.uvs[idx[0]], u1 = m.uvs[idx[1]], u2 = m.uvs[idx[2]];
    const float w0 = 1.0f - a - b;
    const Vec2f uv{u0.x * w0 + u1.x * a + u2.x * b, u0.y * w0 + u1.y * a + u2.y * b};
    radiance = radiance * texel(scene, texture, uv);
    return accel::max_component(radiance) > 0;
}

}  // namespace

LightModel parse_light_model(const std::string& name, scenes::SceneFormat format) {
    if (name.empty()) return format == scenes::SceneFormat::Collada ? LightModel::Course : LightModel::Mesh;
    if (name == "course") return LightModel::Course;
    if (name == "mesh") return LightModel::Mesh;
    throw std::invalid_argument("unknown light model '" + name + "' (course | mesh)");
}

const char* light_model_name(LightModel m) { return m == LightModel::Course ? "course" : "mesh"; }

Vec3f LightSet::emitted(const Interaction& it, const Vec3f& wo) const {
    const scenes::Scene& scene = *scene_;
    if (it.material >= scene.materials.size()) return Vec3f(0.0f);
    const scenes::Material& m = scene.materials[it.material];
    if (!m.is_emissive()) return Vec3f(0.0f);
    // The course's emission has no side test; in Mesh a one-sided emitter emits toward
    // its shading normal, the side sample() draws (Tri::n below). Spheres: both sides.
    const bool two_sided = model_ == LightModel::Course || m.double_sided || it.sphere;
    if (!two_sided && accel::dot(it.ns, wo) <= 0) return Vec3f(0.0f);
    // Where the glow map's texels under the lookup are all zero, its value is 0 exactly.
    if (m.emission_texture < emission_zero_.size() &&
        emission_zero_[m.emission_texture].zero(scene.textures[m.emission_texture], it.uv, it.lod, it.filter))
        return Vec3f(0.0f);
    return m.emission * texel(scene, m.emission_texture, it);
}

LightSet::LightSet(const scenes::Scene& scene, LightModel model, std::vector<std::string>& notes)
    : model_(model), scene_(&scene) {
    if (model == LightModel::Course && scene.format == scenes::SceneFormat::Gltf) {
        model_ = LightModel::Mesh;
        notes.push_back("the course's light semantics apply to COLLADA scenes: this glTF scene uses --lights=mesh");
    }
    const bool course = model_ == LightModel::Course;
    for (const scenes::Material& m : scene.materials) {
        const uint32_t tex = m.emission_texture;
        if (!m.is_emissive() || tex >= scene.textures.size()) continue;
        emission_zero_.resize(std::max(emission_zero_.size(), size_t(tex) + 1));
        if (!emission_zero_[tex].built()) emission_zero_[tex] = ZeroTiles(scene.textures[tex]);
    }
    // Emissive meshes: one light each; a triangle is picked by area, then sampled by
    // solid angle where near (near_triangle), else by area.
    std::vector<bool> mesh_is_light(scene.meshes.size(), false);
    bool emissive_surfaces = false;
    // Prototype meshes are in object space: one light each for all the placements of its
    // prototype (instances), if it has any.
    const std::vector<int32_t> owner = scene.mesh_prototypes();
    std::vector<std::vector<uint32_t>> placements(scene.prototypes.size());
    for (uint32_t ii = 0; ii < scene.instances.size(); ++ii)
        if (scene.instances[ii].prototype < placements.size()) placements[scene.instances[ii].prototype].push_back(ii);
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
        const scenes::Mesh& m = scene.meshes[mi];
        if (m.material >= scene.materials.size() || !scene.materials[m.material].is_emissive()) continue;
        const bool instanced = owner[mi] >= 0;
        if (instanced && placements[size_t(owner[mi])].empty()) continue;  // placed nowhere
        // Glow maps (emission textures) glow but, alone, are not taken to light a scene.
        if (m.uvs.empty() || scene.materials[m.material].emission_texture == scenes::kNoTexture)
            emissive_surfaces = true;
        if (course) continue;  // seen by camera and -H rays only (emitted())
        const bool two_sided = scene.materials[m.material].double_sided;
        Light l{};
        l.kind = Kind::Mesh;
        l.radiance = radiance_of(scene.materials[m.material]);
        // A texture modulates emission only where the mesh has uvs to look it up with.
        if (!m.uvs.empty()) l.texture = scene.materials[m.material].emission_texture;
        l.first_tri = uint32_t(tris_.size());
        l.first_prim = uint32_t(tri_of_prim_.size());
        l.num_prims = m.num_triangles();
        tri_of_prim_.resize(tri_of_prim_.size() + m.num_triangles(), kNoTri);
        float total = 0;
        for (uint32_t t = 0; t < m.num_triangles(); ++t) {
            const Vec3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                        c = m.positions[m.indices[3 * t + 2]];
            const float area = 0.5f * accel::length(accel::cross(b - a, c - a));
            if (!(area > 0) || !std::isfinite(area)) continue;
            // Emits on the side its shading normals face (file normals, else winding),
            // the same rule camera and bounce rays see (renderer/integrators/path.cpp).
            Vec3f ng = accel::normalize(accel::cross(b - a, c - a));
            if (!m.normals.empty()) {
                const Vec3f avg = m.normals[m.indices[3 * t]] + m.normals[m.indices[3 * t + 1]] +
                                  m.normals[m.indices[3 * t + 2]];
                if (accel::dot(avg, ng) < 0) ng = -ng;
            }
            const Vec3f centroid = (a + b + c) * (1.0f / 3.0f);
            float reach2 = 0;
            for (const Vec3f& v : {a, b, c}) reach2 = std::max(reach2, accel::dot(v - centroid, v - centroid));
            tri_of_prim_[l.first_prim + t] = uint32_t(tris_.size()) - l.first_tri;
            tris_.push_back({a, b - a, c - a, ng, area, centroid, kNearReach * kNearReach * reach2, two_sided,
                             uint32_t(mi), t});
            total += area;
        }
        l.num_tris = uint32_t(tris_.size()) - l.first_tri;
        if (l.num_tris == 0) continue;
        build_alias_table(tris_.data() + l.first_tri, l.num_tris, pick_);
        l.area = total;
        if (instanced) {
            // Placements by power: every one shares the mesh's emission, so by world
            // area, the sum over its triangles of area * |N n| for the unit object
            // normal n: cross(L a, L b) = cof(L) cross(a, b), so the cofactor matrix
            // scales a triangle's area as it scales the length of its unit normal. A
            // placement of zero or non-finite area is left out (never sampled: a ray
            // cannot hit it either).
            l.first_inst = uint32_t(inst_ids_.size());
            std::vector<double> power;
            double total_power = 0;
            for (uint32_t ii : placements[size_t(owner[mi])]) {
                const Placement place(scene.instances[ii].object_to_world);
                double a = 0;
                for (uint32_t k = 0; k < l.num_tris; ++k) {
                    const Tri& t = tris_[l.first_tri + k];
                    a += double(t.area) * double(accel::length(place.normal(t.n)));
                }
                if (!(a > 0) || !std::isfinite(a)) continue;
                inst_ids_.push_back(ii);
                power.push_back(a);
                total_power += a;
            }
            l.num_inst = uint32_t(power.size());
            if (l.num_inst == 0) continue;  // its triangles stay in tris_, unused
            // Running sums in double, each rounded once; the last is exactly 1.
            double run = 0;
            for (uint32_t k = 0; k < l.num_inst; ++k) {
                run += power[k];
                inst_cdf_.push_back(k + 1 == l.num_inst ? 1.0f : float(run / total_power));
            }
            proto_light_.resize(scene.meshes.size(), -1);
            proto_light_[mi] = int(lights_.size());
            lights_.push_back(l);
            continue;
        }
        mesh_light_.resize(scene.meshes.size(), -1);
        mesh_light_[mi] = int(lights_.size());
        lights_.push_back(l);
        mesh_is_light[mi] = true;
    }
    for (size_t si = 0; si < scene.spheres.size(); ++si) {
        const scenes::Sphere& s = scene.spheres[si];
        if (s.material >= scene.materials.size() || !scene.materials[s.material].is_emissive()) continue;
        emissive_surfaces = true;
        if (course) continue;
        sphere_light_.resize(scene.spheres.size(), -1);
        sphere_light_[si] = int(lights_.size());
        Light l{};
        l.kind = Kind::Sphere;
        l.radiance = radiance_of(scene.materials[s.material]);
        l.position = s.center;
        l.radius = s.radius;
        l.area = 4.0f * accel::kPi * s.radius * s.radius;
        lights_.push_back(l);
    }
    for (const scenes::Light& sl : scene.lights) {
        Light l{};
        l.radiance = sl.radiance;
        l.position = sl.position;
        switch (sl.type) {
            case scenes::LightType::Area: {
                bool dup = false;
                for (size_t mi = 0; mi < scene.meshes.size() && !dup; ++mi)
                    if (mesh_is_light[mi] &&
                        duplicates_mesh(sl, scene.meshes[mi], scene.materials[scene.meshes[mi].material])) {
                        notes.push_back(fmt::format(
                            "area light '{}' describes the same emitter as emissive mesh '{}': "
                            "counted once, as the mesh (hit by camera and bounce rays, sampled as a light)",
                            sl.name, scene.meshes[mi].name));
                        dup = true;
                    }
                if (dup) continue;
                l.kind = Kind::Rect;
                l.edge_u = sl.edge_u;
                l.edge_v = sl.edge_v;
                Vec3f n = accel::cross(sl.edge_u, sl.edge_v);
                l.area = accel::length(n);
                if (!(l.area > 0)) continue;
                n = n / l.area;
                // Emits toward the file's facing direction.
                if (accel::dot(n, sl.direction) < 0) n = -n;
                l.normal = n;
                notes.push_back(
                    course ? fmt::format("area light '{}' (--lights=course): sampled for direct light (-l), "
                                         "front side only, invisible to every ray; emissive meshes are seen "
                                         "by camera and -H rays only",
                                         sl.name)
                           : fmt::format("area light '{}' has no emissive geometry: it is sampled for direct "
                                         "light but invisible to camera and bounce rays (-H)",
                                         sl.name));
                break;
            }
            case scenes::LightType::Point: l.kind = Kind::Point; break;
            case scenes::LightType::Spot:
                l.kind = Kind::Spot;
                l.normal = accel::normalize(sl.direction);
                l.cos_inner = sl.spot_cos_inner;
                l.cos_outer = sl.spot_cos_outer;
                break;
            case scenes::LightType::Directional:
                l.kind = Kind::Directional;
                l.normal = accel::normalize(sl.direction);  // direction light travels
                break;
            case scenes::LightType::Environment:
                if (sl.texture != scenes::kNoTexture && sl.texture < scene.textures.size()) {
                    // One image environment; a constant one beside it is folded into neither.
                    env_map_ = EnvironmentMap(scene.textures[sl.texture], scene.up, sl.radiance);
                    if (env_ >= 0) {
                        lights_[size_t(env_)].radiance = Vec3f(0.0f);
                        notes.push_back("an environment image replaces the constant environment");
                        continue;
                    }
                    l.kind = Kind::Environment;
                    env_ = int(lights_.size());
                    break;
                }
                if (env_ >= 0) {
                    lights_[size_t(env_)].radiance += sl.radiance;
                    continue;
                }
                l.kind = Kind::Environment;
                env_ = int(lights_.size());
                break;
        }
        lights_.push_back(l);
    }
    // A default light when nothing would light the scene: no explicit light and no
    // emitter except glow maps (emission textures, as on glTF models: they glow but do
    // not light their surroundings).
    if (scene.lights.empty() && !emissive_surfaces) {
        Light l{};
        l.kind = Kind::Environment;
        l.radiance = Vec3f(1.0f);
        env_ = int(lights_.size());
        lights_.push_back(l);
        bool glow_maps = false;
        for (const scenes::Mesh& m : scene.meshes)
            glow_maps |= m.material < scene.materials.size() && scene.materials[m.material].is_emissive();
        notes.push_back(!glow_maps
                            ? "the scene has no lights: using a constant white environment (radiance 1)"
                            : "the scene has no lights but glow maps: adding a constant white environment "
                              "(radiance 1)");
    }
    build_guard(scene);
}

void LightSet::build_guard(const scenes::Scene& scene) {
    // Only where every emitter a ray can find is a world-space triangle of tris_, few of
    // them, and no environment waits behind a miss; else may_emit_toward says yes.
    if (model_ != LightModel::Mesh || env_ >= 0 || tris_.size() > kGuardTris) return;
    const std::vector<int32_t> owner = scene.mesh_prototypes();
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
        const uint32_t m = scene.meshes[mi].material;
        if (m < scene.materials.size() && scene.materials[m].is_emissive() && (owner[mi] >= 0 || mesh_light_.size() <= mi || mesh_light_[mi] < 0))
            return;
    }
    for (const scenes::Sphere& sp : scene.spheres)
        if (sp.material < scene.materials.size() && scene.materials[sp.material].is_emissive()) return;
    // The ray-independent parts of may_emit_toward's tolerances, once per triangle.
    for (const Tri& t : tris_) {
        const float e1 = accel::length(t.e1), e2 = accel::length(t.e2);
        guard_.push_back({1e-7f * e1 * e2, kGuardSlack * (e1 + e2)});
    }
    guarded_ = true;
}

bool LightSet::may_emit_toward(const accel::Ray& ray) const {
    if (!guarded_) return true;
    // Möller-Trumbore against each emissive triangle, widened: barycentrics within
    // kGuardSlack outside the edges, any t from just behind the origin, and a ray nearly in
    // the triangle's plane counted as a hit, so every ray the backend could find an
    // emitter with says yes.
    const float dir_len = accel::length(ray.dir);
    for (size_t k = 0; k < tris_.size(); ++k) {
        const Tri& t = tris_[k];
        const Vec3f pv = accel::cross(ray.dir, t.e2);
        const float det = accel::dot(t.e1, pv);
        if (!(std::abs(det) > guard_[k].det_floor * dir_len)) return true;
        const float inv = 1.0f / det;
        const Vec3f sv = ray.org - t.v0;
        const float u = accel::dot(sv, pv) * inv;
        if (!(u >= -kGuardSlack && u <= 1.0f + kGuardSlack)) continue;
        const Vec3f qv = accel::cross(sv, t.e1);
        const float v = accel::dot(ray.dir, qv) * inv;
        if (!(v >= -kGuardSlack && u + v <= 1.0f + kGuardSlack)) continue;
        const float tt = accel::dot(t.e2, qv) * inv;
        if (tt >= -(kGuardSlack * accel::length(sv) + guard_[k].t_slack)) return true;
    }
    return false;
}

uint32_t LightSet::pick(const AliasBin* bins, uint32_t n, float u, float* rest) {
    // u's integer part in n bins picks a bin, its fraction the bin's side; the fraction's
    // place within that side is what is left.
    const float x = u * float(n);
    const uint32_t k = std::min(uint32_t(x), n - 1);
    const float f = std::min(x - float(k), 0x1.fffffep-1f), q = bins[k].q;
    const bool own = f < q;
    if (rest) *rest = std::min(own ? f / q : (f - q) / (1.0f - q), 0x1.fffffep-1f);
    return own ? k : bins[k].alias;
}

void LightSet::build_alias_table(const Tri* tris, uint32_t n, std::vector<AliasBin>& out) {
    // Vose (1991): bins under the mean are topped up from one over it, which then joins
    // the small or the large list; in double, so the table's probabilities are the
    // areas' to float precision.
    double total = 0;
    for (uint32_t k = 0; k < n; ++k) total += double(tris[k].area);
    std::vector<double> scaled(n);
    std::vector<uint32_t> small, large;
    for (uint32_t k = 0; k < n; ++k) {
        scaled[k] = double(tris[k].area) * double(n) / total;
        (scaled[k] < 1.0 ? small : large).push_back(k);
    }
    const size_t base = out.size();
    out.resize(base + n, AliasBin{1.0f, 0});
    while (!small.empty() && !large.empty()) {
        const uint32_t s = small.back(), g = large.back();
        small.pop_back();
        out[base + s] = AliasBin{float(scaled[s]), g};
        scaled[g] -= 1.0 - scaled[s];
        if (scaled[g] < 1.0) {
            large.pop_back();
            small.push_back(g);
        }
    }
    // What is left holds 1 up to rounding: it keeps itself.
    for (uint32_t k : small) out[base + k] = AliasBin{1.0f, k};
    for (uint32_t k : large) out[base + k] = AliasBin{1.0f, k};
}

SphericalTriangle LightSet::near_triangle(const Tri& t, const Vec3f& p) {
    const Vec3f d = p - t.centroid;
    if (!(accel::dot(d, d) < t.near2)) return {};
    return SphericalTriangle(p, t.v0, t.v0 + t.e1, t.v0 + t.e2);
}

LightSet::Tri LightSet::placed(const Tri& t, const Placement& place) {
    Tri w = t;
    w.v0 = place.point(t.v0);
    w.e1 = place.vector(t.e1);
    w.e2 = place.vector(t.e2);
    w.n = accel::normalize(place.normal(t.n));  // the emitting side, as the flattened copy's
    w.area = 0.5f * accel::length(accel::cross(w.e1, w.e2));
    w.centroid = place.point(t.centroid);
    float reach2 = 0;
    for (const Vec3f& v : {w.v0, w.v0 + w.e1, w.v0 + w.e2})
        reach2 = std::max(reach2, accel::dot(v - w.centroid, v - w.centroid));
    w.near2 = kNearReach * kNearReach * reach2;
    return w;
}

bool LightSet::sample(size_t i, const Vec3f& p, const Vec3f& n, float choice, Vec2f u2, LightSample& out) const {
    const Light& l = lights_[i];
    out.delta = false;
    out.target_error = Vec3f(0.0f);
    out.normal = Vec3f(0.0f);
    // q is a point of the light computed in float with error bound q_err (pbrt-v4 6.8
    // style: gamma(n) times the sum of the magnitudes added).
    // solid_pdf > 0: the point was drawn by direction with that solid-angle density.
    // area: the light's, whose uniform density is 1 / area. One division per quantity
    // (wi by a reciprocal, the density as one quotient): divisions were a third of this
    // function's time on CBbunny ("light sample divisions" in renderer/README.md).
    auto finite_area = [&](const Vec3f& q, const Vec3f& q_err, const Vec3f& nl, float area, bool two_sided,
                           float solid_pdf = 0.0f) {
        const Vec3f d = q - p;
        const float dist2 = accel::dot(d, d);
        if (!(dist2 > 0)) return false;
        const float dist = std::sqrt(dist2);
        const Vec3f wi = d * (1.0f / dist);
        // The solid-angle pdf needs the cosine with the UNIT direction (course trap).
        float cos_l = -accel::dot(nl, wi);
        if (two_sided) cos_l = std::abs(cos_l);
        if (!(cos_l > 0)) return false;
        out.radiance = l.radiance;
        out.target = q;
        out.target_error = q_err;
        out.normal = nl;
        out.wi = wi;
        out.distance = dist;
        out.pdf = solid_pdf > 0 ? solid_pdf : dist2 / (cos_l * area);
        return std::isfinite(out.pdf) && out.pdf > 0;
    };
    switch (l.kind) {
        case Kind::Rect: {
            const Vec3f du = l.edge_u * (u2.x - 0.5f), dv = l.edge_v * (u2.y - 0.5f);
            const Vec3f q = l.position + du + dv;
            const Vec3f err = (accel::vabs(l.position) + accel::vabs(du) + accel::vabs(dv)) * gamma_bound(5);
            return finite_area(q, err, l.normal, l.area, false);
        }
        case Kind::Mesh: {
            if (l.num_inst) return sample_instanced(l, p, choice, u2, out);
            // The triangle from u2.x, the point from what is left of it and u2.y: a
            // stratified u2 covers the whole light evenly (Cycles reuses its light pick's
            // number the same way), where a separate choice number would hand each
            // triangle a random share of the strata.
            float a = u2.x, b = u2.y;
            const Tri& t = tris_[l.first_tri + pick(pick_.data() + l.first_tri, l.num_tris, u2.x, &a)];
            // Near triangles by solid angle (see solid_angle_sampled), the rest by area.
            float solid_pdf = 0;
            const SphericalTriangle st = near_triangle(t, p);
            if (solid_angle_sampled(st)) {
                // The point of the triangle in that direction: its barycentrics replace (a, b).
                if (!barycentrics_toward(p, st.sample(a, b), t.v0, t.e1, t.e2, a, b)) return false;
                solid_pdf = t.area / (l.area * st.solid_angle());
            } else {
                uniform_triangle(a, b, a, b);
            }
            const Vec3f ea = t.e1 * a, eb = t.e2 * b;
            const Vec3f q = t.v0 + ea + eb;
            // gamma(7) as for a hit point (renderer/interaction.cpp), which also covers the
            // rounding of the stored edges e1 = v1 - v0, e2 = v2 - v0.
            const Vec3f err = (accel::vabs(t.v0) + accel::vabs(ea) + accel::vabs(eb)) * gamma_bound(7);
            if (!finite_area(q, err, t.n, l.area, t.two_sided, solid_pdf)) return false;
            if (l.texture != scenes::kNoTexture &&
                !textured_emission(*scene_, l.texture, scene_->meshes[t.mesh], t.index, a, b, out.radiance))
                return false;
            return true;
        }
        case Kind::Sphere: {
            const Vec3f nl = uniform_sphere(u2.x, u2.y);
            // Two-sided like meshes: a camera inside an emissive sphere sees it too.
            const Vec3f r = nl * l.radius;
            // |nl| is 1 only to a few ulps (sqrt, sin, cos): gamma(9) on the radius.
            const Vec3f err = accel::vabs(l.position) * gamma_bound(1) + accel::vabs(r) * gamma_bound(9);
            return finite_area(l.position + r, err, nl, l.area, true);
        }
        case Kind::Point:
        case Kind::Spot: {
            const Vec3f d = l.position - p;
            const float dist2 = accel::dot(d, d);
            if (!(dist2 > 0)) return false;
            out.distance = std::sqrt(dist2);
            out.wi = d / out.distance;
            out.target = l.position;
            // Intensity I (W/sr) gives irradiance I/r^2; as a "radiance" with pdf 1.
            float falloff = 1.0f;
            if (l.kind == Kind::Spot) {
                const float c = accel::dot(-out.wi, l.normal);
                if (c <= l.cos_outer) return false;
                if (c < l.cos_inner) {
                    const float t = (c - l.cos_outer) / std::max(l.cos_inner - l.cos_outer, 1e-6f);
                    falloff = t * t * (3.0f - 2.0f * t);
                }
            }
            out.radiance = l.radiance * (falloff / dist2);
            out.pdf = 1.0f;
            out.delta = true;
            return true;
        }
        case Kind::Directional:
            out.wi = -l.normal;
            out.distance = accel::kInfinity;
            out.radiance = l.radiance;
            out.pdf = 1.0f;
            out.delta = true;
            return true;
        case Kind::Environment: {
            out.distance = accel::kInfinity;
            if (!env_map_.empty())
                return env_map_.sample(u2.x, u2.y, out.wi, out.pdf, out.radiance);
            const Vec3f local = cosine_hemisphere(u2.x, u2.y);
            out.wi = to_world(local, n);
            out.distance = accel::kInfinity;
            out.radiance = l.radiance;
            out.pdf = local.z * accel::kInvPi;
            return out.pdf > 0;
        }
    }
    return false;
}

bool LightSet::sample_instanced(const Light& l, const Vec3f& p, float choice, Vec2f u2, LightSample& out) const {
    // A placement by power, then, with the choice number remapped into its cdf interval
    // (pbrt-v4's SampleDiscrete and its uRemapped), a triangle of the prototype mesh by
    // its object-space area (the cdf every placement shares), then a point of it placed
    // in world space. The density is P(placement) P(triangle) over the placed triangle's
    // world area, or over its world solid angle where it is near: exactly what sampling
    // the placed triangle on its own would give, times the two discrete probabilities.
    const float* icdf = inst_cdf_.data() + l.first_inst;
    const uint32_t j = std::min<uint32_t>(uint32_t(std::upper_bound(icdf, icdf + l.num_inst, choice) - icdf),
                                          l.num_inst - 1);
    const float p_inst = instance_pmf(l, j);
    if (!(p_inst > 0)) return false;
    const float lo = j ? icdf[j - 1] : 0.0f;
    const float u = std::min((choice - lo) / p_inst, 0x1.fffffep-1f);
    const Tri& t = tris_[l.first_tri + pick(pick_.data() + l.first_tri, l.num_tris, u)];
    const Placement place(scene_->instances[inst_ids_[l.first_inst + j]].object_to_world);
    const Tri w = placed(t, place);
    const float p_tri = p_inst * t.area / l.area;  // P(placement) P(triangle)
    float a = u2.x, b = u2.y;
    float solid_pdf = 0;
    const SphericalTriangle st = near_triangle(w, p);
    if (solid_angle_sampled(st)) {
        if (!barycentrics_toward(p, st.sample(a, b), w.v0, w.e1, w.e2, a, b)) return false;
        solid_pdf = p_tri / st.solid_angle();
    } else {
        uniform_triangle(a, b, a, b);
    }
    // The point in object space (the bound of a world-space emitter's point), then
    // placed with the transform's own rounding added (Placement::point, pbrt-v4 6.8.6).
    const Vec3f ea = t.e1 * a, eb = t.e2 * b;
    const Vec3f err_obj = (accel::vabs(t.v0) + accel::vabs(ea) + accel::vabs(eb)) * gamma_bound(7);
    Vec3f q, q_err;
    place.point(t.v0 + ea + eb, err_obj, q, q_err);
    const Vec3f d = q - p;
    const float dist2 = accel::dot(d, d);
    if (!(dist2 > 0)) return false;
    const float dist = std::sqrt(dist2);
    const Vec3f wi = d * (1.0f / dist);
    float cos_l = -accel::dot(w.n, wi);
    if (t.two_sided) cos_l = std::abs(cos_l);
    if (!(cos_l > 0)) return false;
    out.radiance = l.radiance;
    out.target = q;
    out.target_error = q_err;
    out.normal = w.n;
    out.wi = wi;
    out.distance = dist;
    out.pdf = solid_pdf > 0 ? solid_pdf : p_tri / w.area * dist2 / cos_l;
    if (!(std::isfinite(out.pdf) && out.pdf > 0)) return false;
    if (l.texture != scenes::kNoTexture &&
        !textured_emission(*scene_, l.texture, scene_->meshes[t.mesh], t.index, a, b, out.radiance))
        return false;
    return true;
}

float LightSet::pdf(size_t i, const Vec3f& p, const Vec3f& n, const Vec3f& wi, float dist, const Vec3f& nq,
                   uint32_t prim, uint32_t inst) const {
    const Light& l = lights_[i];
    switch (l.kind) {
        case Kind::Mesh: {
            // The triangle hit, by its index in the mesh (a degenerate one, which no ray
            // hits, has none).
            if (prim >= l.num_prims) return 0.0f;
            const uint32_t k = tri_of_prim_[l.first_prim + prim];
            if (k == kNoTri) return 0.0f;
            const Tri* it = &tris_[l.first_tri + k];
            if (l.num_inst) {
                // sample_instanced's density: the placement found by its id (ascending).
                const uint32_t* ids = inst_ids_.data() + l.first_inst;
                const uint32_t* f = std::lower_bound(ids, ids + l.num_inst, inst);
                if (f == ids + l.num_inst || *f != inst) return 0.0f;
                const float p_tri = instance_pmf(l, uint32_t(f - ids)) * it->area / l.area;
                const Tri w = placed(*it, Placement(scene_->instances[inst].object_to_world));
                const SphericalTriangle st = near_triangle(w, p);
                if (solid_angle_sampled(st)) return p_tri / st.solid_angle();
                const float cos_l = std::abs(accel::dot(nq, wi));
                return cos_l > 0 ? p_tri * dist * dist / (cos_l * w.area) : 0.0f;
            }
            const SphericalTriangle st = near_triangle(*it, p);
            if (solid_angle_sampled(st)) return it->area / (l.area * st.solid_angle());
            const float cos_l = std::abs(accel::dot(nq, wi));
            return cos_l > 0 ? dist * dist / (cos_l * l.area) : 0.0f;
        }
        case Kind::Sphere: {
            // Area sampling: 1/area over the light, converted to solid angle.
            const float cos_l = std::abs(accel::dot(nq, wi));
            return cos_l > 0 ? dist * dist / (cos_l * l.area) : 0.0f;
        }
        case Kind::Environment: {
            if (!env_map_.empty()) return env_map_.pdf(wi);
            const float c = accel::dot(n, wi);
            return c > 0 ? c * accel::kInvPi : 0.0f;
        }
        default: return 0.0f;
    }
}

std::string LightSet::summary() const {
    size_t counts[7] = {};
    for (const Light& l : lights_) ++counts[size_t(l.kind)];
    size_t instanced = 0;
    for (const Light& l : lights_) instanced += l.num_inst > 0;
    // Instanced emitters: how many of the emissive meshes are prototype meshes, and how
    // many placements of them are sampled (only when there are any, so a flat scene's
    // line is as it was).
    const std::string placed =
        instanced ? fmt::format(", {} of them instanced in {} placements", instanced, inst_ids_.size()) : "";
    return fmt::format("[PathTracer] Lights sampled: {} area rectangles, {} emissive meshes ({} triangles{}), "
                       "{} emissive spheres, {} point, {} spot, {} directional, {} environment",
                       counts[0], counts[1], tris_.size(), placed, counts[2], counts[3], counts[4], counts[5],
                       counts[6]);
}

}  // namespace renderer
