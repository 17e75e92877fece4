// Our own BVH backend ("custom"): binary BVH, midpoint or binned-SAH build, flat
// depth-first 32-byte nodes, pre-gathered leaf primitives; traced through an 8-wide
// collapse of that tree with SSE2 box tests and a templated, ordered traversal.
#include "accel/bvh/bvh.h"

#include <emmintrin.h>  // SSE2: the x86-64 baseline, no -march needed
#include <sys/mman.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <new>
#include <limits>

#include "accel/primitive.h"

namespace accel {
namespace {

// ---------------------------------------------------------------------------------
// Layout
// ---------------------------------------------------------------------------------

/// 32 bytes, so two siblings share one 64-byte cache line (siblings are adjacent and
/// the node array is 32-byte aligned, so a sibling pair never straddles lines).
struct alignas(32) Node {
    float b[6];         ///< lo.x lo.y lo.z hi.x hi.y hi.z: indexable by the ray's sign
    uint32_t offset;    ///< leaf: first primitive; interior: left child (right = +1)
    uint32_t meta;      ///< leaf: primitive count (> 0); interior: 0 | split axis << 30

    static constexpr uint32_t kCountMask = (1u << 30) - 1;
    bool is_leaf() const { return (meta & kCountMask) != 0; }
    uint32_t count() const { return meta & kCountMask; }
    int axis() const { return int(meta >> 30); }
    Bounds3f bounds() const { return {{b[0], b[1], b[2]}, {b[3], b[4], b[5]}}; }
};
static_assert(sizeof(Node) == 32, "two nodes per cache line");

/// Leaf primitive data copied in leaf order, so a leaf reads one contiguous block
/// instead of chasing indices -> positions. Triangles: the three vertices exactly as
/// stored in the scene (copies, not derived values, so the shared intersector in
/// triangle.h runs the same arithmetic as naive). Spheres: v0 = centre, v1.x = radius.
struct PrimData {
    Vec3f v0, v1, v2;
};

/// 8-wide node for traversal, collapsed from the binary tree (the binary tree stays the
/// build output and what inspect_bvh/SAH cost describe). Child boxes in SoA form so one
/// SSE2 slab test covers four of them (multi-branching BVHs: Dammertz et al. 2008,
/// "Shallow Bounding Volume Hierarchies for Fast SIMD Ray Tracing of Incoherent Rays";
/// Wald et al. 2008, "Getting Rid of Packets"). Eight children cost two SSE2 tests per
/// node but halve the levels of a wide tree's dependent cache misses; measured on
/// cow/CBbunny/maxplanck, 8 wide traced 10-15% more rays/s than 4 wide. 256 bytes
/// (four cache lines). Unused lanes hold an inverted box (+inf/-inf) that no ray hits,
/// without NaN: inf - finite stays inf.
constexpr int kWidth = 8;
struct alignas(64) WideNode {
    float b[6][kWidth];      ///< [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z][lane]
    uint32_t child[kWidth];  ///< interior: WideNode index; leaf: kLeaf | first primitive; kEmpty
    uint32_t count[kWidth];  ///< leaf: primitive count; otherwise 0

    static constexpr uint32_t kLeaf = 0x80000000u;
    static constexpr uint32_t kEmpty = 0xFFFFFFFFu;
};
static_assert(sizeof(WideNode) == 32 * kWidth);

/// Allocator for the arrays traversal reads: incoherent rays touch them at random, and
/// with 4 KiB pages a few MiB of nodes overflow the TLB. Large blocks are 2 MiB aligned
/// and advised as transparent huge pages (Linux; a no-op where unsupported). On our
/// loaded 2-core test machine the gain was within measurement noise; it costs nothing.
template <typename T>
struct TraversalAllocator {
    using value_type = T;
    static constexpr size_t kHuge = size_t(2) << 20;
    TraversalAllocator() = default;
    template <typename U>
    TraversalAllocator(const TraversalAllocator<U>&) {}
    T* allocate(size_t n) {
        const size_t bytes = n * sizeof(T);
        const size_t align = bytes >= kHuge / 2 ? kHuge : std::max<size_t>(alignof(T), 16);
        void* p = std::aligned_alloc(align, (bytes + align - 1) / align * align);
        if (!p) throw std::bad_alloc();
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

// ---------------------------------------------------------------------------------
// Ray/box test
// ---------------------------------------------------------------------------------

/// NaN-ignoring min/max: when `a` is NaN the comparison is false and `b` is returned.
/// Callers put the possibly-NaN slab distance first and a never-NaN accumulator second
/// (madmann91/bvh's robust_min/robust_max; with SSE these are exactly minss/maxss).
inline float robust_min(float a, float b) { return a < b ? a : b; }
inline float robust_max(float a, float b) { return a > b ? a : b; }

/// Ize 2013, "Robust BVH Ray Traversal" (JCGT 2(2)): scaling the far slab distance by
/// 1 + 2*gamma(3) makes the box test conservative under float rounding, so rays that
/// graze a box edge (e.g. hit a triangle exactly on its boundary) are not culled.
/// gamma(n) = n*u / (1 - n*u), u = 2^-24 (pbrt's notation).
constexpr float kUnitRoundoff = std::numeric_limits<float>::epsilon() * 0.5f;
constexpr float gamma_n(int n) { return (n * kUnitRoundoff) / (1 - n * kUnitRoundoff); }
constexpr float kFarScale = 1.0f + 2.0f * gamma_n(3);

/// Per-ray constants of the slab test (Williams, Barrus, Morley, Shirley 2005, "An
/// Efficient and Robust Ray-Box Intersection Algorithm"): the inverse direction, and
/// for each axis which of lo/hi is the near plane, chosen by the sign bit so that
/// -0 behaves like a negative direction (1/-0 = -inf) and +0 like a positive one.
struct RayBox {
    float org[3];
    float inv[3];
    int near[3], far[3];

    explicit RayBox(const Ray& r) {
        for (int a = 0; a < 3; ++a) {
            org[a] = r.org[a];
            inv[a] = 1.0f / r.dir[a];
            const bool neg = std::signbit(r.dir[a]);
            near[a] = neg ? a + 3 : a;
            far[a] = neg ? a : a + 3;
        }
    }

    /// True if [t_min, t_max] overlaps the box; `entry` is the entry distance. A
    /// direction component of +-0 with the origin exactly on that slab's plane gives
    /// 0 * inf = NaN, which robust_min/max ignore: that axis then constrains nothing,
    /// which is right because the ray lies in the box's face plane.
    bool hit(const Node& n, float t_min, float t_max, float& entry) const {
        const float tx0 = (n.b[near[0]] - org[0]) * inv[0];
        const float ty0 = (n.b[near[1]] - org[1]) * inv[1];
        const float tz0 = (n.b[near[2]] - org[2]) * inv[2];
        const float tx1 = (n.b[far[0]] - org[0]) * inv[0];
        const float ty1 = (n.b[far[1]] - org[1]) * inv[1];
        const float tz1 = (n.b[far[2]] - org[2]) * inv[2];
        const float t0 = robust_max(tx0, robust_max(ty0, robust_max(tz0, t_min)));
        const float t1f = robust_min(tx1, robust_min(ty1, robust_min(tz1, kInfinity)));
        // Scaling min(far, t_max) rather than far alone also keeps a box whose entry
        // rounds just past the closest hit so far (or past ray.t_max) when a primitive
        // inside it lies exactly at that distance.
        const float t1 = std::min(t1f, t_max) * kFarScale;
        entry = t0;
        return t0 <= t1;
    }
};

// ---------------------------------------------------------------------------------
// Build
// ---------------------------------------------------------------------------------

/// 32 bytes; the build partitions these in place (better locality than an index array).
struct BuildPrim {
    Vec3f lo;
    uint32_t id;  ///< index into the collected PrimRefs
    Vec3f hi;
    uint32_t pad;
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

// Wald 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies": bin the
// centroids into K equal intervals per axis, evaluate the SAH at the K-1 bin borders.
constexpr int kBins = 32;
// Below these sizes the work is too small to be worth a task.
constexpr uint32_t kParallelBuild = 4096;
constexpr uint32_t kParallelBin = 32768;
// SAH constants for both the build decision and the reported cost: C_trav = C_isect = 1.
constexpr double kCostTraversal = 1.0;
constexpr double kCostIntersect = 1.0;
// Traversal stack depth. The build switches to object-median splits (each halving the
// count, so at most 32 more levels for 2^32 primitives) below kMaxFreeDepth, so no
// tree is deeper than kMaxFreeDepth + 32 < kStackSize.
constexpr uint32_t kStackSize = 128;
constexpr uint32_t kMaxFreeDepth = 90;

struct Bins {
    Bounds3f b[3][kBins];
    uint32_t n[3][kBins] = {};
    void merge(const Bins& o) {
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < kBins; ++i) {
                b[a][i].extend(o.b[a][i]);
                n[a][i] += o.n[a][i];
            }
    }
};

/// Maps a centroid coordinate to its bin; the same function classifies for counting
/// and for partitioning, so the partition matches the evaluated split exactly.
struct Binner {
    float lo[3], scale[3];
    explicit Binner(const Bounds3f& cb) {
        for (int a = 0; a < 3; ++a) {
            const float ext = cb.hi[a] - cb.lo[a];
            lo[a] = cb.lo[a];
            scale[a] = ext > 0.0f ? float(kBins) * (1.0f - 1e-6f) / ext : 0.0f;
        }
    }
    int bin(float c, int a) const {
        // Clamp in float before converting: with a denormal extent the scale is inf and
        // (c - lo) * scale can be inf or NaN (0 * inf), whose int conversion is UB.
        const float f = (c - lo[a]) * scale[a];
        if (!(f > 0.0f)) return 0;
        return f < float(kBins - 1) ? int(f) : kBins - 1;
    }
};

class Builder {
public:
    Builder(std::vector<BuildPrim>& prims, BvhSplit split, uint32_t leaf_size)
        : p_(prims), split_(split), leaf_size_(leaf_size) {}

    std::unique_ptr<BuildNode> build(uint32_t begin, uint32_t end, uint32_t depth) {
        auto node = std::make_unique<BuildNode>();
        const uint32_t n = end - begin;
        const RangeInfo ri = range_info(begin, end);
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
            leaf = !sah_split(begin, end, ri, mid, axis);
        }
        if (leaf) {
            node->begin = begin;
            node->count = n;
            leaves_.fetch_add(1, std::memory_order_relaxed);
            return node;
        }
        node->axis = axis;
        if (n >= kParallelBuild) {
            tbb::parallel_invoke([&] { node->kid[0] = build(begin, mid, depth + 1); },
                                 [&] { node->kid[1] = build(mid, end, depth + 1); });
        } else {
            node->kid[0] = build(begin, mid, depth + 1);
            node->kid[1] = build(mid, end, depth + 1);
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

    Bins bin(uint32_t begin, uint32_t end, const Binner& binner) const {
        auto body = [&](const tbb::blocked_range<uint32_t>& r, Bins acc) {
            for (uint32_t i = r.begin(); i < r.end(); ++i) {
                const Vec3f c = p_[i].centroid();
                Bounds3f pb{p_[i].lo, p_[i].hi};
                for (int a = 0; a < 3; ++a) {
                    const int k = binner.bin(c[a], a);
                    acc.b[a][k].extend(pb);
                    ++acc.n[a][k];
                }
            }
            return acc;
        };
        if (end - begin < kParallelBin) return body({begin, end}, Bins{});
        return tbb::parallel_reduce(
            tbb::blocked_range<uint32_t>(begin, end, 8192), Bins{}, body,
            [](Bins a, const Bins& b) {
                a.merge(b);
                return a;
            });
    }

    /// Binned SAH. Returns false for "make a leaf". Above leaf_size a split is forced:
    /// the best binned one, or an object median when all centroids coincide.
    bool sah_split(uint32_t begin, uint32_t end, const RangeInfo& ri, uint32_t& mid,
                   int& axis) {
        const uint32_t n = end - begin;
        const Vec3f cext = ri.cbounds.diagonal();
        if (!(max_component(cext) > 0.0f)) {  // all centroids coincide: no plane separates
            if (n <= leaf_size_) return false;
            mid = begin + n / 2;  // any order is as good as any other here
            return true;
        }
        const Binner binner(ri.cbounds);
        const Bins bins = bin(begin, end, binner);
        double best = std::numeric_limits<double>::infinity();
        int best_axis = -1, best_split = 0;
        for (int a = 0; a < 3; ++a) {
            if (!(cext[a] > 0.0f)) continue;
            // Right-to-left sweep: area and count of everything at or right of bin i.
            float right_area[kBins];
            uint32_t right_count[kBins];
            Bounds3f acc;
            uint32_t cnt = 0;
            for (int i = kBins - 1; i > 0; --i) {
                acc.extend(bins.b[a][i]);
                cnt += bins.n[a][i];
                right_area[i] = acc.surface_area();
                right_count[i] = cnt;
            }
            acc = Bounds3f{};
            cnt = 0;
            for (int i = 1; i < kBins; ++i) {
                acc.extend(bins.b[a][i - 1]);
                cnt += bins.n[a][i - 1];
                if (cnt == 0 || right_count[i] == 0) continue;
                const double cost = double(acc.surface_area()) * cnt +
                                    double(right_area[i]) * right_count[i];
                if (cost < best) {
                    best = cost;
                    best_axis = a;
                    best_split = i;
                }
            }
        }
        if (best_axis < 0) {  // cannot happen with a positive extent; be safe anyway
            if (n <= leaf_size_) return false;
            mid = median_split(begin, end, axis);
            return true;
        }
        const double area = std::max(double(ri.bounds.surface_area()), 1e-30);
        const double split_cost = kCostTraversal + kCostIntersect * best / area;
        const double leaf_cost = kCostIntersect * n;
        if (n <= leaf_size_ && !(split_cost < leaf_cost)) return false;
        axis = best_axis;
        auto it = std::partition(p_.begin() + begin, p_.begin() + end, [&](const BuildPrim& q) {
            return binner.bin(q.centroid()[best_axis], best_axis) < best_split;
        });
        mid = uint32_t(it - p_.begin());
        if (mid == begin || mid == end) mid = median_split(begin, end, axis);  // paranoia
        return true;
    }

    std::vector<BuildPrim>& p_;
    BvhSplit split_;
    uint32_t leaf_size_;
    std::atomic<uint64_t> leaves_{0};
};

// ---------------------------------------------------------------------------------
// Tree facts shared by BuildInfo and inspect_bvh
// ---------------------------------------------------------------------------------

struct TreeFacts {
    uint64_t leaves = 0;
    uint32_t depth = 0;
    uint32_t max_leaf = 0;
    double sah_cost = 0.0;
};

/// Standard SAH cost (Goldsmith & Salmon 1987; MacDonald & Booth 1990):
///   sum_interior SA(n)/SA(root) * C_trav + sum_leaves SA(l)/SA(root) * count(l) * C_isect
/// with C_trav = C_isect = 1, i.e. the expected number of node visits plus primitive
/// tests for a random ray that hits the root box (root itself counts 1).
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
            f.sah_cost += rel * n.count() * kCostIntersect;
        } else {
            f.sah_cost += rel * kCostTraversal;
            stack.push_back({n.offset, it.depth + 1});
            stack.push_back({n.offset + 1, it.depth + 1});
        }
    }
    return f;
}

// ---------------------------------------------------------------------------------
// The accelerator
// ---------------------------------------------------------------------------------

/// Non-templated data, so inspect_bvh can reach it with one dynamic_cast.
class BvhBase : public Accelerator {
public:
    const BuildInfo& info() const override { return info_; }
    Bounds3f bounds() const override {
        return nodes_.empty() ? Bounds3f{} : nodes_[0].bounds();
    }

    std::vector<GeometryView> geometry_;
    std::vector<Node> nodes_;
    std::vector<PrimRef> refs_;    ///< leaf order
    TraversalVector<PrimData> data_;  ///< leaf order, parallel to refs_
    std::vector<uint8_t> sphere_;  ///< leaf order, 1 = sphere; empty if no spheres
    TraversalVector<WideNode> wide_;  ///< traversal tree, collapsed from nodes_
    uint32_t leaf_size_ = 4;
    BuildInfo info_;

protected:
    void build(std::span<const GeometryView> geometry, const AccelOptions& opt);
    uint32_t collapse(uint32_t binary);
};

/// Turns binary node `binary` (interior) into one WideNode by repeatedly opening the
/// interior child with the largest surface area (the one most rays would enter) until
/// kWidth children are gathered; children are emitted depth-first after their parent.
uint32_t BvhBase::collapse(uint32_t binary) {
    uint32_t kids[kWidth] = {nodes_[binary].offset, nodes_[binary].offset + 1};
    int n = 2;
    while (n < kWidth) {
        int best = -1;
        float best_area = -1.0f;
        for (int i = 0; i < n; ++i) {
            const Node& c = nodes_[kids[i]];
            if (!c.is_leaf() && c.bounds().surface_area() > best_area) {
                best = i;
                best_area = c.bounds().surface_area();
            }
        }
        if (best < 0) break;
        const uint32_t open = kids[best];
        kids[best] = nodes_[open].offset;
        kids[n++] = nodes_[open].offset + 1;
    }
    const uint32_t self = uint32_t(wide_.size());
    wide_.emplace_back();
    for (int i = 0; i < kWidth; ++i) {
        WideNode& w = wide_[self];
        if (i >= n) {
            for (int a = 0; a < 3; ++a) w.b[a][i] = kInfinity, w.b[a + 3][i] = -kInfinity;
            w.child[i] = WideNode::kEmpty;
            w.count[i] = 0;
            continue;
        }
        const Node& c = nodes_[kids[i]];
        for (int k = 0; k < 6; ++k) w.b[k][i] = c.b[k];
        if (c.is_leaf()) {
            w.child[i] = WideNode::kLeaf | c.offset;
            w.count[i] = c.count();
        } else {
            w.count[i] = 0;
            const uint32_t ci = collapse(kids[i]);  // may reallocate wide_: no reference kept
            wide_[self].child[i] = ci;
        }
    }
    return self;
}

void BvhBase::build(std::span<const GeometryView> geometry, const AccelOptions& opt) {
    const auto start = std::chrono::steady_clock::now();
    geometry_.assign(geometry.begin(), geometry.end());
    leaf_size_ = std::clamp<uint32_t>(opt.leaf_size, 1u, Node::kCountMask);
    const std::vector<PrimRef> refs = collect_primitives(geometry_, info_.dropped);
    const uint32_t n = uint32_t(refs.size());

    const int threads = opt.build_threads > 0 ? opt.build_threads : tbb::task_arena::automatic;
    tbb::task_arena arena(threads);
    arena.execute([&] {
        std::vector<BuildPrim> prims(n);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1024),
                          [&](const tbb::blocked_range<uint32_t>& r) {
                              for (uint32_t i = r.begin(); i < r.end(); ++i) {
                                  const Bounds3f b =
                                      primitive_bounds(geometry_[refs[i].geom], refs[i].prim);
                                  prims[i] = {b.lo, i, b.hi, 0};
                              }
                          });
        if (n == 0) return;
        Builder builder(prims, opt.split, leaf_size_);
        std::unique_ptr<BuildNode> root = builder.build(0, n, 1);

        // Flatten depth-first: [node][its two children][left subtree][right subtree].
        nodes_.resize(2 * builder.leaves() - 1);
        uint32_t next = 1;
        auto emit = [&](auto&& self, const BuildNode* b, uint32_t slot) -> void {
            Node& out = nodes_[slot];
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

        refs_.resize(n);
        data_.resize(n);
        bool any_sphere = false;
        for (const GeometryView& g : geometry_) any_sphere |= g.type == GeometryType::Spheres && g.num_prims;
        if (any_sphere) sphere_.assign(n, 0);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1024),
                          [&](const tbb::blocked_range<uint32_t>& r) {
                              for (uint32_t i = r.begin(); i < r.end(); ++i) {
                                  const PrimRef ref = refs[prims[i].id];
                                  const GeometryView& g = geometry_[ref.geom];
                                  refs_[i] = ref;
                                  PrimData& d = data_[i];
                                  if (g.type == GeometryType::Triangles) {
                                      triangle_vertices(g, ref.prim, d.v0, d.v1, d.v2);
                                  } else {
                                      d.v0 = sphere_center(g, ref.prim);
                                      d.v1 = Vec3f(sphere_radius(g, ref.prim), 0.0f, 0.0f);
                                      d.v2 = Vec3f(0.0f);
                                      sphere_[i] = 1;
                                  }
                              }
                          });
    });

    if (!nodes_.empty()) {
        if (nodes_[0].is_leaf()) {  // a lone leaf still gets a WideNode around it
            wide_.emplace_back();
            WideNode& w = wide_[0];
            for (int i = 0; i < kWidth; ++i) {
                for (int a = 0; a < 3; ++a)
                    w.b[a][i] = i ? kInfinity : nodes_[0].b[a],
                    w.b[a + 3][i] = i ? -kInfinity : nodes_[0].b[a + 3];
                w.child[i] = i ? WideNode::kEmpty : WideNode::kLeaf | nodes_[0].offset;
                w.count[i] = i ? 0 : nodes_[0].count();
            }
        } else {
            collapse(0);
            wide_.shrink_to_fit();  // growth left up to 2x slack (and 2 MiB rounding)
        }
    }

    const TreeFacts f = tree_facts(nodes_);
    const char* split = opt.split == BvhSplit::Sah ? "sah" : "midpoint";
    const char* test = opt.triangle == TriangleTest::Watertight ? "watertight" : "fast";
    info_.backend = std::string("custom(") + split + ", " + test + ")";
    info_.primitives = n;
    info_.nodes = nodes_.size();
    info_.leaves = f.leaves;
    info_.depth = f.depth;
    info_.sah_cost = f.sah_cost;
    info_.bytes = nodes_.capacity() * sizeof(Node) + wide_.capacity() * sizeof(WideNode) + refs_.capacity() * sizeof(PrimRef) +
                  data_.capacity() * sizeof(PrimData) + sphere_.capacity() +
                  geometry_.capacity() * sizeof(GeometryView);
    info_.counts_nodes = true;
    info_.counts_prims = true;
    info_.build_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Traversal is compiled per (triangle test, any-hit, spheres present); the only
/// virtual call is intersect/occluded itself.
template <TriangleTest Test>
class BvhAccelerator final : public BvhBase {
public:
    BvhAccelerator(std::span<const GeometryView> geometry, const AccelOptions& opt) {
        build(geometry, opt);
    }

    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        Hit h;
        h.t = ray.t_max;
        const uint32_t found = sphere_.empty() ? traverse<false, false>(ray, h.t, h.u, h.v, stats)
                                               : traverse<false, true>(ray, h.t, h.u, h.v, stats);
        if (found == kInvalidId) return false;
        h.geom_id = refs_[found].geom;
        h.prim_id = refs_[found].prim;
        finish_hit(geometry_, ray, h);
        hit = h;
        return true;
    }

    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        float t = ray.t_max, u, v;
        const uint32_t found = sphere_.empty() ? traverse<true, false>(ray, t, u, v, stats)
                                               : traverse<true, true>(ray, t, u, v, stats);
        return found != kInvalidId;
    }

private:
    /// Returns the leaf-order index of the closest (AnyHit: some) primitive hit in
    /// [ray.t_min, t], or kInvalidId; shrinks t as hits are found.
    ///
    /// Counting: nodes_visited counts ray-box tests: the scene (root) box once, then,
    /// for every wide node processed, its real children (2 to kWidth; the SSE test of
    /// unused lanes is not counted). A popped subtree whose entry distance is already
    /// beyond the closest hit is dropped without a box test and not counted.
    /// prim_tests counts every call of the shared primitive intersector.
    template <bool AnyHit, bool HasSpheres>
    uint32_t traverse(const Ray& ray_in, float& t_io, float& u_out, float& v_out,
                      TraceStats& stats) const {
        if (nodes_.empty()) return kInvalidId;
        // Local copies: through references every store to t could alias the ray and the
        // leaf vertices (all floats), forcing reloads in the innermost loop.
        const Ray ray = ray_in;
        float t = t_io, u = 0.0f, v = 0.0f;
        const auto finish = [&](uint32_t found, uint64_t boxes, uint64_t tests) {
            stats.nodes_visited += boxes;
            stats.prim_tests += tests;
            if (found != kInvalidId) t_io = t, u_out = u, v_out = v;
            return found;
        };
        const RayBox rb(ray);
        const float t_min = ray.t_min;
        uint64_t boxes = 1, tests = 0;
        uint32_t found = kInvalidId;

        // One scalar test of the scene box first: cheap, and it turns away every ray
        // that misses the scene (most camera rays on a lone object) before any SIMD work.
        float entry;
        if (!rb.hit(nodes_[0], t_min, t, entry)) return finish(kInvalidId, boxes, tests);
        const WatertightRay wr = Test == TriangleTest::Watertight ? WatertightRay(ray.dir)
                                                                  : WatertightRay();
        const WideNode* wide = wide_.data();
        const PrimData* data = data_.data();

        // Per-ray SSE constants. Near/far plane rows are picked by the sign bit, as in
        // RayBox (Williams et al. 2005), so every lane needs one sub and one mul per plane.
        const __m128 ox = _mm_set1_ps(ray.org.x), oy = _mm_set1_ps(ray.org.y),
                     oz = _mm_set1_ps(ray.org.z);
        const __m128 ix = _mm_set1_ps(rb.inv[0]), iy = _mm_set1_ps(rb.inv[1]),
                     iz = _mm_set1_ps(rb.inv[2]);
        const int nx = rb.near[0], ny = rb.near[1], nz = rb.near[2];
        const int fx = rb.far[0], fy = rb.far[1], fz = rb.far[2];
        const __m128 vt_min = _mm_set1_ps(t_min), vinf = _mm_set1_ps(kInfinity),
                     vscale = _mm_set1_ps(kFarScale);

        struct Entry {
            uint32_t ref, count;
            float t;
        };
        // Each wide level pushes at most kWidth - 1 entries and is no deeper than the binary
        // tree, whose depth the build bounds by kStackSize.
        Entry stack[(kWidth - 1) * kStackSize];
        uint32_t sp = 0;
        uint32_t ref = 0, count = 0;  // start at wide_[0] (interior)
        for (;;) {
            if (ref & WideNode::kLeaf) {
                const uint32_t first = ref & ~WideNode::kLeaf, last = first + count;
                for (uint32_t i = first; i < last; ++i) {
                    ++tests;
                    const PrimData& d = data[i];
                    bool ok;
                    if (HasSpheres && sphere_[i]) {
                        float ts;
                        ok = intersect_sphere(ray, d.v0, d.v1.x, t, ts);
                        if (ok) t = ts, u = v = 0.0f;
                    } else {
                        TriangleHit th;
                        ok = Test == TriangleTest::Watertight
                                 ? intersect_triangle_wt(ray, wr, d.v0, d.v1, d.v2, t, th)
                                 : intersect_triangle_mt(ray, d.v0, d.v1, d.v2, t, th);
                        if (ok) t = th.t, u = th.u, v = th.v;
                    }
                    if (ok) {
                        found = i;
                        if constexpr (AnyHit) return finish(found, boxes, tests);
                    }
                }
            } else {
                const WideNode& n = wide[ref];
                const __m128 vt = _mm_set1_ps(t);
                unsigned mask = 0;
                alignas(16) float dist[kWidth];
                for (int q = 0; q < kWidth; q += 4) {
                    // Slab test of four boxes. _mm_max_ps/_mm_min_ps return their SECOND
                    // operand when either is NaN, so the possibly-NaN slab distance goes
                    // first and the never-NaN accumulator second (= robust_max/min).
                    const __m128 tnx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[nx] + q), ox), ix);
                    const __m128 tny = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[ny] + q), oy), iy);
                    const __m128 tnz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[nz] + q), oz), iz);
                    const __m128 tfx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[fx] + q), ox), ix);
                    const __m128 tfy = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[fy] + q), oy), iy);
                    const __m128 tfz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[fz] + q), oz), iz);
                    const __m128 t0 = _mm_max_ps(tnx, _mm_max_ps(tny, _mm_max_ps(tnz, vt_min)));
                    const __m128 t1f = _mm_min_ps(tfx, _mm_min_ps(tfy, _mm_min_ps(tfz, vinf)));
                    // Ize 2013: conservative far distance (see RayBox::hit).
                    const __m128 t1 = _mm_mul_ps(_mm_min_ps(t1f, vt), vscale);
                    mask |= unsigned(_mm_movemask_ps(_mm_cmple_ps(t0, t1))) << q;
                    _mm_store_ps(dist + q, t0);
                }
                uint32_t valid = 1;
                for (int k = 1; k < kWidth; ++k) valid += n.child[k] != WideNode::kEmpty;
                boxes += valid;
                if (mask) {
                    int i = __builtin_ctz(mask);
                    mask &= mask - 1;
                    if (!mask) {  // one child hit: the common case deep in the tree
                        ref = n.child[i];
                        count = n.count[i];
                        continue;
                    }
                    if constexpr (AnyHit) {
                        // Any hit ends the query, so order buys little: push the rest
                        // unsorted and go on with the first.
                        ref = n.child[i];
                        count = n.count[i];
                        do {
                            i = __builtin_ctz(mask);
                            mask &= mask - 1;
                            stack[sp++] = {n.child[i], n.count[i], dist[i]};
                        } while (mask);
                        continue;
                    }
                    // Several hits: push them farthest first so the nearest is visited
                    // next and the others are likely culled by the shrunk t on pop.
                    // Insertion sort into the stack top (at most 4 items).
                    const uint32_t base = sp;
                    for (;;) {
                        Entry e{n.child[i], n.count[i], dist[i]};
                        uint32_t k = sp++;
                        while (k > base && stack[k - 1].t < e.t) {
                            stack[k] = stack[k - 1];
                            --k;
                        }
                        stack[k] = e;
                        if (!mask) break;
                        i = __builtin_ctz(mask);
                        mask &= mask - 1;
                    }
                    const Entry& nearest = stack[--sp];
                    ref = nearest.ref;
                    count = nearest.count;
                    continue;
                }
            }
            // Pop the next subtree whose box entry is not beyond the closest hit.
            for (;;) {
                if (sp == 0) return finish(found, boxes, tests);
                const Entry& e = stack[--sp];
                if (e.t <= t * kFarScale) {  // same tolerance as the box test
                    ref = e.ref;
                    count = e.count;
                    break;
                }
            }
        }
    }
};

}  // namespace

std::unique_ptr<Accelerator> make_bvh(std::span<const GeometryView> geometry,
                                      const AccelOptions& options) {
    if (options.triangle == TriangleTest::Watertight)
        return std::make_unique<BvhAccelerator<TriangleTest::Watertight>>(geometry, options);
    return std::make_unique<BvhAccelerator<TriangleTest::Fast>>(geometry, options);
}

std::optional<BvhReport> inspect_bvh(const Accelerator& accel) {
    const auto* bvh = dynamic_cast<const BvhBase*>(&accel);
    if (!bvh) return std::nullopt;
    BvhReport r;
    auto fail = [&](bool& flag, std::string msg) {
        flag = false;
        if (r.errors.size() < 16) r.errors.push_back(std::move(msg));
    };
    const auto& nodes = bvh->nodes_;
    const TreeFacts f = tree_facts(nodes);
    r.nodes = nodes.size();
    r.leaves = f.leaves;
    r.depth = f.depth;
    r.max_leaf_size = f.max_leaf;
    r.leaf_size_limit = bvh->leaf_size_;
    r.sah_cost = f.sah_cost;
    r.primitives = bvh->refs_.size();

    // Every leaf-order slot covered by exactly one leaf, and the slots hold exactly the
    // primitives collect_primitives keeps (each once).
    std::vector<uint32_t> covered(bvh->refs_.size(), 0);
    for (uint32_t i = 0; i < nodes.size(); ++i) {
        const Node& n = nodes[i];
        const Bounds3f nb = n.bounds();
        if (n.is_leaf()) {
            if (n.count() > bvh->leaf_size_)
                fail(r.leaf_size_ok, "leaf " + std::to_string(i) + " holds " +
                                         std::to_string(n.count()) + " primitives");
            if (uint64_t(n.offset) + n.count() > covered.size()) {
                fail(r.prims_once, "leaf " + std::to_string(i) + " range out of bounds");
                continue;
            }
            for (uint32_t k = n.offset; k < n.offset + n.count(); ++k) {
                ++covered[k];
                const PrimRef ref = bvh->refs_[k];
                const GeometryView& g = bvh->geometry_[ref.geom];
                if (!nb.contains(primitive_bounds(g, ref.prim)))
                    fail(r.leaves_contain_prims, "leaf " + std::to_string(i) +
                                                     " does not contain prim " +
                                                     std::to_string(ref.prim));
                const PrimData& d = bvh->data_[k];
                bool same;
                if (g.type == GeometryType::Triangles) {
                    Vec3f v0, v1, v2;
                    triangle_vertices(g, ref.prim, v0, v1, v2);
                    same = std::memcmp(&v0, &d.v0, sizeof v0) == 0 &&
                           std::memcmp(&v1, &d.v1, sizeof v1) == 0 &&
                           std::memcmp(&v2, &d.v2, sizeof v2) == 0 &&
                           (bvh->sphere_.empty() || bvh->sphere_[k] == 0);
                } else {
                    same = sphere_center(g, ref.prim) == d.v0 &&
                           sphere_radius(g, ref.prim) == d.v1.x && !bvh->sphere_.empty() &&
                           bvh->sphere_[k] == 1;
                }
                if (!same) fail(r.gathered_ok, "slot " + std::to_string(k) + " data differs");
            }
        } else {
            if (n.offset <= i || uint64_t(n.offset) + 1 >= nodes.size()) {
                fail(r.siblings_adjacent, "node " + std::to_string(i) + " child index bad");
                continue;
            }
            for (int k = 0; k < 2; ++k)
                if (!nb.contains(nodes[n.offset + k].bounds()))
                    fail(r.children_inside, "child " + std::to_string(n.offset + k) +
                                                " of node " + std::to_string(i) +
                                                " sticks out");
        }
    }
    for (size_t k = 0; k < covered.size(); ++k)
        if (covered[k] != 1)
            fail(r.prims_once, "slot " + std::to_string(k) + " in " +
                                   std::to_string(covered[k]) + " leaves");
    uint64_t dropped = 0;
    std::vector<PrimRef> expect = collect_primitives(bvh->geometry_, dropped);
    std::vector<PrimRef> got = bvh->refs_;
    auto less = [](const PrimRef& a, const PrimRef& b) {
        return a.geom != b.geom ? a.geom < b.geom : a.prim < b.prim;
    };
    std::sort(expect.begin(), expect.end(), less);
    std::sort(got.begin(), got.end(), less);
    const bool same_set =
        expect.size() == got.size() &&
        std::equal(expect.begin(), expect.end(), got.begin(), [](const PrimRef& a, const PrimRef& b) {
            return a.geom == b.geom && a.prim == b.prim;
        });
    if (!same_set) fail(r.prims_once, "leaf primitives differ from the collected set");

    // The wide traversal tree: every slot reached through exactly one leaf lane, every
    // lane box inside the box its parent lane gave, leaf lanes containing their prims.
    const auto& wide = bvh->wide_;
    if (nodes.empty() != wide.empty()) fail(r.wide_ok, "wide tree missing or extra");
    if (!wide.empty()) {
        std::vector<uint32_t> wcovered(bvh->refs_.size(), 0);
        struct Item {
            uint32_t idx;
            Bounds3f parent;
        };
        std::vector<Item> stack{{0, nodes[0].bounds()}};
        uint64_t visited = 0;
        while (!stack.empty() && visited <= wide.size()) {
            const Item it = stack.back();
            stack.pop_back();
            ++visited;
            const WideNode& w = wide[it.idx];
            for (int i = 0; i < kWidth; ++i) {
                if (w.child[i] == WideNode::kEmpty) continue;
                const Bounds3f lb{{w.b[0][i], w.b[1][i], w.b[2][i]}, {w.b[3][i], w.b[4][i], w.b[5][i]}};
                if (!it.parent.contains(lb)) fail(r.wide_ok, "wide lane sticks out of its parent");
                if (w.child[i] & WideNode::kLeaf) {
                    const uint32_t first = w.child[i] & ~WideNode::kLeaf;
                    if (w.count[i] == 0 || uint64_t(first) + w.count[i] > wcovered.size()) {
                        fail(r.wide_ok, "wide leaf range bad");
                        continue;
                    }
                    for (uint32_t k = first; k < first + w.count[i]; ++k) {
                        ++wcovered[k];
                        const PrimRef ref = bvh->refs_[k];
                        if (!lb.contains(primitive_bounds(bvh->geometry_[ref.geom], ref.prim)))
                            fail(r.wide_ok, "wide leaf does not contain its primitive");
                    }
                } else if (w.child[i] <= it.idx || w.child[i] >= wide.size()) {
                    fail(r.wide_ok, "wide child index bad");
                } else {
                    stack.push_back({w.child[i], lb});
                }
            }
        }
        if (visited != wide.size()) fail(r.wide_ok, "wide nodes unreachable or shared");
        for (uint32_t c : wcovered)
            if (c != 1) {
                fail(r.wide_ok, "wide tree covers a slot " + std::to_string(c) + " times");
                break;
            }
    }
    return r;
}

}  // namespace accel
