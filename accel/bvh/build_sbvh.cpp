// SBVH: Stich, Friedrich, Dietrich 2009, "Spatial Splits in Bounding Volume Hierarchies"
// (HPG 2009). Every node weighs the best binned object split (Wald 2007, as build.cpp)
// against the best spatial split: the node box is cut into kBins slabs per axis, each
// reference is clipped into every slab it crosses ("chopped" bounds of the triangle
// clipped to the plane, intersected with the reference's box, not the box cut in two),
// and the SAH counts references entering left of a border and leaving right of it.
// Spatial splits are only tried where the object split's two children overlap by more
// than alpha of the root's area (section 4.4), and straddling references are kept on
// one side when that is cheaper ("reference unsplitting", section 4.5). The duplicates
// are bounded by a budget split between children in proportion to their references
// (as Embree's builders do), which keeps the tree the same at any thread count.
#include <tbb/blocked_range.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <utility>

#include "accel/bvh/build.h"
#include "accel/bvh/build_bins.h"
#include "accel/primitive.h"

namespace accel::bvh {
namespace {

using namespace binned;

constexpr uint32_t kParallelBuild = 4096;
constexpr uint32_t kParallelBin = 16384;

/// One reference: (the part of) collected primitive `id` inside box `b`.
struct Ref {
    Bounds3f b;
    uint32_t id;
    Vec3f centroid() const { return b.center(); }
};

struct SNode {
    Bounds3f bounds;
    std::vector<uint32_t> prims;  ///< leaf: collected-primitive ids (interior: empty)
    int axis = 0;
    std::unique_ptr<SNode> kid[2];
};

/// The float one step below f (f not NaN; -inf stays). Inline bit arithmetic: libm's
/// nextafterf, a call per clipped bound, was 8 % of an SBVH build's instructions.
inline float step_down(float f) {
    if (f == -kInfinity) return f;
    if (f == 0.0f) return -std::numeric_limits<float>::denorm_min();
    const uint32_t b = std::bit_cast<uint32_t>(f);
    return std::bit_cast<float>(f > 0.0f ? b - 1 : b + 1);
}
inline float step_up(float f) { return -step_down(-f); }

inline float round_down(double d) {
    const float f = float(d);
    return double(f) <= d ? f : step_down(f);
}
inline float round_up(double d) {
    const float f = float(d);
    return double(f) >= d ? f : step_up(f);
}

struct Spatial {
    Bounds3f b[3][kBins];
    uint32_t enter[3][kBins] = {}, exit[3][kBins] = {};
    void merge(const Spatial& o) {
        for (int a = 0; a < 3; ++a)
            for (int i = 0; i < kBins; ++i) {
                b[a][i].extend(o.b[a][i]);
                enter[a][i] += o.enter[a][i];
                exit[a][i] += o.exit[a][i];
            }
    }
};

/// Equal slabs over the node box (not the centroids): spatial bins.
struct Slabs {
    float lo[3], width[3], scale[3];
    explicit Slabs(const Bounds3f& nb) {
        for (int a = 0; a < 3; ++a) {
            const float ext = nb.hi[a] - nb.lo[a];
            lo[a] = nb.lo[a];
            width[a] = ext / float(kBins);
            scale[a] = ext > 0.0f ? float(kBins) * (1.0f - 1e-6f) / ext : 0.0f;
        }
    }
    int bin(float c, int a) const {
        const float f = (c - lo[a]) * scale[a];
        if (!(f > 0.0f)) return 0;
        return f < float(kBins - 1) ? int(f) : kBins - 1;
    }
    float plane(int i, int a) const { return lo[a] + float(i) * width[a]; }
};

class SpatialBuilder {
public:
    SpatialBuilder(std::span<const GeometryView> g, const std::vector<PrimRef>& refs, uint32_t leaf_size,
                   double root_area)
        : g_(g), refs_(refs), leaf_size_(leaf_size), min_overlap_(kSbvhAlpha * root_area) {}

    std::unique_ptr<SNode> build(std::vector<Ref> r, uint32_t depth, uint64_t budget) {
        auto node = std::make_unique<SNode>();
        const uint32_t n = uint32_t(r.size());
        Bounds3f bounds, cbounds;
        for (const Ref& x : r) bounds.extend(x.b), cbounds.extend(x.centroid());
        node->bounds = bounds;

        std::vector<Ref> left, right;
        int axis = max_dimension(cbounds.diagonal());
        bool leaf = n == 1;
        if (!leaf && depth >= kMaxFreeDepth) {
            leaf = n <= leaf_size_;
            if (!leaf) median(r, axis, left, right);
        } else if (!leaf) {
            leaf = !split(r, bounds, cbounds, budget, axis, left, right);
        }
        if (leaf) {
            // One primitive type per leaf, as build.cpp: split a mixed range by type.
            auto sphere = [&](const Ref& x) { return g_[refs_[x.id].geom].type == GeometryType::Spheres; };
            const auto first_sphere = std::stable_partition(r.begin(), r.end(), [&](const Ref& x) { return !sphere(x); });
            if (first_sphere != r.begin() && first_sphere != r.end()) {
                leaf = false;
                left.assign(r.begin(), first_sphere);
                right.assign(first_sphere, r.end());
            }
        }
        if (leaf) {
            node->prims.reserve(n);
            for (const Ref& x : r) node->prims.push_back(x.id);
            return node;
        }
        std::vector<Ref>().swap(r);
        node->axis = axis;
        // The budget left after this split goes to the children by their share of
        // references: deterministic, unlike a shared counter raced for by tasks.
        const uint64_t used = left.size() + right.size() > n ? left.size() + right.size() - n : 0;
        const uint64_t rest = budget > used ? budget - used : 0;
        const uint64_t lb = rest * left.size() / (left.size() + right.size());
        const uint64_t rb = rest - lb;
        if (n >= kParallelBuild) {
            tbb::parallel_invoke([&] { node->kid[0] = build(std::move(left), depth + 1, lb); },
                                 [&] { node->kid[1] = build(std::move(right), depth + 1, rb); });
        } else {
            node->kid[0] = build(std::move(left), depth + 1, lb);
            node->kid[1] = build(std::move(right), depth + 1, rb);
        }
        return node;
    }

private:
    /// Object median on `axis` (deep nodes, and when nothing else separates).
    static void median(std::vector<Ref>& r, int axis, std::vector<Ref>& left, std::vector<Ref>& right) {
        const size_t mid = r.size() / 2;
        std::nth_element(r.begin(), r.begin() + mid, r.end(), [axis](const Ref& a, const Ref& b) {
            const float ca = a.centroid()[axis], cb = b.centroid()[axis];
            return ca != cb ? ca < cb : a.id < b.id;  // total order: same result every run
        });
        left.assign(r.begin(), r.begin() + mid);
        right.assign(r.begin() + mid, r.end());
    }

    /// Clips (the part in `x.b` of) primitive x.id at `pos` on `axis`: the boxes of the
    /// primitive's parts on either side, each within x.b. A side may come back empty.
    void clip(const Ref& x, int axis, float pos, Bounds3f& l, Bounds3f& r) const {
        const PrimRef pr = refs_[x.id];
        const GeometryView& g = g_[pr.geom];
        l = x.b, r = x.b;
        l.hi[axis] = std::min(l.hi[axis], pos);
        r.lo[axis] = std::max(r.lo[axis], pos);
        if (g.type != GeometryType::Triangles) return;  // spheres: the box cut in two
        Vec3f fv[3];
        triangle_vertices(g, pr.prim, fv[0], fv[1], fv[2]);
        // Edge-plane intersections in double, rounded outward to float: the parts'
        // boxes must contain every point of the triangle on their side, or rays leak.
        double lo[2][3], hi[2][3];
        for (int s = 0; s < 2; ++s)
            for (int a = 0; a < 3; ++a) lo[s][a] = kInfinity, hi[s][a] = -kInfinity;
        auto add = [&](int s, const double* p) {
            for (int a = 0; a < 3; ++a) lo[s][a] = std::min(lo[s][a], p[a]), hi[s][a] = std::max(hi[s][a], p[a]);
        };
        const double P = pos;
        for (int e = 0; e < 3; ++e) {
            const double p0[3] = {fv[e].x, fv[e].y, fv[e].z};
            const Vec3f& f1 = fv[(e + 1) % 3];
            const double p1[3] = {f1.x, f1.y, f1.z};
            if (p0[axis] <= P) add(0, p0);
            if (p0[axis] >= P) add(1, p0);
            if ((p0[axis] < P && p1[axis] > P) || (p0[axis] > P && p1[axis] < P)) {
                const double t = (P - p0[axis]) / (p1[axis] - p0[axis]);
                double q[3];
                for (int a = 0; a < 3; ++a) q[a] = p0[a] + t * (p1[a] - p0[a]);
                q[axis] = P;
                add(0, q), add(1, q);
            }
        }
        Bounds3f* out[2] = {&l, &r};
        for (int s = 0; s < 2; ++s) {
            Bounds3f& o = *out[s];
            if (!(lo[s][0] <= hi[s][0])) {  // nothing of the triangle on this side
                o = Bounds3f{};
                continue;
            }
            for (int a = 0; a < 3; ++a) {
                o.lo[a] = std::max(o.lo[a], round_down(lo[s][a]));
                o.hi[a] = std::min(o.hi[a], round_up(hi[s][a]));
            }
        }
    }

    /// Runs body over [0, n) into one accumulator (Acc::merge joins partial ones): in
    /// one piece below kParallelBin references, where a task costs more than it saves.
    template <class Acc, class Body>
    static Acc reduce(size_t n, size_t grain, const Body& body) {
        if (n < kParallelBin) return body(tbb::blocked_range<size_t>(0, n), Acc{});
        return tbb::parallel_reduce(tbb::blocked_range<size_t>(0, n, grain), Acc{}, body, [](Acc a, const Acc& b) {
            a.merge(b);
            return a;
        });
    }

    Spatial spatial_bins(const std::vector<Ref>& r, const Slabs& slabs, const bool (&usable)[3]) const {
        auto body = [&](const tbb::blocked_range<size_t>& range, Spatial acc) {
            for (size_t k = range.begin(); k < range.end(); ++k) {
                const Ref& x = r[k];
                for (int a = 0; a < 3; ++a) {
                    if (!usable[a]) continue;
                    const int first = slabs.bin(x.b.lo[a], a), last = slabs.bin(x.b.hi[a], a);
                    ++acc.enter[a][first];
                    ++acc.exit[a][last];
                    Ref cur = x;
                    for (int i = first; i < last; ++i) {
                        Bounds3f l, rr;
                        clip(cur, a, slabs.plane(i + 1, a), l, rr);
                        acc.b[a][i].extend(l);
                        cur.b = rr;
                        if (rr.empty()) break;
                    }
                    acc.b[a][last].extend(cur.b);
                }
            }
            return acc;
        };
        return reduce<Spatial>(r.size(), 2048, body);
    }

    Bins object_bins(const std::vector<Ref>& r, const Binner& binner) const {
        auto body = [&](const tbb::blocked_range<size_t>& range, Bins acc) {
            for (size_t k = range.begin(); k < range.end(); ++k) {
                const Vec3f c = r[k].centroid();
                for (int a = 0; a < 3; ++a) {
                    const int i = binner.bin(c[a], a);
                    acc.b[a][i].extend(r[k].b);
                    ++acc.n[a][i];
                }
            }
            return acc;
        };
        return reduce<Bins>(r.size(), 4096, body);
    }

    /// Chooses and performs the split; false for "make a leaf". Above leaf_size a split
    /// is forced, as in build.cpp.
    bool split(std::vector<Ref>& r, const Bounds3f& bounds, const Bounds3f& cbounds, uint64_t budget,
               int& axis, std::vector<Ref>& left, std::vector<Ref>& right) {
        const uint32_t n = uint32_t(r.size());
        const Vec3f cext = cbounds.diagonal();
        Sweep obj;
        std::unique_ptr<Binner> binner;
        if (max_component(cext) > 0.0f) {
            binner = std::make_unique<Binner>(cbounds);
            const Bins bins = object_bins(r, *binner);
            const bool usable[3] = {cext[0] > 0.0f, cext[1] > 0.0f, cext[2] > 0.0f};
            sweep(bins.b, bins.n, bins.n, usable, obj);
        }
        // Spatial splits only where the object split's children overlap noticeably.
        Sweep spa;
        std::unique_ptr<Slabs> slabs;
        Bounds3f overlap;
        if (obj.axis >= 0) {
            overlap.lo = vmax(obj.left.lo, obj.right.lo);
            overlap.hi = vmin(obj.left.hi, obj.right.hi);
        }
        if (budget > 0 && (obj.axis < 0 || double(overlap.surface_area()) > min_overlap_)) {
            slabs = std::make_unique<Slabs>(bounds);
            const Vec3f ext = bounds.diagonal();
            const bool usable[3] = {ext[0] > 0.0f, ext[1] > 0.0f, ext[2] > 0.0f};
            const Spatial sp = spatial_bins(r, *slabs, usable);
            sweep(sp.b, sp.enter, sp.exit, usable, spa);
            if (spa.axis >= 0 && spa.n_left + spa.n_right > n + budget) spa = Sweep{};  // over budget
        }
        const double best = std::min(obj.cost, spa.cost);
        if (!(best < std::numeric_limits<double>::infinity())) {  // nothing separates
            if (n <= leaf_size_) return false;
            median(r, axis, left, right);
            return true;
        }
        const double area = std::max(double(bounds.surface_area()), 1e-30);
        const double split_cost = kCostTraversal + kCostIntersect * best / area;
        if (n <= leaf_size_ && !(split_cost < kCostIntersect * blocks(n))) return false;
        if (spa.cost < obj.cost && spatial_partition(r, *slabs, spa, budget, left, right)) {
            axis = spa.axis;
            return true;
        }
        if (obj.axis < 0) {
            median(r, axis, left, right);
            return true;
        }
        axis = obj.axis;
        for (const Ref& x : r)
            (binner->bin(x.centroid()[obj.axis], obj.axis) < obj.split ? left : right).push_back(x);
        if (left.empty() || right.empty()) {  // paranoia, as build.cpp
            left.clear(), right.clear();
            median(r, axis, left, right);
        }
        return true;
    }

    /// Distributes the references for the spatial split `s`; straddlers are unsplit
    /// (kept whole on one side) when that lowers the SAH (Stich et al. section 4.5).
    /// False if a side would be empty or the duplicates exceed the budget: the caller
    /// falls back to the object split.
    bool spatial_partition(const std::vector<Ref>& r, const Slabs& slabs, const Sweep& s, uint64_t budget,
                           std::vector<Ref>& left, std::vector<Ref>& right) const {
        const int a = s.axis;
        const float pos = slabs.plane(s.split, a);
        Bounds3f lb = s.left, rb = s.right;
        double nl = s.n_left, nr = s.n_right;
        left.reserve(s.n_left), right.reserve(s.n_right);
        for (const Ref& x : r) {
            const int first = slabs.bin(x.b.lo[a], a), last = slabs.bin(x.b.hi[a], a);
            if (last < s.split) {
                left.push_back(x);
                continue;
            }
            if (first >= s.split) {
                right.push_back(x);
                continue;
            }
            Bounds3f l_or_b = lb, r_or_b = rb;
            l_or_b.extend(x.b), r_or_b.extend(x.b);
            const double al = lb.surface_area(), ar = rb.surface_area();
            const double c_split = al * nl + ar * nr;
            const double c_left = double(l_or_b.surface_area()) * nl + ar * (nr - 1);
            const double c_right = al * (nl - 1) + double(r_or_b.surface_area()) * nr;
            if (c_left < c_split && c_left <= c_right) {
                left.push_back(x), lb = l_or_b, nr -= 1;
            } else if (c_right < c_split) {
                right.push_back(x), rb = r_or_b, nl -= 1;
            } else {
                Bounds3f l, rr;
                clip(x, a, pos, l, rr);
                if (!l.empty()) left.push_back({l, x.id});
                if (!rr.empty()) right.push_back({rr, x.id});
                if (l.empty() && rr.empty()) left.push_back(x);  // cannot happen; never lose a reference
            }
        }
        // Both sides may keep every reference (needles cut across): the boxes still shrink,
        // and the budget, which every duplicate spends, bounds how often that can happen.
        if (left.empty() || right.empty() || left.size() + right.size() > r.size() + budget) {
            left.clear(), right.clear();
            return false;
        }
        return true;
    }

    std::span<const GeometryView> g_;
    const std::vector<PrimRef>& refs_;
    uint32_t leaf_size_;
    double min_overlap_;
};

}  // namespace

BinaryTree build_sbvh(std::span<const GeometryView> geometry, const std::vector<PrimRef>& refs,
                      uint32_t leaf_size, int threads) {
    BinaryTree tree;
    tree.spatial = true;
    const uint32_t n = uint32_t(refs.size());
    if (n == 0) return tree;
    tbb::task_arena arena(threads > 0 ? threads : tbb::task_arena::automatic);
    arena.execute([&] {
        std::vector<Ref> r(n);
        Bounds3f root;
        for (uint32_t i = 0; i < n; ++i) {
            r[i] = {primitive_bounds(geometry[refs[i].geom], refs[i].prim), i};
            root.extend(r[i].b);
        }
        SpatialBuilder builder(geometry, refs, leaf_size, double(root.surface_area()));
        const uint64_t budget = uint64_t(kSbvhBudget * double(n));
        std::unique_ptr<SNode> top = builder.build(std::move(r), 1, budget);

        // Flatten depth-first as build.cpp does; leaves take their slots in that order.
        auto emit = [&](auto&& self, const SNode* b, uint32_t slot) -> void {
            Node& out = tree.nodes[slot];
            out.b[0] = b->bounds.lo.x, out.b[1] = b->bounds.lo.y, out.b[2] = b->bounds.lo.z;
            out.b[3] = b->bounds.hi.x, out.b[4] = b->bounds.hi.y, out.b[5] = b->bounds.hi.z;
            if (!b->kid[0]) {
                out.offset = uint32_t(tree.order.size());
                out.meta = uint32_t(b->prims.size());
                for (uint32_t id : b->prims) tree.order.push_back(refs[id]);
                return;
            }
            const uint32_t c = uint32_t(tree.nodes.size());
            tree.nodes.emplace_back();
            tree.nodes.emplace_back();
            // `out` may dangle after the emplaces: write through the index.
            tree.nodes[slot].offset = c;
            tree.nodes[slot].meta = uint32_t(b->axis) << 30;
            self(self, b->kid[0].get(), c);
            self(self, b->kid[1].get(), c + 1);
        };
        tree.nodes.emplace_back();
        emit(emit, top.get(), 0);
        tree.nodes.shrink_to_fit();
        tree.order.shrink_to_fit();
    });
    return tree;
}

}  // namespace accel::bvh
