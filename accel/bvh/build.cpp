// The binary builders. Binned SAH: Wald 2007, "On fast Construction of SAH-based
// Bounding Volume Hierarchies" (32 bins per axis, the SAH evaluated at the bin borders,
// leaves priced in SIMD blocks as Embree's builders do); midpoint: the course's split.
// Built in parallel (subtrees of >= 4096 primitives split across tasks, binning of
// >= 32K primitives reduced across tasks) into the same depth-first array at any thread
// count; the 5M-triangle build's profile and the reasons for each step are in
// accel/DECISIONS.md, "parallel build".
#include "accel/bvh/build.h"

#include "accel/bvh/build_bins.h"
#include "accel/out_of_memory.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <type_traits>

#include <emmintrin.h>
#include <sys/mman.h>

namespace accel::bvh {
namespace {

struct BuildPrim {
    Vec3f lo;
    uint32_t id;  ///< index into the collected PrimRefs
    Vec3f hi;
    uint32_t sphere;  ///< 1 for a sphere: leaves hold one type only
    Vec3f centroid() const { return (lo + hi) * 0.5f; }
};
static_assert(std::is_trivially_copyable_v<BuildPrim>);

struct RangeInfo {
    Bounds3f bounds, cbounds;  ///< primitive bounds, centroid bounds
    void merge(const RangeInfo& o) {
        bounds.extend(o.bounds);
        cbounds.extend(o.cbounds);
    }
};

using namespace binned;

// Below this size a node's two halves are built by one task, into one local array
// (a "chunk"); from it on, in parallel (tbb::parallel_invoke).
constexpr uint32_t kParallelBuild = 4096;
// Below this size binning is one loop; from it on, a parallel reduction.
constexpr uint32_t kParallelBin = 32768;
// From this size on a range's bins are all cleared and updated without a test
// (bin_dense); below it only the bins used are written (SparseBins).
constexpr uint32_t kDenseBins = 256;

// The binning and partition loops below use SSE2 (the x86-64 baseline, so no kernel
// dispatch): a box is two 4-float registers, one min and one max per box update instead
// of six scalar ones, as Embree's binner does (Wald 2007 counts the bin update as the
// builder's inner loop). Lane 3 holds the BuildPrim's id/type bits and is ignored;
// it is cleared before arithmetic, since those bits read as denormals.
inline __m128 xyz(__m128 v) { return _mm_and_ps(v, _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1))); }
inline __m128 prim_lo(const BuildPrim& q) { return _mm_loadu_ps(&q.lo.x); }
inline __m128 prim_hi(const BuildPrim& q) { return _mm_loadu_ps(&q.hi.x); }
/// (lo + hi) * 0.5 per axis: the same float operations as BuildPrim::centroid().
inline __m128 prim_centroid(const BuildPrim& q) {
    return _mm_mul_ps(_mm_add_ps(xyz(prim_lo(q)), xyz(prim_hi(q))), _mm_set1_ps(0.5f));
}
/// Bounds3f::extend's min/max, lane for lane: vmin(acc, p) keeps acc on ties and
/// _mm_min_ps(p, acc) returns its second operand on ties, so the bits (signed zeros
/// included) are the scalar code's.
inline __m128 box_min(__m128 acc, __m128 p) { return _mm_min_ps(p, acc); }
inline __m128 box_max(__m128 acc, __m128 p) { return _mm_max_ps(p, acc); }
inline Bounds3f to_bounds(__m128 lo, __m128 hi) {
    alignas(16) float l[4], h[4];
    _mm_store_ps(l, lo);
    _mm_store_ps(h, hi);
    return {{l[0], l[1], l[2]}, {h[0], h[1], h[2]}};
}

/// Binner::bin for the three axes at once, the same arithmetic lane for lane.
struct Binner4 {
    __m128 lo, scale;
    explicit Binner4(const Binner& b)
        : lo(_mm_setr_ps(b.lo[0], b.lo[1], b.lo[2], 0.0f)), scale(_mm_setr_ps(b.scale[0], b.scale[1], b.scale[2], 0.0f)) {}
    __m128i bins(__m128 c) const {
        const __m128 f = _mm_mul_ps(_mm_sub_ps(c, lo), scale);
        const __m128i last = _mm_set1_epi32(kBins - 1);
        const __m128i in = _mm_castps_si128(_mm_cmplt_ps(f, _mm_set1_ps(float(kBins - 1))));
        const __m128i i = _mm_or_si128(_mm_and_si128(in, _mm_cvttps_epi32(f)), _mm_andnot_si128(in, last));
        return _mm_and_si128(i, _mm_castps_si128(_mm_cmpgt_ps(f, _mm_setzero_ps())));  // !(f > 0): bin 0
    }
    void bins(__m128 c, int (&k)[4]) const { _mm_storeu_si128(reinterpret_cast<__m128i*>(k), bins(c)); }
};

/// A box without default initialisers: a bin's box is written when its first primitive
/// arrives, so a small node never clears the 3 x 32 boxes it does not touch.
struct Box {
    __m128 lo, hi;
};

/// Centroid bins (Wald 2007) that only pay for the bins they use. A node of 8 primitives
/// fills at most 8 of the 32 bins per axis, and clearing and sweeping all 96 cost more
/// than binning the primitives: near the leaves, where most nodes are, that fixed cost
/// was most of the build (profile of the 5M sphere; accel/DECISIONS.md, "parallel build").
/// `used[a]` has bit k set when bin k of axis a holds a primitive; the sweep visits only
/// those bins and picks exactly the split the dense 32-bin sweep picks (sparse_sweep).
struct SparseBins {
    static_assert(kBins <= 32, "one bit per bin");
    uint32_t used[3];
    uint32_t n[3][kBins];
    Box b[3][kBins];

    void clear() { used[0] = used[1] = used[2] = 0; }
    void add(int a, int k, __m128 lo, __m128 hi, uint32_t count = 1) {
        const uint32_t bit = 1u << k;
        Box& box = b[a][k];
        if (used[a] & bit) {
            box.lo = box_min(box.lo, lo);
            box.hi = box_max(box.hi, hi);
            n[a][k] += count;
        } else {
            used[a] |= bit;
            box.lo = lo;
            box.hi = hi;
            n[a][k] = count;
        }
    }
    void merge(const SparseBins& o) {
        for (int a = 0; a < 3; ++a)
            for (uint32_t m = o.used[a]; m; m &= m - 1) {
                const int k = std::countr_zero(m);
                add(a, k, o.b[a][k].lo, o.b[a][k].hi, o.n[a][k]);
            }
    }
};

/// The split found by the sweep over SparseBins.
struct SparseSweep {
    double cost = std::numeric_limits<double>::infinity();
    int axis = -1, split = 0;  ///< bins < split go left
};

/// binned::sweep over the used bins only. Between two used bins p < q every border
/// p+1..q puts the same primitives on each side, so the dense sweep's costs there are
/// equal and its strict `<` keeps the first, p+1; the borders are visited in the same
/// order, axis by axis, so the choice (axis, split) is the dense sweep's exactly. Unions
/// are taken in bin order, as the dense sweep's (skipping an empty bin changes no bit).
inline void sparse_sweep(const SparseBins& bins, const bool (&usable)[3], SparseSweep& best) {
    for (int a = 0; a < 3; ++a) {
        if (!usable[a] || std::popcount(bins.used[a]) < 2) continue;
        int idx[kBins];
        int k = 0;
        for (uint32_t m = bins.used[a]; m; m &= m - 1) idx[k++] = std::countr_zero(m);
        float right_area[kBins];
        uint32_t right_n[kBins];
        __m128 lo = bins.b[a][idx[k - 1]].lo, hi = bins.b[a][idx[k - 1]].hi;
        uint32_t cnt = bins.n[a][idx[k - 1]];
        right_area[k - 1] = to_bounds(lo, hi).surface_area();
        right_n[k - 1] = cnt;
        for (int j = k - 2; j > 0; --j) {
            const Box& box = bins.b[a][idx[j]];
            lo = box_min(lo, box.lo), hi = box_max(hi, box.hi);
            cnt += bins.n[a][idx[j]];
            right_area[j] = to_bounds(lo, hi).surface_area();
            right_n[j] = cnt;
        }
        lo = bins.b[a][idx[0]].lo, hi = bins.b[a][idx[0]].hi;
        cnt = 0;
        for (int j = 1; j < k; ++j) {
            if (j > 1) {
                const Box& box = bins.b[a][idx[j - 1]];
                lo = box_min(lo, box.lo), hi = box_max(hi, box.hi);
            }
            cnt += bins.n[a][idx[j - 1]];
            const double cost =
                double(to_bounds(lo, hi).surface_area()) * blocks(cnt) + double(right_area[j]) * blocks(right_n[j]);
            if (cost < best.cost) best.cost = cost, best.axis = a, best.split = idx[j - 1] + 1;
        }
    }
}

/// Memory that is written once, by parallel tasks, right after it is allocated: no
/// clearing pass (std::vector would clear it on one thread first), and advised as
/// transparent huge pages, since page faults are most of the cost of touching fresh
/// memory on this machine (perf: clear_page and the fault path, ~20 % of the build).
template <typename T>
struct FreshArray {
    static_assert(std::is_trivially_copyable_v<T>);
    T* p = nullptr;
    size_t bytes = 0;
    explicit FreshArray(size_t n) {
        constexpr size_t kHuge = size_t(2) << 20;
        bytes = std::max<size_t>(n * sizeof(T), 1);
        const size_t align = bytes >= kHuge ? kHuge : 64;
        bytes = (bytes + align - 1) / align * align;
        p = static_cast<T*>(std::aligned_alloc(align, bytes));
        if (!p) throw_out_of_memory(bytes);
#ifdef MADV_HUGEPAGE
        if (align == kHuge) madvise(p, bytes, MADV_HUGEPAGE);
#endif
    }
    ~FreshArray() { std::free(p); }
    FreshArray(const FreshArray&) = delete;
    FreshArray& operator=(const FreshArray&) = delete;
    T& operator[](size_t i) { return p[i]; }
};

/// Advises the whole 2 MiB pages inside [p, p + bytes) as transparent huge pages, for a
/// std::vector's storage that is about to be written for the first time.
void advise_huge(void* p, size_t bytes) {
#ifdef MADV_HUGEPAGE
    constexpr uintptr_t kHuge = uintptr_t(2) << 20;
    const uintptr_t lo = (reinterpret_cast<uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
    const uintptr_t hi = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(kHuge - 1);
    if (hi > lo) madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);
#else
    (void)p, (void)bytes;
#endif
}

/// One task's subtree: its nodes in the final depth-first order, indexed locally
/// (p[0] is the subtree's root; interior offsets are local indices).
struct Chunk {
    Node* p = nullptr;
    uint32_t size = 0;
};

/// Scratch for the chunks, per thread: large huge-page blocks cut into chunks in turn.
/// A chunk then costs no allocation of its own, and mostly lands on pages that earlier
/// chunks already faulted in (a std::vector per chunk was one mmap and ~60 fresh 4 KiB
/// pages each). A chunk is built by one task that runs no other task meanwhile (no TBB
/// call below kParallelBuild), so the thread's block is its alone while it builds.
class ChunkArena {
public:
    /// `nodes`: the most the whole tree can have (2n - 1 for n primitives). A small
    /// tree's block is cut to it: a block of its own size, not a huge page faulted in
    /// (2 MiB cleared by the kernel; most of a 32-triangle tree's build).
    explicit ChunkArena(size_t nodes) : block_nodes_(std::min(kBlockNodes, std::max<size_t>(nodes, 1))) {}
    /// Room for `n` nodes at the calling thread's cursor.
    Node* reserve(size_t n) {
        Local& t = local_.local();
        if (t.left < n) {
            const size_t cap = std::max(n, block_nodes_);
            t.blocks.push_back(std::make_unique<FreshArray<Node>>(cap));
            t.cur = t.blocks.back()->p;
            t.left = cap;
        }
        return t.cur;
    }
    /// Keeps the first `used` nodes of the last reserve().
    void commit(size_t used) {
        Local& t = local_.local();
        t.cur += used;
        t.left -= used;
    }

private:
    static constexpr size_t kBlockNodes = size_t(8) << 20 >> 5;  // 8 MiB of 32-byte nodes
    struct Local {
        std::vector<std::unique_ptr<FreshArray<Node>>> blocks;
        Node* cur = nullptr;
        size_t left = 0;
    };
    size_t block_nodes_;
    tbb::enumerable_thread_specific<Local> local_;
};

/// A node of the tree's top, above the chunks: big enough that its halves were built in
/// parallel. Each half is another top node or a chunk; flatten() joins them.
struct TopNode;
struct Part {
    std::unique_ptr<TopNode> top;
    Chunk chunk;  ///< when !top
};
struct TopNode {
    Node node;
    Part kid[2];
};

void set_box(Node& out, const Bounds3f& b) {
    out.b[0] = b.lo.x, out.b[1] = b.lo.y, out.b[2] = b.lo.z;
    out.b[3] = b.hi.x, out.b[4] = b.hi.y, out.b[5] = b.hi.z;
}

class Builder {
public:
    Builder(BuildPrim* prims, BvhSplit split, uint32_t leaf_size, ChunkArena& arena)
        : p_(prims), split_(split), leaf_size_(leaf_size), arena_(arena) {}

    /// Builds [begin, end). `known`: the range's bounds if the parent already has them.
    Part build(uint32_t begin, uint32_t end, uint32_t depth, const RangeInfo* known) {
        Part part;
        const uint32_t n = end - begin;
        if (n < kParallelBuild) {
            // At most 2n - 1 nodes: reserved at once, the unused rest given back.
            part.chunk.p = arena_.reserve(2 * size_t(n) - 1);
            part.chunk.size = 1;
            build_serial(begin, end, depth, known, part.chunk, 0);
            arena_.commit(part.chunk.size);
            return part;
        }
        Node node;
        Decision d = decide(begin, end, depth, known, node);
        if (d.leaf) {
            part.chunk.p = arena_.reserve(1);
            part.chunk.p[0] = node;
            part.chunk.size = 1;
            arena_.commit(1);
            return part;
        }
        part.top = std::make_unique<TopNode>();
        part.top->node = node;
        tbb::parallel_invoke(
            [&] { part.top->kid[0] = build(begin, d.mid, depth + 1, d.kids_known ? &d.kids[0] : nullptr); },
            [&] { part.top->kid[1] = build(d.mid, end, depth + 1, d.kids_known ? &d.kids[1] : nullptr); });
        return part;
    }

private:
    struct Decision {
        bool leaf = false;
        uint32_t mid = 0;
        bool kids_known = false;
        RangeInfo kids[2];
    };

    /// Writes the node for [begin, end) to `node` (box; leaf range or split axis; the
    /// interior child offset is the caller's) and says where it splits.
    Decision decide(uint32_t begin, uint32_t end, uint32_t depth, const RangeInfo* known, Node& node) {
        Decision d;
        const uint32_t n = end - begin;
        const RangeInfo ri = known ? *known : range_info(begin, end);
        set_box(node, ri.bounds);
        d.mid = begin;
        int axis = max_dimension(ri.cbounds.diagonal());
        if (n == 1) {
            d.leaf = true;
        } else if (depth >= kMaxFreeDepth) {
            d.leaf = n <= leaf_size_;
            if (!d.leaf) d.mid = median_split(begin, end, axis);
        } else if (split_ == BvhSplit::Midpoint) {
            d.leaf = n <= leaf_size_;
            if (!d.leaf) d.mid = midpoint_split(begin, end, ri.cbounds, axis);
        } else if (n <= leaf_size_ && kCostIntersect * blocks(n) <= kCostTraversal) {
            // The SAH cannot split this range: any split costs C_trav plus something
            // non-negative, at least the one block's test the leaf costs. Every path of
            // sah_split ends in a leaf here; skipping it skips binning the ~1.3M ranges
            // of <= 4 primitives of the 5M sphere, which are most of its nodes.
            d.leaf = true;
        } else {
            d.leaf = !sah_split(begin, end, ri, d.mid, axis, d.kids, d.kids_known);
        }
        if (d.leaf) {
            // Leaves hold one primitive type, so each maps to one kind of SIMD block;
            // a mixed range is split by type instead (rare: spheres beside meshes).
            const BuildPrim* first_sphere =
                std::partition(p_ + begin, p_ + end, [](const BuildPrim& q) { return q.sphere == 0; });
            const uint32_t tmid = uint32_t(first_sphere - p_);
            if (tmid != begin && tmid != end) {
                d.leaf = false;
                d.mid = tmid;
                d.kids_known = false;
            }
        }
        if (d.leaf) {
            node.offset = begin;
            node.meta = n;
        } else {
            node.meta = uint32_t(axis) << 30;
        }
        return d;
    }

    /// One task's subtree, written depth-first into `out` from `slot`:
    /// [node][its two children][left subtree][right subtree], as the traversal and
    /// tree_facts read it (children adjacent, so one offset names both).
    void build_serial(uint32_t begin, uint32_t end, uint32_t depth, const RangeInfo* known, Chunk& out,
                      uint32_t slot) {
        Node node;
        Decision d = decide(begin, end, depth, known, node);
        if (!d.leaf) {
            node.offset = out.size;
            out.size += 2;
        }
        out.p[slot] = node;
        if (d.leaf) return;
        const uint32_t c = node.offset;
        build_serial(begin, d.mid, depth + 1, d.kids_known ? &d.kids[0] : nullptr, out, c);
        build_serial(d.mid, end, depth + 1, d.kids_known ? &d.kids[1] : nullptr, out, c + 1);
    }

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
        std::nth_element(p_ + begin, p_ + mid, p_ + end, [axis](const BuildPrim& a, const BuildPrim& b) {
            return a.centroid()[axis] < b.centroid()[axis];
        });
        return mid;
    }

    /// The course's method: midpoint of the centroid bounds on their largest axis.
    uint32_t midpoint_split(uint32_t begin, uint32_t end, const Bounds3f& cb, int axis) {
        const float pivot = cb.center()[axis];
        BuildPrim* it =
            std::partition(p_ + begin, p_ + end, [&](const BuildPrim& q) { return q.centroid()[axis] < pivot; });
        const uint32_t mid = uint32_t(it - p_);
        if (mid == begin || mid == end) return median_split(begin, end, axis);
        return mid;
    }

    /// Small ranges: each bin written when first used (SparseBins).
    void bin_sparse(uint32_t begin, uint32_t end, const Binner4& binner, SparseBins& acc) const {
        for (uint32_t i = begin; i < end; ++i) {
            const BuildPrim& q = p_[i];
            const __m128 lo = prim_lo(q), hi = prim_hi(q);
            int k[4];
            binner.bins(_mm_mul_ps(_mm_add_ps(xyz(lo), xyz(hi)), _mm_set1_ps(0.5f)), k);
            for (int a = 0; a < 3; ++a) acc.add(a, k[a], lo, hi);
        }
    }

    /// Larger ranges: all bins cleared first, then updated without a test, alternating
    /// two sets of bins. Neighbouring primitives of a mesh mostly fall into the same
    /// bins, and one set would make every update wait for the previous one's store
    /// (the interleaving Embree's binner uses too). The sets are then merged into `acc`.
    void bin_dense(uint32_t begin, uint32_t end, const Binner4& binner, SparseBins& acc) const {
        struct alignas(16) Dense {
            __m128 lo[3][kBins], hi[3][kBins];
            uint32_t n[3][kBins];
        };
        Dense d[2];
        const __m128 inf = _mm_set1_ps(kInfinity), ninf = _mm_set1_ps(-kInfinity);
        for (Dense& x : d)
            for (int a = 0; a < 3; ++a)
                for (int k = 0; k < kBins; ++k) x.lo[a][k] = inf, x.hi[a][k] = ninf, x.n[a][k] = 0;
        auto one = [&](Dense& x, const BuildPrim& q) {
            const __m128 lo = prim_lo(q), hi = prim_hi(q);
            int k[4];
            binner.bins(_mm_mul_ps(_mm_add_ps(xyz(lo), xyz(hi)), _mm_set1_ps(0.5f)), k);
            for (int a = 0; a < 3; ++a) {
                x.lo[a][k[a]] = box_min(x.lo[a][k[a]], lo);
                x.hi[a][k[a]] = box_max(x.hi[a][k[a]], hi);
                ++x.n[a][k[a]];
            }
        };
        uint32_t i = begin;
        for (; i + 1 < end; i += 2) {
            one(d[0], p_[i]);
            one(d[1], p_[i + 1]);
        }
        if (i < end) one(d[0], p_[i]);
        for (int a = 0; a < 3; ++a)
            for (int k = 0; k < kBins; ++k) {
                const uint32_t cnt = d[0].n[a][k] + d[1].n[a][k];
                if (cnt) acc.add(a, k, box_min(d[0].lo[a][k], d[1].lo[a][k]), box_max(d[0].hi[a][k], d[1].hi[a][k]), cnt);
            }
    }

    void bin_range(uint32_t begin, uint32_t end, const Binner4& binner, SparseBins& acc) const {
        if (end - begin >= kDenseBins)
            bin_dense(begin, end, binner, acc);
        else
            bin_sparse(begin, end, binner, acc);
    }

    /// Hoare partition, the very permutation std::partition (libstdc++'s bidirectional
    /// loop) makes, classifying each primitive once; on the way it gathers each side's
    /// centroid bounds, which the children then need no pass of their own for.
    template <typename Left>
    uint32_t partition(uint32_t begin, uint32_t end, Left left, Bounds3f (&cb)[2]) {
        const __m128 inf = _mm_set1_ps(kInfinity);
        __m128 lo[2] = {inf, inf}, hi[2] = {_mm_sub_ps(_mm_setzero_ps(), inf), _mm_sub_ps(_mm_setzero_ps(), inf)};
        auto side = [&](const BuildPrim& q) {
            const __m128 c = prim_centroid(q);
            const int s = left(c) ? 0 : 1;
            lo[s] = box_min(lo[s], c), hi[s] = box_max(hi[s], c);
            return s;
        };
        BuildPrim* first = p_ + begin;
        BuildPrim* last = p_ + end;
        uint32_t mid;
        while (true) {
            while (first != last && side(*first) == 0) ++first;
            if (first == last) break;
            --last;
            while (first != last && side(*last) == 1) --last;
            if (first == last) break;
            std::swap(*first, *last);
            ++first;
        }
        mid = uint32_t(first - p_);
        cb[0] = to_bounds(lo[0], hi[0]);
        cb[1] = to_bounds(lo[1], hi[1]);
        return mid;
    }

    /// Binned SAH. Returns false for "make a leaf". Above leaf_size a split is forced:
    /// the best binned one, or an object median when all centroids coincide.
    /// On a binned split also returns the children's RangeInfo: boxes from the bins,
    /// centroid bounds from the partition.
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
        const Binner4 binner4(binner);
        SparseBins bins;
        if (n < kParallelBin) {
            bins.clear();
            bin_range(begin, end, binner4, bins);
        } else {
            SparseBins none{};  // the reduction's identity is copied: no indeterminate bytes
            none.clear();
            bins = tbb::parallel_reduce(
                tbb::blocked_range<uint32_t>(begin, end, 8192), none,
                [&](const tbb::blocked_range<uint32_t>& r, SparseBins acc) {
                    bin_range(r.begin(), r.end(), binner4, acc);
                    return acc;
                },
                [](SparseBins a, const SparseBins& b) {
                    a.merge(b);
                    return a;
                });
        }
        const bool usable[3] = {cext[0] > 0.0f, cext[1] > 0.0f, cext[2] > 0.0f};
        SparseSweep sw;
        sparse_sweep(bins, usable, sw);
        if (sw.axis < 0) {  // cannot happen with a positive extent; be safe anyway
            if (n <= leaf_size_) return false;
            mid = median_split(begin, end, axis);
            return true;
        }
        const double area = std::max(double(ri.bounds.surface_area()), 1e-30);
        const double split_cost = kCostTraversal + kCostIntersect * sw.cost / area;
        const double leaf_cost = kCostIntersect * blocks(n);
        if (n <= leaf_size_ && !(split_cost < leaf_cost)) return false;
        axis = sw.axis;
        const int best_axis = sw.axis, best_split = sw.split;
        Bounds3f cb[2];
        // Binner4 computes the three axes' bins as Binner::bin does: the side is the
        // bin on best_axis against best_split, as counted.
        const __m128i split4 = _mm_set1_epi32(best_split);
        mid = partition(
            begin, end,
            [&](__m128 c) {
                const int lt = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmplt_epi32(binner4.bins(c), split4)));
                return (lt >> best_axis) & 1;
            },
            cb);
        if (mid == begin || mid == end) {  // paranoia
            mid = median_split(begin, end, axis);
            return true;
        }
        // The bins hold exactly the primitives each side received: their union is the
        // same min/max a pass over the children would compute, bit for bit.
        for (uint32_t m = bins.used[best_axis]; m; m &= m - 1) {
            const int k = std::countr_zero(m);
            const Box& box = bins.b[best_axis][k];
            kids[k < best_split ? 0 : 1].bounds.extend(to_bounds(box.lo, box.hi));
        }
        kids[0].cbounds = cb[0];
        kids[1].cbounds = cb[1];
        kids_known = true;
        return true;
    }

    BuildPrim* p_;
    BvhSplit split_;
    uint32_t leaf_size_;
    ChunkArena& arena_;
};

/// Joins the top nodes and the chunks into one depth-first array, as if one task had
/// built it all: the layout is the same at any thread count. Walks the top (a few
/// thousand nodes) to give each chunk its place, then copies the chunks in parallel,
/// shifting their local child offsets.
void flatten(const Part& root, std::vector<Node>& out) {
    struct Job {
        const Chunk* chunk;
        uint32_t slot, base;  ///< chunk[0] goes to slot, chunk[j >= 1] to base + j - 1
    };
    std::vector<Job> jobs;
    std::vector<std::pair<Node, uint32_t>> tops;  ///< top node (offset set), its slot
    uint32_t next = 1;
    auto place = [&](auto&& self, const Part& part, uint32_t slot) -> void {
        if (!part.top) {
            jobs.push_back({&part.chunk, slot, next});
            next += part.chunk.size - 1;
            return;
        }
        const uint32_t c = next;
        next += 2;
        Node node = part.top->node;
        node.offset = c;
        tops.push_back({node, slot});
        self(self, part.top->kid[0], c);
        self(self, part.top->kid[1], c + 1);
    };
    place(place, root, 0);
    out.reserve(next);
    prepare_fresh(out.data(), size_t(next) * sizeof(Node));
    out.resize(next);
    for (const auto& [node, slot] : tops) out[slot] = node;
    tbb::parallel_for(size_t(0), jobs.size(), [&](size_t i) {
        const Job& j = jobs[i];
        const Chunk& ch = *j.chunk;
        auto shift = [&](Node nd) {
            if (!nd.is_leaf()) nd.offset = j.base + nd.offset - 1;
            return nd;
        };
        out[j.slot] = shift(ch.p[0]);
        for (uint32_t k = 1; k < ch.size; ++k) out[j.base + k - 1] = shift(ch.p[k]);
    });
}

}  // namespace

void prepare_fresh(void* p, size_t bytes) {
    advise_huge(p, bytes);
    constexpr size_t kPage = 4096;
    volatile char* c = static_cast<char*>(p);
    const size_t pages = (bytes + kPage - 1) / kPage;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, pages, 512), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t i = r.begin(); i < r.end(); ++i) c[i * kPage] = 0;
    });
}

TreeFacts tree_facts(const std::vector<Node>& nodes) {
    TreeFacts f;
    if (nodes.empty()) return f;
    const double root_area = std::max(double(nodes[0].bounds().surface_area()), 1e-30);
    // Children always follow their parent (depth-first layout, offset > index), so one
    // pass in index order meets every parent before its children: depths without a
    // stack, the nodes read in memory order (a stack walk of the 5M sphere's 2.6M nodes
    // was ~75 ms, serial). A malformed child index (inspect_bvh reports those) is skipped.
    std::vector<uint16_t> depth(nodes.size(), 0);
    depth[0] = 1;
    for (size_t i = 0; i < nodes.size(); ++i) {
        const Node& n = nodes[i];
        const double rel = double(n.bounds().surface_area()) / root_area;
        f.depth = std::max<uint32_t>(f.depth, depth[i]);
        if (n.is_leaf()) {
            ++f.leaves;
            f.max_leaf = std::max(f.max_leaf, n.count());
            f.sah_cost += rel * blocks(n.count()) * kCostIntersect;
        } else {
            f.sah_cost += rel * kCostTraversal;
            if (n.offset > i && uint64_t(n.offset) + 1 < nodes.size())
                depth[n.offset] = depth[n.offset + 1] = uint16_t(depth[i] + 1);
        }
    }
    return f;
}

namespace {
/// The binned build over n primitives whose BuildPrim `fill(i)` makes; order[i] is
/// `ref(id)` of the primitive placed at slot i.
template <class Fill, class Ref>
BinaryTree build_prims(uint32_t n, BvhSplit split, uint32_t leaf_size, int threads, const Fill& fill, const Ref& ref) {
    BinaryTree tree;
    if (n == 0) return tree;
    const auto build = [&] {
        FreshArray<BuildPrim> prims(n);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1024),
                          [&](const tbb::blocked_range<uint32_t>& r) {
                              for (uint32_t i = r.begin(); i < r.end(); ++i) prims[i] = fill(i);
                          });
        ChunkArena arena(2 * size_t(n));
        Builder builder(prims.p, split, leaf_size, arena);
        Part root = builder.build(0, n, 1, nullptr);
        flatten(root, tree.nodes);
        tree.order.reserve(n);
        prepare_fresh(tree.order.data(), size_t(n) * sizeof(PrimRef));
        tree.order.resize(n);
        tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 16384), [&](const tbb::blocked_range<uint32_t>& r) {
            for (uint32_t i = r.begin(); i < r.end(); ++i) tree.order[i] = ref(prims[i].id);
        });
        root = Part{};
    };
    // A small tree's build forks no task (Builder::build below kParallelBuild) and its
    // loops are a chunk or four: an arena of its own would cost more than the build, so it
    // runs in the caller's. Measured on 256 prototypes of 32 triangles each (a two-level
    // scene's bottom trees, instanced.cpp): 117 us per tree with their two arenas
    // (accel/DECISIONS.md, "small builds inline").
    if (n < kParallelBuild) {
        build();
    } else {
        tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
        arena.execute(build);
    }
    return tree;
}
}  // namespace

BinaryTree build_binary(std::span<const GeometryView> geometry, const std::vector<PrimRef>& refs,
                        BvhSplit split, uint32_t leaf_size, int threads) {
    return build_prims(
        uint32_t(refs.size()), split, leaf_size, threads,
        [&](uint32_t i) {
            const GeometryView& g = geometry[refs[i].geom];
            const Bounds3f b = primitive_bounds(g, refs[i].prim);
            return BuildPrim{b.lo, i, b.hi, g.type == GeometryType::Spheres ? 1u : 0u};
        },
        [&](uint32_t id) { return refs[id]; });
}

BinaryTree build_boxes(uint32_t n, const std::function<Bounds3f(uint32_t)>& box, BvhSplit split, uint32_t leaf_size,
                       int threads) {
    return build_prims(
        n, split, leaf_size, threads,
        [&](uint32_t i) {
            const Bounds3f b = box(i);
            return BuildPrim{b.lo, i, b.hi, 0u};
        },
        [](uint32_t id) { return PrimRef{0, id}; });
}

}  // namespace accel::bvh
