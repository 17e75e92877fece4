#pragma once
#include <memory>
#include <span>

#include "accel/accelerator.h"

namespace accel {
/// Intel Embree 3 behind our interface. The only code that includes Embree headers
/// lives in this directory.
std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView> geometry,
                                         const AccelOptions& options);
}  // namespace accel
