#include "renderer/interaction.h"

#include <algorithm>
#include <cmath>

#include "renderer/spawn.h"

namespace renderer {

Vec3f texel(const scenes::Scene& scene, uint32_t texture, const Vec2f& uv) {
    if (texture == scenes::kNoTexture || texture >= scene.textures.size()) return Vec3f(1.0f);
    return lookup(scene.textures[texture], uv, kNoFootprint, TextureFilter::Nearest).rgb();
}

Texel4 texel4(const scenes::Scene& scene, uint32_t texture, const Interaction& it) {
    if (texture == scenes::kNoTexture || texture >= scene.textures.size()) return Texel4{1.0f, 1.0f, 1.0f, 1.0f};
    return lookup(scene.textures[texture], it.uv, it.lod, it.filter);
}

void set_texture_footprint(Interaction& it, const PixelSpread& spread, TextureFilter filter, bool camera_ray,
                           const Vec3f& dir) {
    it.filter = filter;
    if (!is_mip_filter(filter) || !spread.valid()) return;
    Vec3f dpdx, dpdy;
    if (camera_ray)
        camera_dpdxy(spread, dir, it.p, it.ng, dpdx, dpdy);
    else
        approximate_dpdxy(spread, it.p, it.ng, dpdx, dpdy);
    it.lod = uv_lod(uv_footprint(it.dpdu, it.dpdv, dpdx, dpdy));
}

void sphere_point(const Vec3f& c, float r, const Vec3f& p_hit, Vec3f& p, Vec3f& p_error) {
    Vec3f q = p_hit - c;  // object space (sphere at the origin)
    const float len = accel::length(q);
    if (len > 0.0f && std::isfinite(len)) q = q * (r / len);
    p = c + q;
    p_error = accel::vabs(q) * gamma_bound(5) + (accel::vabs(c) + accel::vabs(q)) * gamma_bound(1);
}

Placement::Placement(const accel::Affine3f& object_to_world) : m(object_to_world) {
    const Vec3f c0(m.m[0][0], m.m[1][0], m.m[2][0]), c1(m.m[0][1], m.m[1][1], m.m[2][1]),
        c2(m.m[0][2], m.m[1][2], m.m[2][2]);
    mirrors = m.det() < 0.0;
    const float s = mirrors ? -1.0f : 1.0f;
    n0 = accel::cross(c1, c2) * s;
    n1 = accel::cross(c2, c0) * s;
    n2 = accel::cross(c0, c1) * s;
}

void Placement::point(const Vec3f& p, const Vec3f& p_err, Vec3f& out, Vec3f& out_err) const {
    out = m.point(p);
    const float g3 = gamma_bound(3);
    for (int r = 0; r < 3; ++r) {
        const float* row = m.m[r];
        const float mag = std::abs(row[0] * p.x) + std::abs(row[1] * p.y) + std::abs(row[2] * p.z) + std::abs(row[3]);
        const float carried = std::abs(row[0]) * p_err.x + std::abs(row[1]) * p_err.y + std::abs(row[2]) * p_err.z;
        out_err[r] = g3 * mag + (g3 + 1.0f) * carried;
    }
}

namespace {

/// The hit's texture coordinates and vertex colour, interpolated from the mesh's, and
/// for textured materials the triangle's dp/du and dp/dv from the mesh's own positions
/// (pbrt-v4 Triangle::InteractionFromIntersection: the 2x2 system of edge vectors against
/// uv differences). An instance's are those of its prototype's triangle, carried by L.
inline void mesh_uv(const scenes::Scene& scene, const scenes::Mesh& m, const uint32_t* idx, float u, float v,
                    Interaction& it) {
    const float w0 = 1.0f - u - v;
    if (!m.colors.empty()) [[unlikely]]
        it.color = m.colors[idx[0]] * w0 + m.colors[idx[1]] * u + m.colors[idx[2]] * v;
    if (m.uvs.empty()) return;
    const Vec2f a = m.uvs[idx[0]], b = m.uvs[idx[1]], c = m.uvs[idx[2]];
    it.uv = {a.x * w0 + b.x * u + c.x * v, a.y * w0 + b.y * u + c.y * v};
    if (it.material < scene.materials.size() && is_textured(scene.materials[it.material])) {
        const Vec3f e1 = m.positions[idx[1]] - m.positions[idx[0]];
        const Vec3f e2 = m.positions[idx[2]] - m.positions[idx[0]];
        const float du1 = b.x - a.x, dv1 = b.y - a.y, du2 = c.x - a.x, dv2 = c.y - a.y;
        const float det = du1 * dv2 - dv1 * du2;
        if (std::abs(det) > 1e-12f) {
            it.dpdu = (e1 * dv2 - e2 * dv1) / det;
            it.dpdv = (e2 * du1 - e1 * du2) / det;
        }
    }
}

/// make_interaction for a triangle of a prototype mesh hit through instance
/// hit.inst_id: the surface quantities of the object-space triangle (the same
/// arithmetic as a world-space one), then carried to world space. Its own function, so
/// that the world-space path below keeps its arithmetic exactly.
void instanced_triangle(const scenes::Scene& scene, const scenes::Mesh& m, const accel::Hit& hit,
                        Interaction& it) {
    const Placement place(scene.instances[hit.inst_id].object_to_world);
    const uint32_t* idx = &m.indices[3 * size_t(hit.prim_id)];
    Vec3f p_obj, e_obj;
    triangle_point(m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]], hit.u, hit.v, p_obj, e_obj);
    place.point(p_obj, e_obj, it.p, it.p_error);
    // Hit::ng of an instance is cof(L) n_obj: the mirrored placement's is reversed
    // against its flattened copy (whose winding was swapped), so it is turned back.
    it.ng = accel::normalize(hit.ng);
    if (place.mirrors) it.ng = -it.ng;
    it.ns = it.ng;
    const float w0 = 1.0f - hit.u - hit.v;
    if (!m.normals.empty()) {
        // Each vertex normal placed and renormalised, then interpolated: the normals the
        // flattened copy stores (scenes::flatten_instances), so that a placement shades as
        // its copy does. Under a non-uniform scale, placing the interpolated normal instead
        // would weigh the vertices differently (pbrt-v4 transforms the interpolated one).
        Vec3f nv[3];
        for (int k = 0; k < 3; ++k) {
            const Vec3f w = place.normal(m.normals[idx[k]]);
            const float len = accel::length(w);
            nv[k] = len > 0.0f ? w / len : m.normals[idx[k]];
        }
        const Vec3f n = nv[0] * w0 + nv[1] * hit.u + nv[2] * hit.v;
        const float len = accel::length(n);
        if (len > 0.0f && std::isfinite(len)) it.ns = n / len;
    }
    // Texture coordinates are the mesh's own, shared by every placement; dp/du of the
    // placed surface is L times the object's (the chain rule; the translation drops out).
    mesh_uv(scene, m, idx, hit.u, hit.v, it);
    it.dpdu = place.vector(it.dpdu);
    it.dpdv = place.vector(it.dpdv);
}

}  // namespace

void make_interaction(const scenes::Scene& scene, const SceneGeometry& geometry, const accel::Ray& ray,
                      const accel::Hit& hit, Interaction& it) {
    // Every field is written: those a hit may leave at their defaults first.
    it.uv = Vec2f{};
    it.color = Vec3f(1.0f);
    it.dpdu = it.dpdv = Vec3f(0.0f);
    it.lod = kNoFootprint;
    it.filter = TextureFilter::Nearest;
    it.t = hit.t;
    it.material = geometry.material(hit.geom_id, hit.prim_id);
    if (hit.inst_id != accel::kInvalidId) {
        // Prototypes hold meshes only (scenes::Prototype), never spheres.
        it.sphere = false;
        instanced_triangle(scene, scene.meshes[geometry.source(hit.geom_id).mesh], hit, it);
        return;
    }
    it.p = ray.org + ray.dir * hit.t;
    it.p_error = Vec3f(0.0f);
    it.ng = accel::normalize(hit.ng);
    it.ns = it.ng;
    const GeomSource& src = geometry.source(hit.geom_id);
    it.sphere = src.kind == GeomSource::Spheres;
    if (it.sphere) {
        const accel::GeometryView& g = geometry.views()[hit.geom_id];
        const float* s = g.spheres + 4 * size_t(hit.prim_id);
        sphere_point(Vec3f(s[0], s[1], s[2]), s[3], it.p, it.p, it.p_error);
    }
    if (src.kind == GeomSource::Mesh) {
        const scenes::Mesh& m = scene.meshes[src.mesh];
        const uint32_t* idx = &m.indices[3 * size_t(hit.prim_id)];
        triangle_point(m.positions[idx[0]], m.positions[idx[1]], m.positions[idx[2]], hit.u, hit.v, it.p,
                       it.p_error);
        const float w0 = 1.0f - hit.u - hit.v;
        if (!m.normals.empty()) {
            Vec3f n = m.normals[idx[0]] * w0 + m.normals[idx[1]] * hit.u + m.normals[idx[2]] * hit.v;
            // By the reciprocal: one division instead of three, on every hit.
            const float len = accel::length(n), inv = 1.0f / len;
            if (len > 0.0f && std::isfinite(len) && std::isfinite(inv)) it.ns = n * inv;
        }
        mesh_uv(scene, m, idx, hit.u, hit.v, it);
    }
}

Interaction make_interaction(const scenes::Scene& scene, const SceneGeometry& geometry,
                             const accel::Ray& ray, const accel::Hit& hit) {
    Interaction it;
    make_interaction(scene, geometry, ray, hit, it);
    return it;
}

}  // namespace renderer
