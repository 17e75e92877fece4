// The two-level BVH: a top-level tree over the instances' world boxes, with the same
// 8-wide nodes and per-ISA kernels as a flat scene, over one bottom-level tree per
// prototype, shared by all its instances (pbrt-v4's BVHAggregate over
// TransformedPrimitives; Embree's two-level instancing, Wald et al. 2014). The data is
// built here by baseline code (instanced.cpp); the traversal lives in kernel.h
// (InstancedKernel), compiled per ISA like the flat one.
#pragma once

#include <memory>
#include <vector>

#include "accel/accelerator.h"
#include "accel/bvh/base.h"

namespace accel::bvh {

/// One leaf entry of the top tree: an instance, or the world-space geometry (inst ==
/// kInvalidId, no transform). 52 bytes; the top tree's leaf lanes index these (leaf
/// order), one placement each, and carry the bottom tree it places in the lane's count
/// field, which the node test has just brought into the cache (accel/DECISIONS.md,
/// "the bottom tree in the top leaf lane").
struct Placement {
    Affine3f world_to_object;  ///< the inverse of InstanceView::object_to_world
    uint32_t inst;             ///< Hit::inst_id: the instance's index in the InstanceSet
};
static_assert(sizeof(Placement) == 52);

/// Everything of the two-level BVH that is not traversal (built and finished by baseline
/// code, for the reason BvhBase gives).
class InstancedBase : public Accelerator {
public:
    InstancedBase();
    ~InstancedBase() override;
    const BuildInfo& info() const override;
    Bounds3f bounds() const override;

    /// Builds the bottom trees (one per prototype, and one for the world-space geometry
    /// if any) with the kernels of `isa`, then the top tree over the placements' world
    /// boxes. Returns false, as BvhBase::build, if `quantized` was asked for and some
    /// tree could not be compressed; the caller then builds again with float nodes.
    bool build(std::span<const GeometryView> geometry, const AccelOptions& opt, const InstanceSet& instances,
               Isa isa, bool top_quantized, bool quantized);
    /// The hit of placement `p` found at (t, u, v) in lane `at` of a block of its bottom
    /// tree `bottom`: ids from the block (geometry ids made the caller's), the instance, and the
    /// normal carried to world space (to_world_normal, accel/primitive.h).
    void finish(const Placement& p, uint32_t bottom, BlockLane at, const Ray& ray, float t, float u, float v,
                Hit& hit) const;

    WideBvh top_;  ///< leaf lanes: child kLeaf | placement, count = its bottom tree
    /// In leaf order; huge pages, as the nodes (accel/DECISIONS.md, "placements in huge pages").
    TraversalVector<Placement> placements_;
    std::vector<const WideBvh*> bottom_wide_;  ///< per bottom tree: what traversal reads
    std::vector<uint32_t> geom_base_;          ///< per bottom tree: its geometry 0's id
    std::vector<std::unique_ptr<BvhBase>> bottoms_;
    bool masked_ = false;
    BuildInfo info_;
    Bounds3f bounds_;
};

/// The two-level kernel for one ISA (kernel.h), as make_kernel_* for flat scenes.
/// `top_quantized`: the top tree's nodes are QuantNodes; `quantized`: the bottom trees'.
std::unique_ptr<InstancedBase> make_instanced_sse2(TriangleTest test, bool top_quantized, bool quantized, bool masked);
std::unique_ptr<InstancedBase> make_instanced_avx2(TriangleTest test, bool top_quantized, bool quantized, bool masked);
std::unique_ptr<InstancedBase> make_instanced_avx512(TriangleTest test, bool top_quantized, bool quantized,
                                                     bool masked);

}  // namespace accel::bvh
