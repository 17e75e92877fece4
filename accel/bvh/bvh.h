#pragma once
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "accel/accelerator.h"

namespace accel {
/// Our own BVH ("custom"): midpoint or binned-SAH build into a binary tree (build.h),
/// collapsed into 8-wide nodes with SoA leaf blocks of four primitives (wide.h), traced
/// by a kernel compiled per instruction set and picked at run time (kernel.h,
/// dispatch.h). Statistics per query: ++rays (intersect) or ++shadow_rays (occluded);
/// when TraceStats::counting, nodes_visited = 1 per wide node whose children are tested
/// (the root's always), prim_tests = filled lanes of the leaf blocks tested.
/// BuildInfo::sah_cost is the binary tree's SAH cost with C_trav = 1 and C_isect = 1
/// per leaf block of four (tree_facts in build.h).
std::unique_ptr<Accelerator> make_bvh(std::span<const GeometryView> geometry,
                                      const AccelOptions& options, const InstanceSet& instances = {});

/// "sse2", "avx2", "avx512" ("auto" for Auto).
const char* isa_name(Isa isa);
/// Parses auto|sse2|avx2|avx512; false for anything else.
bool parse_isa(const std::string& s, Isa& out);
/// True if this CPU (and OS) can run the kernel for `isa`.
bool cpu_has(Isa isa);
/// The kernel Auto picks on this CPU; any other value is returned unchanged.
Isa resolve_isa(Isa isa);
/// "float", "quantized" ("auto" for Auto).
const char* layout_name(NodeLayout layout);
/// Parses auto|float|quantized; false for anything else.
bool parse_layout(const std::string& s, NodeLayout& out);
/// Auto's threshold for quantized nodes, in primitives. Measured (accel/DECISIONS.md,
/// "quantized-node threshold"): on the course meshes (<= 51k triangles, trees of a few MiB that stay in L2/L3)
/// quantized nodes are 10-20 % slower, dequantizing costing ~23 instructions per node; on
/// the 5M sphere (~290 MB of nodes and blocks) they are about even (diffuse +1..+12 %,
/// shadow -7..+7 %), on a 15M sphere 10-15 % faster on shadow and diffuse rays.
constexpr uint64_t kQuantizeFrom = 4000000;
/// The layout Auto picks for a scene of `primitives` (any other value is returned
/// unchanged): quantized from kQuantizeFrom primitives on, float below.
NodeLayout resolve_layout(NodeLayout layout, uint64_t primitives);
/// Kernels compiled in that this CPU can run, narrowest first.
std::vector<Isa> supported_isas();

/// Structural facts about a custom BVH, recomputed from the built tree (not from
/// BuildInfo), so tests can check the build instead of trusting it.
struct BvhReport {
    uint64_t nodes = 0, leaves = 0, primitives = 0;
    /// Leaf slots: primitives plus the duplicates spatial splits (sbvh) made.
    uint64_t references = 0;
    uint32_t depth = 0;          ///< nodes on the longest root-to-leaf path (root only = 1)
    uint32_t max_leaf_size = 0;  ///< largest leaf
    uint32_t leaf_size_limit = 0;///< AccelOptions::leaf_size the tree was built with
    /// SAH cost recomputed from the nodes, leaves priced per block (tree_facts, build.h).
    double sah_cost = 0.0;
    /// Every collected primitive in exactly one leaf (sbvh: in at least one, and every
    /// leaf slot in exactly one leaf).
    bool prims_once = true;
    bool children_inside = true;     ///< every child's box inside its parent's box
    /// Every leaf box contains its primitives' boxes. sbvh, whose leaves hold clipped
    /// parts: every leaf box overlaps its primitives' boxes, and the leaf boxes holding a
    /// triangle together cover it (checked at 28 barycentric points per triangle).
    bool leaves_contain_prims = true;
    bool leaf_size_ok = true;        ///< no leaf above the limit, no empty leaf
    bool gathered_ok = true;         ///< leaf blocks hold the scene's vertices (or exact edges)
    bool siblings_adjacent = true;   ///< children of a node are consecutive and after it
    /// The 8-wide tree traversal actually uses (collapsed from the binary one) covers
    /// every primitive once, with nested, containing boxes.
    uint64_t wide_nodes = 0, blocks = 0;
    bool quantized = false;          ///< traversal reads compressed nodes (QuantNode)
    bool leaf_hints = false;         ///< interior lanes carry leaf-block prefetch hints
    double filled_lanes = 0;         ///< primitives / (4 * blocks)
    bool wide_ok = true;
    std::vector<std::string> errors; ///< first few violations, human readable

    bool ok() const {
        return prims_once && children_inside && leaves_contain_prims && leaf_size_ok &&
               gathered_ok && siblings_adjacent && wide_ok;
    }
};

/// Inspects an accelerator made by make_bvh with AccelOptions::keep_binary_tree; nullopt
/// for any other backend, or one built without it. Slow (walks the whole tree and
/// re-reads the geometry); meant for tests and tools.
std::optional<BvhReport> inspect_bvh(const Accelerator& accel);
}  // namespace accel
