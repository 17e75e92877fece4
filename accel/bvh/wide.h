// The traversal layout: 8-wide nodes with SoA child boxes and SoA leaf blocks of four
// primitives, collapsed from the binary build.
//
// Wide nodes: Dammertz, Hanika, Keller 2008, "Shallow Bounding Volume Hierarchies for
// Fast SIMD Ray Tracing of Incoherent Rays"; Wald, Benthin, Boulos 2008, "Getting Rid of
// Packets". One node is 256 bytes (four cache lines), tested in one 8-lane instruction
// sequence with AVX2 or two 4-lane halves with SSE2. Leaf blocks: the "triangle4" of
// Embree (Wald et al. 2014, "Embree: A Kernel Framework for Efficient CPU Ray Tracing"),
// four triangles in SoA form so one Möller–Trumbore or Woop test covers them all.
#pragma once

#include <sys/mman.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <span>
#include <vector>

#include "accel/bvh/build.h"
#include "accel/out_of_memory.h"

namespace accel::bvh {

constexpr int kWidth = 8;

struct alignas(64) WideNode {
    float b[6][kWidth];      ///< [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z][lane]
    uint32_t child[kWidth];  ///< interior: WideNode index; leaf: kLeaf | first block; kEmpty
    /// Leaf: number of blocks | (primitives << kPrimShift) | kSpheres; the primitive
    /// count (the blocks' filled lanes) lets a counting traversal add a leaf's tests at
    /// once (kernel.h, traverse). Interior child whose lanes are all leaves (a
    /// bottom node) of a tree with WideBvh::leaf_hints: where its blocks lie, as
    /// (number << kHintShift) | first, which the kernels prefetch on entering it
    /// (kernel.h, prefetch_leaves); 0 for any other interior child, or one whose
    /// blocks the fields cannot hold.
    uint32_t count[kWidth];

    static constexpr uint32_t kLeaf = 0x80000000u;
    static constexpr uint32_t kEmpty = 0xFFFFFFFFu;
    static constexpr uint32_t kSpheres = 0x80000000u;  ///< in count: the blocks hold spheres
    static constexpr uint32_t kBlockMask = 0xFFFFu;     ///< in a leaf's count: its number of blocks
    static constexpr uint32_t kPrimShift = 16;          ///< in a leaf's count: where its primitives start
    static constexpr uint32_t kPrimMask = 0x7FFFu;      ///< the primitives, after the shift
    /// A leaf lane's count, and its two fields back (the builders cap a leaf at 255
    /// primitives, far inside either field; inspect_bvh checks the primitives).
    static uint32_t leaf_count(uint32_t blocks, uint32_t prims, bool spheres) {
        return blocks | prims << kPrimShift | (spheres ? kSpheres : 0u);
    }
    static uint32_t leaf_blocks(uint32_t count) { return count & kBlockMask; }
    static uint32_t leaf_prims(uint32_t count) { return (count >> kPrimShift) & kPrimMask; }
    static constexpr uint32_t kHintShift = 24;
    static constexpr uint32_t kHintBlocks = 1u << kHintShift;  ///< first block below this (64M triangles)
    static constexpr uint32_t kHintMaxBlocks = 32;             ///< 8 leaves of up to 16 primitives (sbvh)

    /// The count of an interior lane whose child, a bottom node, has blocks [first, first + n).
    static uint32_t leaves_hint(uint32_t first, uint32_t n) {
        return first < kHintBlocks && n <= kHintMaxBlocks ? (n << kHintShift) | first : 0u;
    }
};
static_assert(sizeof(WideNode) == 32 * kWidth);

/// The compressed wide node (Ylitie, Karras, Laine 2017, "Efficient Incoherent Ray
/// Traversal on GPUs Through Compressed Wide BVHs", section 3.1; Embree's
/// QuantizedBaseNode is the same idea on CPUs): the eight child boxes as 8-bit offsets
/// on a per-node grid, origin[a] + q * 2^(exp[a] - 127), rounded outward so each is a
/// superset of the child's float box. 128 bytes (two cache lines) instead of 256, for
/// trees whose nodes miss the caches. Dequantisation is exact up to the one rounding of
/// the addition (q * 2^e is exact), so the kernel tests the very float box quantize.cpp
/// checked, with the float node's own slab test: a ray the float node lets through
/// passes here too (every operation of that test is monotone in the box), and no hit is
/// lost. Empty lanes are cleared by `valid`, not by an inverted box (an 8-bit grid
/// cannot express +-inf).
struct alignas(64) QuantNode {
    float origin[3];         ///< grid origin per axis (the node's box low corner)
    uint8_t exp[3];          ///< grid step 2^(exp - 127), a float's biased exponent
    uint8_t valid;           ///< bit i: lane i holds a child
    uint8_t q[6][kWidth];    ///< [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z][lane], rows as WideNode::b
    uint32_t child[kWidth];  ///< as WideNode::child (interior children index QuantNodes)
    uint32_t count[kWidth];  ///< as WideNode::count
};
static_assert(sizeof(QuantNode) == 16 * kWidth);

/// Four primitives of one leaf, SoA. Triangles, fast mode: v0 and the precomputed edges
/// e1 = v1 - v0, e2 = v2 - v0 (the same float subtractions the scalar test makes, so the
/// results are bit-identical to naive's). Watertight mode: v0, v1, v2 as stored in the
/// scene (Woop's test translates by the ray origin, so edges would lose its guarantee).
/// Spheres: p[0] = centre, p[1][0] = radius. Unused lanes: prim kNone and all-zero
/// geometry (a degenerate triangle, det = 0, that no lane mask lets through anyway).
/// The primitive's own index is stored, not its leaf-order slot: a closest hit then
/// needs no read of the slot map, a random access into 8 bytes per primitive that
/// missed the caches on big meshes (5M sphere: +22 % camera rays; accel/DECISIONS.md, "primitive ids in the leaf blocks").
struct alignas(16) Block {
    float p[3][3][4];  ///< [vertex or edge][axis][lane]
    uint32_t prim[4];  ///< the primitive's index in its geometry (Hit::prim_id); kNone: unused lane

    static constexpr uint32_t kNone = 0xFFFFFFFFu;
};
static_assert(sizeof(Block) == 160);

/// Where a closest hit was found: its block and lane.
struct BlockLane {
    const Block* block = nullptr;
    int lane = 0;
};

/// Allocator for the arrays traversal reads: incoherent rays touch them at random, and
/// with 4 KiB pages a few MiB of nodes overflow the TLB. Large blocks are 2 MiB aligned
/// and advised as transparent huge pages (Linux; a no-op where unsupported).
template <typename T>
struct TraversalAllocator {
    using value_type = T;
    static constexpr size_t kHuge = size_t(2) << 20;
    TraversalAllocator() = default;
    template <typename U>
    TraversalAllocator(const TraversalAllocator<U>&) {}
    T* allocate(size_t n) {
        const size_t bytes = n * sizeof(T);
        const size_t align = bytes >= kHuge / 2 ? kHuge : std::max<size_t>(alignof(T), 64);
        void* p = std::aligned_alloc(align, (bytes + align - 1) / align * align);
        if (!p) throw_out_of_memory(bytes);
#ifdef MADV_HUGEPAGE
        if (align == kHuge) madvise(p, (bytes + align - 1) / align * align, MADV_HUGEPAGE);
#endif
        return static_cast<T*>(p);
    }
    void deallocate(T* p, size_t) { std::free(p); }
    template <typename U>
    bool operator==(const TraversalAllocator<U>&) const { return true; }
};
template <typename T>
using TraversalVector = std::vector<T, TraversalAllocator<T>>;

struct WideBvh {
    /// nodes[0] is the root (if any primitive). Emptied by quantize(), which moves the
    /// tree to qnodes (same indices): traversal reads one layout or the other.
    TraversalVector<WideNode> nodes;
    TraversalVector<QuantNode> qnodes;
    TraversalVector<Block> blocks;    ///< leaf blocks, in the order collapse reaches them
    /// The geometry of each block lane (block * 4 + lane), only for scenes of several
    /// geometries; otherwise empty, and every primitive belongs to one_geom.
    TraversalVector<uint32_t> lane_geom;
    uint32_t one_geom = 0;
    /// Interior lanes carry their bottom children's leaf-block hints (WideNode::count).
    bool leaf_hints = false;
    float root[6] = {};               ///< scene box (bounds(); traversal starts at nodes[0])
    /// The geometry views, indexed by geometry id, for the hit filters of masked geometry
    /// (kernel.h, keep_hit): BvhBase::geometry_'s array, set by BvhBase::build only when
    /// some view is masked; null otherwise. Last, so the fields traversal reads keep
    /// their offsets.
    const GeometryView* geometry = nullptr;
};

/// The primitive in lane `lane` of block `b` (one of w.blocks), as (geometry, index).
inline PrimRef lane_primitive(const WideBvh& w, const Block& b, int lane) {
    const uint32_t geom =
        w.lane_geom.empty() ? w.one_geom : w.lane_geom[size_t(&b - w.blocks.data()) * 4 + size_t(lane)];
    return {geom, b.prim[lane]};
}

/// The cost model of the collapse (wide.cpp, Plan), in units of one 8-wide node test:
/// a leaf of one block costs kBlockCost and each pair of blocks, which the AVX2 and
/// AVX-512 kernels test in one 8-lane Möller–Trumbore, kBlockPairCost (the tree does not
/// depend on the ISA that traces it). Measured on the course meshes and the 5M sphere
/// (accel/DECISIONS.md, "collapse by dynamic programming"): a pair cost of 1.25 or 1.5 gives the same speed within noise;
/// 1.0, a block cost of 0.7 or 1.5, or a fixed cost per leaf visited, no gain.
struct CollapseCost {
    static constexpr float kNode = 1.0f;
    static constexpr float kBlock = 1.0f;
    static constexpr float kBlockPair = 1.25f;
    static float leaf(uint32_t prims) {
        const uint32_t b = (prims + kLeafBlock - 1) / kLeafBlock;
        return float(b / 2) * kBlockPair + float(b % 2) * kBlock;
    }
};

/// The SAH cost of a float wide tree under CollapseCost, relative to the root's area:
/// the expected node tests and leaf costs of a ray that hits the root box.
double wide_sah_cost(const WideBvh& w);

/// Leaf blocks of at least this many bytes get prefetch hints under LeafPrefetch::Auto.
/// Measured (accel/DECISIONS.md, "leaf prefetch"): on the course meshes (blocks of 0.2-2.5 MB, in L2
/// or L3) the prefetch cost 1-7 %; on a 250K-triangle sphere (~10 MB) it was even; on
/// 1M (~40 MB) and 5M triangles (~200 MB) it gained 7-22 %. The threshold lies
/// between, near the size of a last-level cache.
constexpr uint64_t kLeafHintBytes = uint64_t(24) << 20;

/// Collapses the binary tree into 8-wide nodes and packs every leaf into blocks. Which
/// binary nodes become wide nodes and which subtrees become leaves (of at most
/// `max_leaf` primitives; a binary leaf stays a leaf whatever its size) is the SAH-optimal
/// choice of Ylitie et al. 2017 (wide.cpp).
/// Interior lanes get leaf-block hints as `prefetch` says (Auto: kLeafHintBytes).
WideBvh collapse(const BinaryTree& tree, std::span<const GeometryView> geometry, TriangleTest test,
                 uint32_t max_leaf, LeafPrefetch prefetch = LeafPrefetch::Auto);

/// Collapses a two-level BVH's top tree, whose binary leaves each hold one placement,
/// into 8-wide nodes by the same plan (no subtree merged into a leaf): leaf lanes are
/// kLeaf | placement (leaf order) with count 1, which the caller may reuse (instanced.cpp
/// stores the placement's bottom tree there); lanes by surface area, largest first (the
/// any-hit walk enters the lowest hit lane first).
void collapse_top(const BinaryTree& tree, TraversalVector<WideNode>& out);

/// Bytes the traversal arrays occupy.
inline uint64_t wide_bytes(const WideBvh& w) {
    return w.nodes.capacity() * sizeof(WideNode) + w.qnodes.capacity() * sizeof(QuantNode) +
           w.blocks.capacity() * sizeof(Block) + w.lane_geom.capacity() * sizeof(uint32_t);
}

/// Builds w.qnodes from w.nodes (quantize.cpp). Returns false, leaving w unchanged, if
/// some node's box cannot be put on an 8-bit grid with a float exponent (a box spanning
/// more than 2^127 * 255, or non-finite); on success w.nodes is released unless
/// keep_float (tests compare the two).
bool quantize(WideBvh& w, bool keep_float = false);

/// Lane i's box of a quantized node as the kernel computes it: [lo xyz, hi xyz].
void dequantize(const QuantNode& n, int lane, float box[6]);

}  // namespace accel::bvh
