#pragma once
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "accel/accelerator.h"

namespace accel {
/// Our own BVH ("custom"): midpoint or binned-SAH build into flat 32-byte binary nodes,
/// traced through an 8-wide SSE2 collapse of that tree. Statistics per query:
/// ++rays (intersect) or ++shadow_rays (occluded); nodes_visited = ray-box tests (the
/// scene box once, then the real children of every wide node processed); prim_tests =
/// calls of the shared primitive intersector. BuildInfo::sah_cost is the binary tree's
/// SAH cost with C_trav = C_isect = 1 (see tree_facts in bvh.cpp).
std::unique_ptr<Accelerator> make_bvh(std::span<const GeometryView> geometry,
                                      const AccelOptions& options);

/// Structural facts about a custom BVH, recomputed from the built tree (not from
/// BuildInfo), so tests can check the build instead of trusting it.
struct BvhReport {
    uint64_t nodes = 0, leaves = 0, primitives = 0;
    uint32_t depth = 0;          ///< nodes on the longest root-to-leaf path (root only = 1)
    uint32_t max_leaf_size = 0;  ///< largest leaf
    uint32_t leaf_size_limit = 0;///< AccelOptions::leaf_size the tree was built with
    /// Standard SAH cost recomputed from the nodes, C_trav = C_isect = 1 (see bvh.cpp).
    double sah_cost = 0.0;
    bool prims_once = true;          ///< every collected primitive in exactly one leaf
    bool children_inside = true;     ///< every child's box inside its parent's box
    bool leaves_contain_prims = true;///< every leaf box contains its primitives' boxes
    bool leaf_size_ok = true;        ///< no leaf above the limit, no empty leaf
    bool gathered_ok = true;         ///< pre-gathered leaf vertices equal the scene's
    bool siblings_adjacent = true;   ///< children of a node are consecutive and after it
    /// The 8-wide tree traversal actually uses (collapsed from the binary one) covers
    /// every primitive once, with nested, containing boxes.
    bool wide_ok = true;
    std::vector<std::string> errors; ///< first few violations, human readable

    bool ok() const {
        return prims_once && children_inside && leaves_contain_prims && leaf_size_ok &&
               gathered_ok && siblings_adjacent && wide_ok;
    }
};

/// Inspects an accelerator made by make_bvh; nullopt for any other backend. Slow
/// (walks the whole tree and re-reads the geometry); meant for tests and tools.
std::optional<BvhReport> inspect_bvh(const Accelerator& accel);
}  // namespace accel
