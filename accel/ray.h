// The one Ray/Hit vocabulary shared by every backend and every integrator.
#pragma once

#include <cstdint>

#include "accel/math.h"

namespace accel {

/// Sentinel for "no geometry / no primitive", as Embree's RTC_INVALID_GEOMETRY_ID.
inline constexpr uint32_t kInvalidId = 0xFFFFFFFFu;

/// A ray segment org + t * dir, t in [t_min, t_max]. `dir` need not be normalised;
/// t is measured in units of |dir|.
struct Ray {
    Vec3f org;
    Vec3f dir;
    float t_min = 0.0f;
    float t_max = kInfinity;
};

/// Closest-hit record. Kept small (like mitsuba's PreliminaryIntersection); the renderer
/// rebuilds shading normals and texture coordinates from the scene using ids and (u, v).
struct Hit {
    float t = kInfinity;
    /// Barycentrics: the hit point is (1-u-v)*v0 + u*v1 + v*v2 for triangles.
    /// For spheres, u and v are unused (0).
    float u = 0.0f, v = 0.0f;
    uint32_t geom_id = kInvalidId;  ///< index of the GeometryView given at build time
    uint32_t prim_id = kInvalidId;  ///< triangle or sphere index inside that geometry
    /// Geometric normal in world space, unnormalised. Triangles: cross(v1-v0, v2-v0)
    /// (follows winding); of an instance, the object-space one times the cofactor matrix
    /// of the linear part L (det L * L^-T), which is the cross product of the transformed
    /// edges, so it matches the flattened copy up to rounding, orientation included.
    /// Spheres: hit point - centre (outward).
    Vec3f ng;
    /// The instance (index into InstanceSet::instances) whose prototype holds geom_id;
    /// kInvalidId for geometry placed in world space. As Embree's instID[0]. Last, so the
    /// plugin ABI's hit (accel_plugin.h) stays the first 32 bytes of this one.
    uint32_t inst_id = kInvalidId;

    bool valid() const { return geom_id != kInvalidId; }
};

}  // namespace accel
