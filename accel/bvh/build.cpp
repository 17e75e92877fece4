// The binary builders. Binned SAH: Wald 2007, "On fast Construction of SAH-based
// Bounding Volume Hierarchies" (32 bins per axis, the SAH evaluated at the bin borders,
// leaves priced in SIMD blocks as Embree's builders do); midpoint: the course's split.
#include "accel/bvh/build.h"

#include "accel/bvh/build_bins.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <memory>

namespace accel::bvh {
namespace {

struct BuildPrim {
    Vec3f lo;
    uint32_t id;  ///< index into the collected PrimRefs
    Vec3f hi;
    uint32_t sphere;  ///< 1 for a sphere: leaves hold one type only
    Vec3f centroid() const { return (lo + hi) * 0.5f; }
};

struct BuildNode {
    Bounds3f bounds;
    uint32_t begin = 0, count = 0;  ///< leaf range in the BuildPrim array (count 0: interior)
    int axis = 0;
    std::unique_ptr<BuildNode> kid[2];
};

struct RangeInfo {
    Bounds3f bounds, cbounds;  ///< primitive bounds, centroid bounds
    void merge(const RangeInfo& o) {
        bounds.extend(o.bounds);
        cbounds.extend(o.cbounds);
    }
};

using namespace binned;

// Below these sizes the work is too small to be worth a task.
constexpr uint32_t kParallelBuild = 4096;
constexpr uint32_t kParallelBin = 32768;

// From this size on a node's bins also keep centroid bounds, which give the children's
// RangeInfo without another pass over their primitives; below it the larger bins cost
// more to clear than the pass they save.
constexpr uint32_t kChildInfoFromBins = 1024;

/// Bins, plus (WithCentroids) the centroid bounds per bin.
template <bool WithCentroids>
struct BinSet : Bins {};
template <>
struct BinSet<true> : Bins {
    Bounds3f c[3][kBins];
    void merge(const BinSet& o) {
        Bins::merge(o);
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < kBins; ++i) c[a][i].extend(o.c[a][i]);
    }
};

class Builder {
public:
    Builder(std::vector<BuildPrim>& prims, BvhSplit split, uint32_t leaf_size)
        : p_(prims), split_(split), leaf_size_(leaf_size) {}

    /// `known`: the range's bounds if the parent's bins already gave them.
    std::unique_ptr<BuildNode> build(uint32_t begin, uint32_t end, uint32_t depth,
                                     const RangeInfo* known = nullptr) {
        auto node = std::make_unique<BuildNode>();
        const uint32_t n = end - begin;
        const RangeInfo ri = known ? *known : range_info(begin, end);
        RangeInfo kids[2];
        bool kids_known = false;
        node->bounds = ri.bounds;
        uint32_t mid = begin;
        int axis = max_dimension(ri.cbounds.diagonal());
        bool leaf = false;
        if (n == 1) {
            leaf = true;
        } else if (depth >= kMaxFreeDepth) {
            leaf = n <= leaf_size_;
            if (!leaf) mid = median_split(begin, end, axis);
        } else if (split_ == BvhSplit::Midpoint) {
            leaf = n <= leaf_size_;
            if (!leaf) mid = midpoint_split(begin, end, ri.cbounds, axis);
        } else {
            leaf = !sah_split(begin, end, ri, mid, axis, kids, kids_known);
        }
        if (leaf) {
            // Leaves hold one primitive type, so each maps to one kind of SIMD block;
            // a mixed range is split by type instead (rare: spheres beside meshes).
            const auto first_sphere = std::partition(p_.begin() + begin, p_.begin() + end,
                                                     [](const BuildPrim& q) { return q.sphere == 0; });
            const uint32_t tmid = uint32_t(first_sphere - p_.begin());
            if (tmid != begin && tmid != end) {
                leaf = false;
                mid = tmid;
                kids_known = false;
            }
        }
        if (leaf) {
            node->begin = begin;
            node->count = n;
            leaves_.fetch_add(1, std::memory_order_relaxed);
            return node;
        }
        node->axis = axis;
        if (n >= kParallelBuild) {
            tbb::parallel_invoke(
                [&] { node->kid[0] = build(begin, mid, depth + 1, kids_known ? &kids[0] : nullptr); },
                [&] { node->kid[1] = build(mid, end, depth + 1, kids_known ? &kids[1] : nullptr); });
        } else {
            node->kid[0] = build(begin, mid, depth + 1, kids_known ? &kids[0] : nullptr);
            node->kid[1] = build(mid, end, depth + 1, kids_known ? &kids[1] : nullptr);
        }
        return node;
    }

    uint64_t leaves() const { return leaves_.load(); }

private:
    RangeInfo range_info(uint32_t begin, uint32_t end) const {
        auto body = [&](const tbb::blocked_range<uint32_t>& r, RangeInfo acc) {
            for (uint32_t i = r.begin(); i < r.end(); ++i) {
                acc.bounds.extend(p_[i].lo);
                acc.bounds.extend(p_[i].hi);
                acc.cbounds.extend(p_[i].centroid());
            }
            return acc;
        };
        if (end - begin < kParallelBin) return body({begin, end}, RangeInfo{});
        return tbb::parallel_reduce(
            tbb::blocked_range<uint32_t>(begin, end, 4096), RangeInfo{}, body,
            [](RangeInfo a, const RangeInfo& b) {
                a.merge(b);
                return a;
            });
    }

    /// Object median on `axis`; also the fallback when a spatial split leaves a side
    /// empty. nth_element keeps the tree balanced whatever the distribution.
    uint32_t median_split(uint32_t begin, uint32_t end, int axis) {
        const uint32_t mid = begin + (end - begin) / 2;
        std::nth_element(p_.begin() + begin, p_.begin() + mid, p_.begin() + end,
                         [axis](const BuildPrim& a, const BuildPrim& b) {
                             return a.centroid()[axis] < b.centroid()[axis];
                         });
        return mid;
    }

    /// The course's method: midpoint of the centroid bounds on their largest axis.
    uint32_t midpoint_split(uint32_t begin, uint32_t end, const Bounds3f& cb, int axis) {
        const float pivot = cb.center()[axis];
        auto it = std::partition(p_.begin() + begin, p_.begin() + end,
                                 [&](const BuildPrim& q) { return q.centroid()[axis] < pivot; });
        const uint32_t mid = uint32_t(it - p_.begin());
        if (mid == begin || mid == end) return median_split(begin, end, axis);
        return mid;
    }

    template <bool C>
    BinSet<C> bin(uint32_t begin, uint32_t end, const Binner& binner) const {
        auto body = [&](const tbb::blocked_range<uint32_t>& r, BinSet<C> acc) {
            for (uint32_t i = r.begin(); i < r.end(); ++i) {
                const Vec3f c = p_[i].centroid();
                Bounds3f pb{p_[i].lo, p_[i].hi};
                for (int a = 0; a < 3; ++a) {
                    const int k = binner.bin(c[a], a);
                    acc.b[a][k].extend(pb);
                    if constexpr (C) acc.c[a][k].extend(c);
                    ++acc.n[a][k];
                }
            }
            return acc;
        };
        if (end - begin < kParallelBin) return body({begin, end}, BinSet<C>{});
        return tbb::parallel_reduce(
            tbb::blocked_range<uint32_t>(begin, end, 8192), BinSet<C>{}, body,
            [](BinSet<C> a, const BinSet<C>& b) {
                a.merge(b);
                return a;
            });
    }

    /// Binned SAH. Returns false for "make a leaf". Above leaf_size a split is forced:
    /// the best binned one, or an object median when all centroids coincide.
    /// On a binned split also returns the children's RangeInfo, read off the bins.
    bool sah_split(uint32_t begin, uint32_t end, const RangeInfo& ri, uint32_t& mid, int& axis,
                   RangeInfo (&kids)[2], bool& kids_known) {
        return end - begin >= kChildInfoFromBins ? sah_split<true>(begin, end, ri, mid, axis, kids, kids_known)
                                                 : sah_split<false>(begin, end, ri, mid, axis, kids, kids_known);
    }
    template <bool C>
    bool sah_split(uint32_t begin, uint32_t end, const RangeInfo& ri, uint32_t& mid, int& axis,
                   RangeInfo (&kids)[2], bool& kids_known) {
        const uint32_t n = end - begin;
        const Vec3f cext = ri.cbounds.diagonal();
        if (!(max_component(cext) > 0.0f)) {  // all centroids coincide: no plane separates
            if (n <= leaf_size_) return false;
            mid = begin + n / 2;  // any order is as good as any other here
            return true;
        }
        const Binner binner(ri.cbounds);
        const BinSet<C> bins = bin<C>(begin, end, binner);
        const bool usable[3] = {cext[0] > 0.0f, cext[1] > 0.0f, cext[2] > 0.0f};
        Sweep sw;
        binned::sweep(bins.b, bins.n, bins.n, usable, sw, false);
        const double best = sw.cost;
        const int best_axis = sw.axis, best_split = sw.split;
        if (best_axis < 0) {  // cannot happen with a positive extent; be safe anyway
            if (n <= leaf_size_) return false;
            mid = median_split(begin, end, axis);
            return true;
        }
        const double area = std::max(double(ri.bounds.surface_area()), 1e-30);
        const double split_cost = kCostTraversal + kCostIntersect * best / area;
        const double leaf_cost = kCostIntersect * blocks(n);
        if (n <= leaf_size_ && !(split_cost < leaf_cost)) return false;
        axis = best_axis;
        auto it = std::partition(p_.begin() + begin, p_.begin() + end, [&](const BuildPrim& q) {
            return binner.bin(q.centroid()[best_axis], best_axis) < best_split;
        });
        mid = uint32_t(it - p_.begin());
        if (mid == begin || mid == end) {  // paranoia
            mid = median_split(begin, end, axis);
            return true;
        }
        // The bins hold exactly the primitives each side received: their union is the
        // same min/max a pass over the children would compute, bit for bit.
        if constexpr (C) {
            for (int i = 0; i < kBins; ++i) {
                RangeInfo& k = kids[i < best_split ? 0 : 1];
                k.bounds.extend(bins.b[best_axis][i]);
                k.cbounds.extend(bins.c[best_axis][i]);
            }
            kids_known = true;
        }
        return true;
    }

    std::vector<BuildPrim>& p_;
    BvhSplit split_;
    uint32_t leaf_size_;
    std::atomic<uint64_t> leaves_{0};
};

}  // namespace

TreeFacts tree_facts(const std::vector<Node>& nodes) {
    TreeFacts f;
    if (nodes.empty()) return f;
    const double root_area = std::max(double(nodes[0].bounds().surface_area()), 1e-30);
    struct Item {
        uint32_t idx, depth;
    };
    std::vector<Item> stack{{0, 1}};
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        const Node& n = nodes[it.idx];
        const double rel = double(n.bounds().surface_area()) / root_area;
        f.depth = std::max(f.depth, it.depth);
        if (n.is_leaf()) {
            ++f.leaves;
            f.max_leaf = std::max(f.max_leaf, n.count());
            f.sah_cost += rel * blocks(n.count()) * kCostIntersect;
        } else {
            f.sah_cost += rel * kCostTraversal;
            stack.push_back({n.offset, it.depth + 1});
            stack.push_back({n.offset + 1, it.depth + 1});
        }
    }
    return f;
}

BinaryTree build_binary(std::span<const GeometryView> geometry, const std::vector<PrimRef>& refs,
                        BvhSplit split, uint32_t leaf_size, int threads) {
    BinaryTree tree;
    const uint32_t n = uint32_t(refs.size());
    if (n == 0) return tree;
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
        std::vector<BuildPrim> prims(n);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1024),
                          [&](const tbb::blocked_range<uint32_t>& r) {
                              for (uint32_t i = r.begin(); i < r.end(); ++i) {
                                  const GeometryView& g = geometry[refs[i].geom];
                                  const Bounds3f b = primitive_bounds(g, refs[i].prim);
                                  prims[i] = {b.lo, i, b.hi, g.type == GeometryType::Spheres ? 1u : 0u};
                              }
                          });
        Builder builder(prims, split, leaf_size);
        std::unique_ptr<BuildNode> root = builder.build(0, n, 1);

        // Flatten depth-first: [node][its two children][left subtree][right subtree].
        tree.nodes.resize(2 * builder.leaves() - 1);
        uint32_t next = 1;
        auto emit = [&](auto&& self, const BuildNode* b, uint32_t slot) -> void {
            Node& out = tree.nodes[slot];
            out.b[0] = b->bounds.lo.x, out.b[1] = b->bounds.lo.y, out.b[2] = b->bounds.lo.z;
            out.b[3] = b->bounds.hi.x, out.b[4] = b->bounds.hi.y, out.b[5] = b->bounds.hi.z;
            if (b->count) {
                out.offset = b->begin;
                out.meta = b->count;
                return;
            }
            const uint32_t c = next;
            next += 2;
            out.offset = c;
            out.meta = uint32_t(b->axis) << 30;
            self(self, b->kid[0].get(), c);
            self(self, b->kid[1].get(), c + 1);
        };
        emit(emit, root.get(), 0);
        tree.order.resize(n);
        for (uint32_t i = 0; i < n; ++i) tree.order[i] = refs[prims[i].id];
    });
    return tree;
}

}  // namespace accel::bvh
