#include "renderer/scene_geometry.h"

#include <fmt/format.h>

#include <chrono>
#include <cstdio>

namespace renderer {

SceneGeometry::SceneGeometry(const scenes::Scene& scene) : scene_(scene) {
    for (uint32_t i = 0; i < scene.meshes.size(); ++i) {
        const scenes::Mesh& m = scene.meshes[i];
        views_.push_back(accel::GeometryView::triangles(m.positions.data(), m.num_vertices(), m.indices.data(),
                                                        m.num_triangles()));
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
    if (verbose) {
        std::fprintf(stderr, "[PathTracer] Building BVH from %llu primitives... ",
                     (unsigned long long)prims);
        std::fflush(stderr);
    }
    auto start = std::chrono::steady_clock::now();
    auto accel = accel::create_accelerator(backend, geometry.views(), options);
    double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (verbose) {
        std::fprintf(stderr, "Done! (%.4f sec)\n", secs);
        const accel::BuildInfo& info = accel->info();
        std::string extra;
        if (info.nodes) extra += fmt::format(", {} nodes, depth {}", info.nodes, info.depth);
        if (info.sah_cost > 0) extra += fmt::format(", SAH cost {:.2f}", info.sah_cost);
        std::fprintf(stderr, "[PathTracer] Accelerator %s: %llu primitives (%llu degenerate dropped)%s, %.2f MiB\n",
                     info.backend.c_str(), (unsigned long long)info.primitives,
                     (unsigned long long)info.dropped, extra.c_str(),
                     double(info.bytes) / (1024.0 * 1024.0));
    }
    return accel;
}

}  // namespace renderer
