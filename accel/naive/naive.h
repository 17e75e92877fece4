#pragma once
#include <memory>
#include <span>

#include "accel/accelerator.h"

namespace accel {
/// Tests every primitive for every ray: the reference (the course's "No BVH"). Instances:
/// every primitive of every instance, the ray carried into each instance's object space.
std::unique_ptr<Accelerator> make_naive(std::span<const GeometryView> geometry,
                                        const AccelOptions& options, const InstanceSet& instances = {});
}  // namespace accel
