#include "renderer/interaction.h"

namespace renderer {

Interaction make_interaction(const scenes::Scene& scene, const SceneGeometry& geometry,
                             const accel::Ray& ray, const accel::Hit& hit) {
    Interaction it;
    it.t = hit.t;
    it.p = ray.org + ray.dir * hit.t;
    it.ng = accel::normalize(hit.ng);
    it.ns = it.ng;
    it.material = geometry.material(hit.geom_id, hit.prim_id);
    const GeomSource& src = geometry.source(hit.geom_id);
    if (src.kind == GeomSource::Mesh) {
        const scenes::Mesh& m = scene.meshes[src.mesh];
        const uint32_t* idx = &m.indices[3 * size_t(hit.prim_id)];
        const float w0 = 1.0f - hit.u - hit.v;
        if (!m.normals.empty()) {
            Vec3f n = m.normals[idx[0]] * w0 + m.normals[idx[1]] * hit.u + m.normals[idx[2]] * hit.v;
            float len = accel::length(n);
            if (len > 0.0f && std::isfinite(len)) it.ns = n / len;
        }
        if (!m.uvs.empty()) {
            const Vec2f a = m.uvs[idx[0]], b = m.uvs[idx[1]], c = m.uvs[idx[2]];
            it.uv = {a.x * w0 + b.x * hit.u + c.x * hit.v, a.y * w0 + b.y * hit.u + c.y * hit.v};
        }
    }
    return it;
}

}  // namespace renderer
