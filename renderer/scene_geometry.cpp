#include "renderer/scene_geometry.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <cstring>

#include "renderer/texture.h"

namespace renderer {

float surface_alpha(const AlphaTest& a, uint32_t prim, float u, float v) {
    const scenes::Mesh& m = *a.mesh;
    float vertex = 1.0f;
    if (!m.alphas.empty()) {
        const uint32_t* idx = &m.indices[3 * size_t(prim)];
        vertex = m.alphas[idx[0]] * (1.0f - u - v) + m.alphas[idx[1]] * u + m.alphas[idx[2]] * v;
    }
    if (!a.texture) return a.factor * vertex;
    // The uv of make_interaction (interaction.cpp), by the same arithmetic.
    Vec2f uv{0.0f, 0.0f};
    if (!m.uvs.empty()) {
        const uint32_t* idx = &m.indices[3 * size_t(prim)];
        const Vec2f p = m.uvs[idx[0]], q = m.uvs[idx[1]], r = m.uvs[idx[2]];
        const float w0 = 1.0f - u - v;
        uv = {p.x * w0 + q.x * u + r.x * v, p.y * w0 + q.y * u + r.y * v};
    }
    return a.factor * lookup_alpha(*a.texture, uv) * vertex;
}

namespace {
/// SplitMix64's finaliser (Steele, Lea, Flood 2014), one word at a time.
inline uint64_t mix(uint64_t h, uint32_t w) {
    uint64_t x = (h ^ w) + 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}
inline uint32_t bits(float f) {
    uint32_t b;
    std::memcpy(&b, &f, 4);
    return b;
}
}  // namespace

float blend_uniform(const accel::Ray& ray, uint32_t geom_id, uint32_t prim_id, uint32_t inst_id) {
    uint64_t h = 0;
    for (int a = 0; a < 3; ++a) h = mix(h, bits(ray.org[a]));
    for (int a = 0; a < 3; ++a) h = mix(h, bits(ray.dir[a]));
    h = mix(mix(h, geom_id), prim_id);
    // Only for instanced hits: world-space geometry keeps the numbers it had before.
    if (inst_id != accel::kInvalidId) h = mix(h, inst_id);
    return float(h >> 40) * 0x1p-24f;  // 24 bits: exactly representable, < 1
}

bool alpha_filter(const void* user, uint32_t geom_id, uint32_t prim_id, uint32_t inst_id, float u, float v,
                  const accel::Ray& ray) {
    const AlphaTest& a = *static_cast<const AlphaTest*>(user);
    const float alpha = surface_alpha(a, prim_id, u, v);
    if (a.mode == scenes::AlphaMode::Mask) return alpha >= a.cutoff;
    if (alpha >= 1.0f) return true;
    if (!(alpha > 0.0f)) return false;
    return blend_uniform(ray, geom_id, prim_id, inst_id) < alpha;
}

SceneGeometry::SceneGeometry(const scenes::Scene& scene) : scene_(scene) {
    alpha_.resize(scene.meshes.size());  // never resized again: views point into it
    for (uint32_t i = 0; i < scene.meshes.size(); ++i) {
        const scenes::Mesh& m = scene.meshes[i];
        accel::GeometryView view =
            accel::GeometryView::triangles(m.positions.data(), m.num_vertices(), m.indices.data(), m.num_triangles());
        if (m.material < scene.materials.size()) {
            const scenes::Material& mat = scene.materials[m.material];
            AlphaTest& a = alpha_[i];
            a.mode = mat.alpha_mode;
            a.factor = mat.base_alpha;
            a.cutoff = mat.alpha_cutoff;
            a.mesh = &m;
            // A texture without stored alpha reads 1 everywhere (the loaders keep alpha
            // only where some texel is not opaque), so the factor alone decides.
            if (mat.albedo_texture < scene.textures.size() && scene.textures[mat.albedo_texture].slot[3] >= 0)
                a.texture = &scene.textures[mat.albedo_texture];
            // Vertex alpha (scenes::Mesh::alphas) is stored only where some vertex is below 1.
            const bool varies = a.texture || !m.alphas.empty();
            const bool cuts = a.mode == scenes::AlphaMode::Mask    ? varies || a.factor < a.cutoff
                              : a.mode == scenes::AlphaMode::Blend ? varies || a.factor < 1.0f
                                                                   : false;
            if (cuts) view.filter = alpha_filter, view.filter_user = &a;
        }
        views_.push_back(view);
        sources_.push_back({GeomSource::Mesh, i});
    }
    if (!scene.spheres.empty()) {
        spheres_.reserve(scene.spheres.size() * 4);
        for (const scenes::Sphere& s : scene.spheres) {
            spheres_.insert(spheres_.end(), {s.center.x, s.center.y, s.center.z, s.radius});
        }
        views_.push_back(accel::GeometryView::sphere_list(spheres_.data(), uint32_t(scene.spheres.size())));
        sources_.push_back({GeomSource::Spheres, 0});
    }
    // Geometry ids are mesh indices, so a prototype's mesh range is its geometry range.
    prototypes_.reserve(scene.prototypes.size());
    for (const scenes::Prototype& p : scene.prototypes) prototypes_.push_back({p.first_mesh, p.num_meshes});
}

uint32_t SceneGeometry::material(uint32_t geom_id, uint32_t prim_id) const {
    const GeomSource& s = sources_[geom_id];
    return s.kind == GeomSource::Mesh ? scene_.meshes[s.mesh].material
                                      : scene_.spheres[prim_id].material;
}

std::unique_ptr<accel::Accelerator> build_accelerator(const std::string& backend,
                                                      const SceneGeometry& geometry,
                                                      const accel::AccelOptions& options,
                                                      bool verbose) {
    uint64_t prims = 0;
    for (const accel::GeometryView& v : geometry.views()) prims += v.num_prims;
    const accel::InstanceSet inst = geometry.instances();
    if (verbose) {
        // The course's line; with instances, the primitives are the unique ones (world
        // space and prototypes') and the line adds what the instances place.
        std::string placed;
        if (!inst.instances.empty()) {
            std::vector<uint64_t> per(inst.prototypes.size(), 0);
            for (size_t p = 0; p < inst.prototypes.size(); ++p)
                for (uint32_t g = 0; g < inst.prototypes[p].num_geoms; ++g)
                    per[p] += geometry.views()[inst.prototypes[p].first_geom + g].num_prims;
            uint64_t instanced = 0;
            for (const accel::InstanceView& i : inst.instances) instanced += per[i.prototype];
            placed = fmt::format(" and {} instances ({} instanced triangles)", inst.instances.size(), instanced);
        }
        std::fprintf(stderr, "[PathTracer] Building BVH from %llu primitives%s... ", (unsigned long long)prims,
                     placed.c_str());
        std::fflush(stderr);
    }
    auto start = std::chrono::steady_clock::now();
    auto accel = accel::create_accelerator(backend, geometry.views(), options, inst);
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (verbose) {
        std::fprintf(stderr, "Done! (%.4f sec)\n", secs);
        const accel::BuildInfo& info = accel->info();
        std::string extra;
        if (info.nodes) extra += fmt::format(", {} nodes, depth {}", info.nodes, info.depth);
        if (info.sah_cost > 0) extra += fmt::format(", SAH cost {:.2f}", info.sah_cost);
        if (info.instances)
            extra += fmt::format(", {} instances placing {} instanced primitives", info.instances,
                                 info.instanced_primitives);
        std::fprintf(stderr, "[PathTracer] Accelerator %s: %llu primitives (%llu degenerate dropped)%s, %.2f MiB\n",
                     info.backend.c_str(), (unsigned long long)info.primitives,
                     (unsigned long long)info.dropped, extra.c_str(),
                     double(info.bytes) / (1024.0 * 1024.0));
    }
    return accel;
}

}  // namespace renderer
