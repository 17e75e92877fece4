// Ray-by-ray comparison of two backends on the same rays, with every disagreement
// classified: an edge/vertex tie (both hit triangles sharing that edge or vertex at the
// same distance), numerical (the ray is within rounding of an edge, a silhouette, a
// segment end or a coplanar surface), or real (anything else: a bug).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "accel/accelerator.h"
#include "renderer/raysets.h"
#include "renderer/scene_geometry.h"

namespace renderer {

struct RayOutcome {
    bool hit = false;
    float t = 0, u = 0, v = 0;
    uint32_t geom = accel::kInvalidId, prim = accel::kInvalidId;
    accel::Vec3f ng;
    /// accel::Hit::inst_id: two hits agree only inside the same placement.
    uint32_t inst = accel::kInvalidId;
};

/// Traces every ray (closest hit; any-hit too for occlusion sets, stored in `hit`),
/// in parallel, with per-thread statistics summed into `stats`.
std::vector<RayOutcome> trace_set(const accel::Accelerator& accel, const RaySet& set,
                                  accel::TraceStats& stats, bool closest_for_shadow = false);

/// trace_set into a caller's array, resized to the set and every element written (a miss
/// as a default RayOutcome). For timing loops: reusing the array keeps its allocation and
/// clearing (serial, ~0.3-0.5 ms for 200 000 rays, 3-7 % of a fast backend's trace) out
/// of the timed region, where it diluted ratios and capped thread scaling.
void trace_set_into(const accel::Accelerator& accel, const RaySet& set, accel::TraceStats& stats,
                    std::vector<RayOutcome>& out, bool closest_for_shadow = false);

enum class Verdict : uint8_t { Agree, Tie, Numerical, Real };
const char* verdict_name(Verdict v);

/// Classifies `other` against `ref` for one ray (closest-hit outcomes; for occlusion
/// sets pass the closest-hit outcomes as well via ref_closest/other_closest).
Verdict classify(const accel::Ray& ray, bool occlusion, const RayOutcome& ref, const RayOutcome& other,
                 const RayOutcome& ref_closest, const RayOutcome& other_closest,
                 const SceneGeometry& geometry, float scene_scale);

struct KindReport {
    RayKind kind = RayKind::Camera;
    std::string reference, backend;
    uint64_t rays = 0;
    uint64_t hit_agree = 0;   ///< same hit/miss
    uint64_t prim_agree = 0;  ///< same hit/miss and, when both hit, same (geom, prim, instance)
    double max_rel_dt = 0;    ///< over rays where both hit the same primitive
    uint64_t ties = 0, numerical = 0, real = 0;
    accel::TraceStats stats;  ///< the backend's own counters on this set
};

struct Disagreement {
    RayKind kind;
    std::string backend;
    accel::Ray ray;
    Verdict verdict;
    RayOutcome ref, other;
};

/// Compares `other` with `ref` on `set`; appends disagreements to `out` (up to `keep`).
KindReport compare_backends(const accel::Accelerator& ref, const std::string& ref_label,
                            const accel::Accelerator& other, const std::string& other_label,
                            const RaySet& set, const SceneGeometry& geometry,
                            std::vector<Disagreement>* out, size_t keep = 100000);

}  // namespace renderer
