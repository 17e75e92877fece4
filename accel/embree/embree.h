#pragma once
#include <memory>
#include <span>
#include <string>

#include "accel/accelerator.h"

namespace accel {
/// Intel Embree 3 behind our interface. The only code that includes Embree headers
/// lives in this directory.
///
/// Normal mode: triangles are Embree triangles sharing the caller's buffers (no copy);
/// spheres are a user geometry running accel::intersect_sphere. Counting mode
/// (options.embree_count): every primitive is a user geometry running
/// accel::intersect_primitive, so prim_tests are counted on the same terms as our BVH.
/// Embree errors surface as AccelError("Embree error RTC_ERROR_...: text").
/// Instances: one child scene per prototype (its views numbered from 0 within it), placed
/// by one RTC_GEOMETRY_TYPE_INSTANCE each in the top scene, after the world-space views'
/// IDs; Hit ids map back to view index and instance index, the object-space Ng Embree
/// reports goes to world space by the cofactor of the instance's linear part (read from
/// the caller's InstanceView: nothing is stored per instance on our side). Embree 3.13
/// itself takes about 390 bytes of heap per instance (a ~290-byte geometry object its
/// memory monitor does not report, counted in BuildInfo::bytes by the heap's growth, and
/// ~95 bytes of top-level BVH); a flat scene is built as before.
std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView> geometry,
                                         const AccelOptions& options, const InstanceSet& instances = {});

/// As make_embree, with `extra_device_config` appended to the rtcNewDevice config string
/// (e.g. "verbose=1" or "tri_accel=bvh4.triangle4v"). For experiments and for the tests
/// that provoke genuine Embree errors through the real error path.
std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView> geometry,
                                         const AccelOptions& options,
                                         const std::string& extra_device_config, const InstanceSet& instances = {});
}  // namespace accel
