// Reproducible sets of rays of the kinds a renderer traces, generated once per scene so
// that every backend traces the very same rays (cross-checks and benchmarks).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "accel/accelerator.h"
#include "renderer/camera.h"
#include "renderer/ray_record.h"
#include "scenes/scene.h"

namespace renderer {

/// RenderClosest and RenderShadow are a render's own rays, read from a ray record
/// (renderer/ray_record.h) rather than generated; they are not among kAllRayKinds.
enum class RayKind : uint8_t { Camera, Random, EdgeVertex, Grazing, Shadow, Diffuse, RenderClosest, RenderShadow };
inline constexpr RayKind kAllRayKinds[] = {RayKind::Camera,  RayKind::Random, RayKind::EdgeVertex,
                                           RayKind::Grazing, RayKind::Shadow, RayKind::Diffuse};
inline constexpr RayKind kRecordedRayKinds[] = {RayKind::RenderClosest, RayKind::RenderShadow};
const char* ray_kind_name(RayKind kind);
bool parse_ray_kind(const std::string& name, RayKind& kind);

struct RaySet {
    RayKind kind = RayKind::Camera;
    std::vector<accel::Ray> rays;
    /// Shadow rays are any-hit queries (occluded); all others closest-hit.
    bool occlusion() const { return kind == RayKind::Shadow || kind == RayKind::RenderShadow; }
};

struct RaySetOptions {
    uint64_t seed = 1;
    size_t count = 100000;  ///< rays per kind (camera: the nearest W x H grid at 4:3)
    /// Where RenderClosest and RenderShadow take their rays (the first `count` of each).
    const RayRecord* record = nullptr;
};

/// Generates `kind` rays for `scene`. Shadow and Diffuse rays start from surface points
/// found by tracing with `reference` (any correct backend), offset along the normal by
/// a scale-relative epsilon, so they exercise secondary-ray traversal.
RaySet make_ray_set(RayKind kind, const scenes::Scene& scene, const accel::Accelerator& reference,
                    const RaySetOptions& options);

}  // namespace renderer
