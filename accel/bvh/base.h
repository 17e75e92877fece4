// The data every kernel traverses, built once by baseline code (bvh.cpp). Kernels
// derive from BvhBase in their own ISA's translation unit.
#pragma once

#include <memory>
#include <vector>

#include "accel/accelerator.h"
#include "accel/bvh/build.h"
#include "accel/bvh/wide.h"

namespace accel::bvh {

/// Everything here that the compiler could emit out of line (constructor, destructor,
/// vtable, finishing a hit) is defined in bvh.cpp, compiled for baseline x86-64: were
/// it inline, an AVX2 kernel file could supply the one copy the linker keeps, and a
/// CPU without AVX2 would fault in code that never meant to use it.
class BvhBase : public Accelerator {
public:
    BvhBase();
    ~BvhBase() override;
    const BuildInfo& info() const override;
    Bounds3f bounds() const override;

    /// Builds the tree; `quantized`: then compresses the wide nodes (quantize.cpp) and
    /// returns false, leaving the float nodes, if that is impossible (a box too large
    /// for an 8-bit grid with a float exponent), so the caller can run a float kernel.
    bool build(std::span<const GeometryView> geometry, const AccelOptions& opt, const char* kernel,
               bool quantized);
    /// Takes over another instance's built data (a float kernel adopting the tree a
    /// quantized one could not compress).
    void adopt(BvhBase&& other);
    /// Fills hit for the primitive found at (t, u, v) in lane `at.lane` of block
    /// `at.block`. Its ids come from the block (and WideBvh::lane_geom for scenes of
    /// several geometries), not from the slot map. The normal comes from the block too
    /// (fast mode: cross(e1, e2) of the stored edges, which are the float subtractions
    /// triangle_normal makes; watertight: the stored vertices; spheres: the stored
    /// centre), bit for bit what finish_hit computes from the scene's arrays, without
    /// their cache misses: on the 5M sphere those arrays are ~90 MB, and reading a hit
    /// triangle's indices and vertices there cost ~1.5 L2 misses per camera ray
    /// (callgrind; accel/DECISIONS.md, "hit data from the leaf block").
    void finish(BlockLane at, const Ray& ray, float t, float u, float v, Hit& hit) const;

    std::vector<GeometryView> geometry_;
    BinaryTree tree_;  ///< the build output, kept only with AccelOptions::keep_binary_tree
    WideBvh wide_;     ///< what traversal reads
    bool has_spheres_ = false;
    bool edges_ = false;  ///< triangle blocks hold v0, e1, e2 (fast mode), not v0, v1, v2
    uint32_t leaf_size_ = 4;
    BuildInfo info_;
};

}  // namespace accel::bvh
