// STUB until the Embree backend lands: asking for it is a clear error.
#include "accel/embree/embree.h"

namespace accel {
std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView>, const AccelOptions&) {
    throw AccelError("--accel=embree is not available yet in this build");
}
}  // namespace accel
