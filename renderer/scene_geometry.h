// The bridge from plain scene data to the accelerator's geometry views.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "accel/accelerator.h"
#include "scenes/scene.h"

namespace renderer {

/// What a hit's geom_id refers to in the scene.
struct GeomSource {
    enum Kind : uint8_t { Mesh, Spheres } kind;
    uint32_t mesh = 0;  ///< scene.meshes index when kind == Mesh
};

/// Geometry views over a scene (no copies of triangles), plus the packed sphere array.
/// Geometry ids: one per mesh in scene order, then one for all spheres if any.
class SceneGeometry {
public:
    explicit SceneGeometry(const scenes::Scene& scene);

    const std::vector<accel::GeometryView>& views() const { return views_; }
    const GeomSource& source(uint32_t geom_id) const { return sources_[geom_id]; }
    /// Material index of the primitive a hit refers to.
    uint32_t material(uint32_t geom_id, uint32_t prim_id) const;

private:
    const scenes::Scene& scene_;
    std::vector<float> spheres_;  // xyzr
    std::vector<accel::GeometryView> views_;
    std::vector<GeomSource> sources_;
};

/// Builds the named backend over the scene, printing the course's build line on stderr.
std::unique_ptr<accel::Accelerator> build_accelerator(const std::string& backend,
                                                      const SceneGeometry& geometry,
                                                      const accel::AccelOptions& options,
                                                      bool verbose = true);

}  // namespace renderer
