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

void triangle_point(const Vec3f& p0, const Vec3f& p1, const Vec3f& p2, float u, float v, Vec3f& p,
                    Vec3f& p_error) {
    const float b0 = 1.0f - u - v;
    const Vec3f a = p0 * b0, b = p1 * u, c = p2 * v;
    p = a + b + c;
    p_error = (accel::vabs(a) + accel::vabs(b) + accel::vabs(c)) * gamma_bound(7);
}

void sphere_point(const Vec3f& c, float r, const Vec3f& p_hit, Vec3f& p, Vec3f& p_error) {
    Vec3f q = p_hit - c;  // object space (sphere at the origin)
    const float len = accel::length(q);
    if (len > 0.0f && std::isfinite(len)) q = q * (r / len);
    p = c + q;
    p_error = accel::vabs(q) * gamma_bound(5) + (accel::vabs(c) + accel::vabs(q)) * gamma_bound(1);
}

Interaction make_interaction(const scenes::Scene& scene, const SceneGeometry& geometry,
                             const accel::Ray& ray, const accel::Hit& hit) {
    Interaction it;
    it.t = hit.t;
    it.p = ray.org + ray.dir * hit.t;
    it.ng = accel::normalize(hit.ng);
    it.ns = it.ng;
    it.material = geometry.material(hit.geom_id, hit.prim_id);
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
            float len = accel::length(n);
            if (len > 0.0f && std::isfinite(len)) it.ns = n / len;
        }
        if (!m.uvs.empty()) {
            const Vec2f a = m.uvs[idx[0]], b = m.uvs[idx[1]], c = m.uvs[idx[2]];
            it.uv = {a.x * w0 + b.x * hit.u + c.x * hit.v, a.y * w0 + b.y * hit.u + c.y * hit.v};
            if (it.material < scene.materials.size() && is_textured(scene.materials[it.material])) {
                // pbrt-v4 Triangle::InteractionFromIntersection: solve the 2x2 system of
                // edge vectors against uv differences.
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
    }
    return it;
}

}  // namespace renderer
