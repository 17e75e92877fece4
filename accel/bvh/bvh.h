#pragma once
#include <memory>
#include <span>

#include "accel/accelerator.h"

namespace accel {
/// Our own BVH ("custom"): midpoint or binned-SAH build, flat nodes.
std::unique_ptr<Accelerator> make_bvh(std::span<const GeometryView> geometry,
                                      const AccelOptions& options);
}  // namespace accel
