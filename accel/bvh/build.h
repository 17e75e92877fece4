// The binary builders: binned SAH (Wald 2007) and the course's midpoint split. They
// produce a flat binary tree; wide.h collapses it into the traversal layout.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "accel/accelerator.h"
#include "accel/primitive.h"

namespace accel::bvh {

/// 32 bytes, depth-first, siblings adjacent. The build output and what inspect_bvh and
/// the reported SAH cost describe; traversal never reads it.
struct alignas(32) Node {
    float b[6];         ///< lo.x lo.y lo.z hi.x hi.y hi.z
    uint32_t offset;    ///< leaf: first slot in leaf order; interior: left child (right = +1)
    uint32_t meta;      ///< leaf: primitive count (> 0); interior: 0 | split axis << 30

    static constexpr uint32_t kCountMask = (1u << 30) - 1;
    bool is_leaf() const { return (meta & kCountMask) != 0; }
    uint32_t count() const { return meta & kCountMask; }
    Bounds3f bounds() const { return {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}}; }
};
static_assert(sizeof(Node) == 32);

/// Leaves are priced in blocks of this many primitives: the leaf kernel tests four
/// triangles in one SIMD Möller–Trumbore or Woop test, so 1..4 triangles cost the same.
constexpr uint32_t kLeafBlock = 4;

/// Traversal stack bound: the build switches to object-median splits below
/// kMaxFreeDepth, so no tree is deeper than kMaxFreeDepth + 32 < kStackSize.
constexpr uint32_t kStackSize = 128;

struct BinaryTree {
    std::vector<Node> nodes;
    std::vector<PrimRef> order;  ///< primitives in leaf order (Node::offset indexes it)
    /// Built with spatial splits: a primitive may sit in several leaves (several slots of
    /// `order`), and a leaf box bounds only the part of each primitive it was given.
    bool spatial = false;
};

/// Builds over the collected primitives `refs`. Leaves hold one geometry type only
/// (triangles or spheres), so every leaf maps to one kind of SIMD block.
BinaryTree build_binary(std::span<const GeometryView> geometry, const std::vector<PrimRef>& refs,
                        BvhSplit split, uint32_t leaf_size, int threads);

/// The same binned build over n boxes, box(i) each (called once per box, from several
/// threads): the top level of the two-level BVH (instanced.cpp), whose primitives are
/// instances. order[k].prim is the box index at leaf slot k (geom is 0).
BinaryTree build_boxes(uint32_t n, const std::function<Bounds3f(uint32_t)>& box, BvhSplit split, uint32_t leaf_size,
                       int threads);

struct TreeFacts {
    uint64_t leaves = 0;
    uint32_t depth = 0;
    uint32_t max_leaf = 0;
    double sah_cost = 0.0;
};

/// SAH cost (Goldsmith & Salmon 1987; MacDonald & Booth 1990) with C_trav = 1 and
/// C_isect = 1 per leaf block of kLeafBlock primitives (what the SIMD leaf test pays):
/// expected binary node visits plus block tests of a random ray that hits the root box.
/// SBVH: Stich, Friedrich, Dietrich 2009, "Spatial Splits in Bounding Volume
/// Hierarchies" (build_sbvh.cpp). Binned object splits as build_binary's, plus spatial
/// splits that clip triangles to the split plane, tried where the object split's children
/// overlap by more than kSbvhAlpha of the root's area, with reference unsplitting. The
/// references grow to at most (1 + kSbvhBudget) x the primitives. Same tree at any
/// thread count. The budget is shared out in proportion to references, and a spatial
/// split across a node of needles duplicates nearly all of them, so a budget below 1.0
/// never affords one on the 1000:1 sliver mesh (measured: 0.3 gave the plain SAH tree).
constexpr double kSbvhAlpha = 1e-5;
constexpr double kSbvhBudget = 1.0;
/// The leaf-size cap a builder uses when AccelOptions::leaf_size is 0. Below the cap the
/// SAH decides (a leaf of 5-8 costs two block tests, which the AVX2 and AVX-512 kernels
/// make in one 8-lane test); above it a split is forced, even one that separates
/// nothing. Measured (accel/DECISIONS.md, "leaf-size cap"), with the 8-lane test of two blocks:
/// - binned SAH, cap 8 against 4 on the course meshes and the 5M sphere: camera +4 to
///   +9 %, shadow 0 to +22 %, diffuse -4 to +11 %;
/// - SBVH, whose meshes hold bundles of overlapping needles no split separates: on the
///   1000:1 sliver mesh caps 4 / 8 / 12 test the same ~1415 triangles per shadow ray but
///   visit 104 / 63 / 49 wide nodes. Cap 16 fills the AVX-512 kernel's 16-lane test
///   (kernel.h, tri16_mt): against 12, sliver shadow rays +9 to +14 %, camera and
///   diffuse within noise ("16-lane SBVH leaves");
/// - binned SAH: caps 12 and 16 with that test measured -14 to +5 % on the course
///   meshes (CBbunny lost on every ray kind), so it keeps 8;
/// - midpoint keeps 4: it makes every node of at most the cap a leaf, without a cost.
constexpr uint32_t default_leaf_size(BvhSplit split) {
    return split == BvhSplit::Sbvh ? 16u : split == BvhSplit::Sah ? 8u : 4u;
}

BinaryTree build_sbvh(std::span<const GeometryView> geometry, const std::vector<PrimRef>& refs,
                      uint32_t leaf_size, int threads);

TreeFacts tree_facts(const std::vector<Node>& nodes);

/// For storage about to be written for the first time (a reserved std::vector's, say):
/// advises it as transparent huge pages and faults its pages in on the calling arena's
/// threads. A std::vector then clears it on one thread, and on this machine the page
/// faults, not the clearing, were most of that serial time (they cost ~1-2 ms per MB
/// for fresh memory: `perf` of the 5M-triangle build; accel/DECISIONS.md, "parallel build").
void prepare_fresh(void* p, size_t bytes);

}  // namespace accel::bvh
