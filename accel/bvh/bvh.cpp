// STUB until the BVH lands: asking for it is a clear error, not a silent fallback.
#include "accel/bvh/bvh.h"

namespace accel {
std::unique_ptr<Accelerator> make_bvh(std::span<const GeometryView>, const AccelOptions&) {
    throw AccelError("--accel=custom is not available yet in this build");
}
}  // namespace accel
