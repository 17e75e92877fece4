// The rays a render traces, recorded at the backend edge, so that the backends can be
// timed against each other on those very rays (`pathtracer --record-rays`, `accel_bench
// --ray-record`). A render's rays are not the generated sets' (renderer/raysets.h): on
// CBbunny its bounce rays start on the bunny and the walls and cross six times as many
// primitive tests as the generated diffuse set's (benchmarks/RESULTS.md, "A render's own
// rays: what bounds the end-to-end ratio").
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include <tbb/enumerable_thread_specific.h>

#include "accel/accelerator.h"
#include "scenes/scene.h"

namespace renderer {

/// What a record file holds: the closest-hit and the any-hit rays, each in the order one
/// thread traced them (threads one after another), and the primitive count of the scene
/// they were traced in (world-space plus instanced), which a reader checks against its own.
struct RayRecord {
    uint64_t scene_primitives = 0;
    std::vector<accel::Ray> closest, any_hit;
};

/// What a record's scene_primitives counts: world-space and instanced triangles and
/// spheres, the same whether the instances are traced as such or flattened.
inline uint64_t scene_primitives(const scenes::Scene& s) {
    return s.world_triangles() + s.instanced_triangles() + s.spheres.size();
}

/// read_ray_record, then a check that `scene` is the record's (its primitive count):
/// rays of another scene would time and compare nothing meaningful.
RayRecord read_ray_record_for(const std::string& path, const scenes::Scene& scene);

/// Reads a file write_ray_record wrote. Throws std::invalid_argument naming the file and
/// what is wrong with it (not a ray record, another version, a size that disagrees with
/// its counts, rays that are not finite) for bad input.
RayRecord read_ray_record(const std::string& path);

/// Writes `r` to `path` whole or not at all (a temporary file renamed over it). Throws
/// std::runtime_error naming the file on a failed write.
void write_ray_record(const std::string& path, const RayRecord& r);

/// An accelerator that traces with `inner` and keeps the first `max_per_kind` closest-hit
/// and any-hit rays it is given (per thread, lock-free; the cap counts all threads). The
/// recorded order is the threads' own, so only a 1-thread render records the same file
/// every time. A second virtual call per ray, and only while recording.
class RayRecorder final : public accel::Accelerator {
public:
    RayRecorder(const accel::Accelerator& inner, uint64_t max_per_kind);
    bool intersect(const accel::Ray& ray, accel::Hit& hit, accel::TraceStats& stats) const override;
    bool occluded(const accel::Ray& ray, accel::TraceStats& stats) const override;
    const accel::BuildInfo& info() const override { return inner_.info(); }
    accel::Bounds3f bounds() const override { return inner_.bounds(); }
    /// The rays recorded so far, threads one after another.
    RayRecord record(uint64_t scene_primitives) const;

private:
    struct Buffers {
        std::vector<accel::Ray> closest, any_hit;
    };
    void keep(std::atomic<uint64_t>& taken, std::vector<accel::Ray>& into, const accel::Ray& ray) const;
    const accel::Accelerator& inner_;
    const uint64_t max_;
    mutable std::atomic<uint64_t> closest_taken_{0}, any_hit_taken_{0};
    mutable tbb::enumerable_thread_specific<Buffers> buffers_;
};

}  // namespace renderer
