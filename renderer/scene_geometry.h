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

/// What the hit filter of one masked mesh reads: its material's alpha mode, the base
/// alpha factor and cutoff, and the base colour texture when it stores alpha.
struct AlphaTest {
    scenes::AlphaMode mode = scenes::AlphaMode::Opaque;
    float factor = 1.0f;  ///< Material::base_alpha
    float cutoff = 0.5f;  ///< Material::alpha_cutoff (Mask)
    const scenes::Texture* texture = nullptr;  ///< null: alpha is `factor` alone
    const scenes::Mesh* mesh = nullptr;
};

/// The surface's alpha at barycentrics (u, v) of triangle `prim`: factor times the
/// texture's alpha at the interpolated uv, read from level 0, times the interpolated
/// vertex alpha (COLOR_0's) where the mesh has one. Level 0, because a shadow or bounce
/// ray has no footprint, and every ray must see the same cut-out (camera rays and the
/// shadow rays that test the same leaves); bilinear, so that the alpha >= cutoff contour
/// is the smooth curve glTF viewers draw with a LINEAR magnification filter rather than a
/// staircase of texels, except for a NEAREST sampler's texture, whose viewers draw the
/// staircase (lookup_alpha).
float surface_alpha(const AlphaTest& a, uint32_t prim, float u, float v);

/// The uniform number in [0, 1) that decides a BLEND hit: a hash of the ray's origin and
/// direction bits, the geometry and the primitive, and the instance for a hit inside one. pbrt-v4 does the same for its
/// stochastic alpha test (GeometricPrimitive::Intersect: HashFloat(r.o, r.d)); the ray is
/// a function of its pixel sample's own stream, so the number is too, and a render is
/// bit-identical whatever the thread count or tile split, on every backend, without a
/// seed in accel::Ray (whose 32 bytes the plugin ABI shares). The geometry and primitive
/// are hashed in as well, unlike pbrt-v4, so that two blended layers on one ray decide
/// independently (with the ray alone, two layers of alpha 0.5 would both be kept or both
/// dropped, 1/2 and 1/2 instead of 1/4 and 3/4). For the same reason the instance is
/// hashed in too (`inst_id`, kInvalidId for world-space geometry, which is left out of
/// the hash so that flat scenes draw the very numbers they did before instancing): two
/// placements of one leaf on one ray are two layers. `ray` is the world ray (the one the
/// backend hands the filter), so an instance decides as its flattened copy would.
float blend_uniform(const accel::Ray& ray, uint32_t geom_id, uint32_t prim_id,
                    uint32_t inst_id = accel::kInvalidId);

/// accel::HitFilter of masked meshes (user = const AlphaTest*): Mask keeps a hit where
/// alpha >= cutoff (glTF 2.0, 3.9.4); Blend keeps it with probability alpha, deciding by
/// blend_uniform < alpha.
bool alpha_filter(const void* user, uint32_t geom_id, uint32_t prim_id, uint32_t inst_id, float u, float v,
                  const accel::Ray& ray);

/// Geometry views over a scene (no copies of triangles), plus the packed sphere array.
/// Geometry ids: one per mesh in scene order, then one for all spheres if any.
/// Instances: one accel::PrototypeView per scenes::Prototype, naming the same range of
/// geometry ids as its meshes (geometry id = mesh index), and the scene's instances passed
/// through without a copy (scenes::Instance is accel::InstanceView); a prototype's views
/// stay in object space, as its meshes are.
/// Meshes whose material masks (Mask, Blend) get alpha_filter on their views, unless
/// their alpha cannot fall below what is kept (no texture alpha and a factor at or above
/// the cutoff, or 1 for Blend): those stay opaque, and so cost nothing.
class SceneGeometry {
public:
    explicit SceneGeometry(const scenes::Scene& scene);
    SceneGeometry(const SceneGeometry&) = delete;  // the views point into this object
    SceneGeometry& operator=(const SceneGeometry&) = delete;

    const std::vector<accel::GeometryView>& views() const { return views_; }
    /// What create_accelerator traces besides the world-space views: empty for a flat
    /// scene. Points into this object and the scene.
    accel::InstanceSet instances() const { return {prototypes_, scene_.instances}; }
    const GeomSource& source(uint32_t geom_id) const { return sources_[geom_id]; }
    /// Material index of the primitive a hit refers to.
    uint32_t material(uint32_t geom_id, uint32_t prim_id) const;

private:
    const scenes::Scene& scene_;
    std::vector<float> spheres_;  // xyzr
    std::vector<accel::GeometryView> views_;
    std::vector<GeomSource> sources_;
    std::vector<accel::PrototypeView> prototypes_;  ///< one per scene prototype
    std::vector<AlphaTest> alpha_;  ///< one per mesh; views' filter_user point here
};

/// Builds the named backend over the scene's views and instances (geometry.instances():
/// the caller flattens beforehand if it wants a flat build, e.g. for a backend that
/// traces no instances, accel::backend_traces_instances), printing the course's build
/// line on stderr.
std::unique_ptr<accel::Accelerator> build_accelerator(const std::string& backend,
                                                      const SceneGeometry& geometry,
                                                      const accel::AccelOptions& options,
                                                      bool verbose = true);

}  // namespace renderer
