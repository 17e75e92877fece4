#include "accel/accelerator.h"

#include "accel/out_of_memory.h"

namespace accel {

bool Accelerator::has_batches() const { return false; }

void Accelerator::intersect_batch(std::span<const Ray> rays, Hit* hits, TraceStats& stats) const {
    for (size_t i = 0; i < rays.size(); ++i) {
        hits[i] = Hit{};
        intersect(rays[i], hits[i], stats);
    }
}

void Accelerator::occluded_batch(std::span<const Ray> rays, uint8_t* occluded, TraceStats& stats) const {
    for (size_t i = 0; i < rays.size(); ++i) occluded[i] = this->occluded(rays[i], stats) ? 1 : 0;
}

void throw_out_of_memory(uint64_t bytes) { throw OutOfMemory(bytes, ""); }

}  // namespace accel
