// Per-thread traversal statistics, filled by the backend that did the work.
#pragma once

#include <cstdint>

namespace accel {

/// Counters for one thread. The caller owns one per thread and passes it to every
/// intersect/occluded call, so the hot path never touches shared or atomic memory;
/// totals are the sum over threads after the work joins.
struct TraceStats {
    uint64_t rays = 0;          ///< closest-hit queries
    uint64_t shadow_rays = 0;   ///< any-hit (occlusion) queries
    uint64_t nodes_visited = 0; ///< BVH nodes whose boxes were tested (0 for naive)
    uint64_t prim_tests = 0;    ///< ray-primitive intersection tests
    /// Backends may skip counting nodes and tests when false (the custom BVH then runs
    /// an instantiation without counters); rays and shadow_rays are always counted.
    bool counting = true;

    TraceStats& operator+=(const TraceStats& o) {
        rays += o.rays;
        shadow_rays += o.shadow_rays;
        nodes_visited += o.nodes_visited;
        prim_tests += o.prim_tests;
        return *this;
    }
    uint64_t total_rays() const { return rays + shadow_rays; }
    double tests_per_ray() const {
        return total_rays() ? double(prim_tests) / double(total_rays()) : 0.0;
    }
    double nodes_per_ray() const {
        return total_rays() ? double(nodes_visited) / double(total_rays()) : 0.0;
    }
};

}  // namespace accel
