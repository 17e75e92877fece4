#pragma once
#include <memory>
#include <span>

#include "accel/accelerator.h"

namespace accel {
/// Tests every primitive for every ray: the reference (the course's "No BVH").
std::unique_ptr<Accelerator> make_naive(std::span<const GeometryView> geometry,
                                        const AccelOptions& options);
}  // namespace accel
