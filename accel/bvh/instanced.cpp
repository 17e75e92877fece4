// The two-level BVH's build (instanced.h): bottom trees by the flat build, the top tree
// by the same binned SAH over the placements' world boxes, collapsed into 8-wide nodes.
#include "accel/bvh/instanced.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "accel/bvh/bvh.h"
#include "accel/bvh/dispatch.h"
#include "accel/primitive.h"

namespace accel::bvh {
namespace {

/// Object-space boxes whose union holds a bottom tree's geometry, for the placements'
/// world boxes: the transformed box of a prototype's box is loose wherever the transform
/// turns it (up to sqrt(2) wider across a turn of 45 degrees about one axis), while the
/// union of its parts' transformed boxes follows the shape. The parts are the lanes of
/// the bottom tree's float nodes from the root down, the largest interior lane opened
/// while the cover stays within kCoverBoxes (accel/DECISIONS.md, "placement boxes from
/// the bottom tree's parts"). SoA, so world_box's loop over parts vectorises.
struct Cover {
    static constexpr size_t kCoverBoxes = 64;
    std::vector<float> lo[3], hi[3];
    Bounds3f whole;

    explicit Cover(const BvhBase& b) : whole(b.bounds()) {
        const WideBvh& w = b.wide_;
        struct Part {
            Bounds3f box;
            uint32_t node;  ///< the wide node below it, or WideNode::kEmpty for a leaf
        };
        std::vector<Part> parts;
        const auto open = [&](uint32_t n) {
            const WideNode& node = w.nodes[n];
            for (int i = 0; i < kWidth; ++i) {
                if (node.child[i] == WideNode::kEmpty) continue;
                Bounds3f box;
                for (int a = 0; a < 3; ++a) box.lo[a] = node.b[a][i], box.hi[a] = node.b[a + 3][i];
                parts.push_back({box, node.child[i] & WideNode::kLeaf ? WideNode::kEmpty : node.child[i]});
            }
        };
        // Quantized bottoms (prototypes of 4M primitives or more) keep their one box.
        if (!w.nodes.empty()) open(0);
        while (parts.size() + kWidth - 1 <= kCoverBoxes) {
            size_t best = parts.size();
            for (size_t i = 0; i < parts.size(); ++i)
                if (parts[i].node != WideNode::kEmpty &&
                    (best == parts.size() || parts[i].box.surface_area() > parts[best].box.surface_area()))
                    best = i;
            if (best == parts.size()) break;
            const uint32_t n = parts[best].node;
            parts.erase(parts.begin() + std::ptrdiff_t(best));
            open(n);
        }
        if (parts.empty() && !whole.empty()) parts.push_back({whole, WideNode::kEmpty});
        for (const Part& p : parts)
            for (int a = 0; a < 3; ++a) lo[a].push_back(p.box.lo[a]), hi[a].push_back(p.box.hi[a]);
    }

    /// The world box of the parts under `a`, rounded outward as Affine3f::bounds rounds
    /// the whole box, with room for this float evaluation's own rounding: each row sums
    /// four terms, within gamma(4) * mag (Higham 2002, section 3.1), where mag bounds
    /// the terms' magnitudes over the whole box and so over every part.
    Bounds3f world_box(const Affine3f& a) const {
        Bounds3f r;
        const size_t n = lo[0].size();
        if (n == 0) return r;
        for (int row = 0; row < 3; ++row) {
            const float* m = a.m[row];
            float l = std::numeric_limits<float>::infinity(), h = -l;
            for (size_t k = 0; k < n; ++k) {
                const float x0 = m[0] * lo[0][k], y0 = m[0] * hi[0][k];
                const float x1 = m[1] * lo[1][k], y1 = m[1] * hi[1][k];
                const float x2 = m[2] * lo[2][k], y2 = m[2] * hi[2][k];
                l = std::min(l, m[3] + std::min(x0, y0) + std::min(x1, y1) + std::min(x2, y2));
                h = std::max(h, m[3] + std::max(x0, y0) + std::max(x1, y1) + std::max(x2, y2));
            }
            double mag = std::fabs(double(m[3]));
            for (int col = 0; col < 3; ++col)
                mag += std::max(std::fabs(double(m[col]) * whole.lo[col]), std::fabs(double(m[col]) * whole.hi[col]));
            // Affine3f::bounds' own 8 eps, and 4 eps more for the sums above.
            const double err = mag * 12.0 * double(std::numeric_limits<float>::epsilon());
            r.lo[row] = std::nextafter(float(double(l) - err), -std::numeric_limits<float>::infinity());
            r.hi[row] = std::nextafter(float(double(h) + err), std::numeric_limits<float>::infinity());
        }
        return r;
    }
};

}  // namespace

InstancedBase::InstancedBase() = default;
InstancedBase::~InstancedBase() = default;
const BuildInfo& InstancedBase::info() const { return info_; }
Bounds3f InstancedBase::bounds() const { return bounds_; }

void InstancedBase::finish(const Placement& p, uint32_t bottom, BlockLane at, const Ray& ray, float t, float u, float v,
                           Hit& hit) const {
    bottoms_[bottom]->finish(at, ray, t, u, v, hit);
    hit.geom_id += geom_base_[bottom];
    hit.inst_id = p.inst;
    if (p.inst != kInvalidId) hit.ng = to_world_normal(p.world_to_object, hit.ng);
}

bool InstancedBase::build(std::span<const GeometryView> geometry, const AccelOptions& opt,
                          const InstanceSet& instances, Isa isa, bool top_quantized, bool quantized) {
    const auto start = std::chrono::steady_clock::now();
    for (const GeometryView& g : geometry) masked_ |= g.masked();
    bool compressed = true;
    // Bottom trees: each prototype's views (its geometry ids from 0), then the
    // world-space views, with the prototypes' emptied so that ids stay the caller's.
    const auto bottom = [&](std::span<const GeometryView> views, uint32_t base) {
        std::unique_ptr<BvhBase> b = make_kernel(isa, opt.triangle, quantized, masked_);
        compressed &= b->build(views, opt, isa_name(isa), quantized);
        bottom_wide_.push_back(&b->wide_);
        geom_base_.push_back(base);
        info_.primitives += b->info_.primitives;
        info_.dropped += b->info_.dropped;
        info_.nodes += b->info_.nodes;
        info_.leaves += b->info_.leaves;
        info_.depth = std::max(info_.depth, b->info_.depth);
        info_.bytes += b->info_.bytes;
        bottoms_.push_back(std::move(b));
    };
    std::vector<GeometryView> world(geometry.begin(), geometry.end());
    for (const PrototypeView& p : instances.prototypes) {
        bottom(geometry.subspan(p.first_geom, p.num_geoms), p.first_geom);
        for (uint32_t g = 0; g < p.num_geoms; ++g) world[p.first_geom + g].num_prims = 0;
    }
    bool any_world = false;
    for (const GeometryView& g : world) any_world |= g.num_prims > 0;
    if (any_world) bottom(world, 0);

    // Placements: every instance whose prototype has something to hit, and the world.
    const uint32_t world_bottom = any_world ? uint32_t(bottoms_.size() - 1) : kInvalidId;
    std::vector<Cover> cover;
    cover.reserve(bottoms_.size());
    for (const auto& b : bottoms_) cover.emplace_back(*b);
    std::vector<uint32_t> kept;  // instance indices (kInvalidId: the world)
    kept.reserve(instances.instances.size() + 1);
    for (uint32_t i = 0; i < instances.instances.size(); ++i) {
        const uint32_t proto = instances.instances[i].prototype;
        info_.instanced_primitives += bottoms_[proto]->info_.primitives;
        if (!cover[proto].whole.empty()) kept.push_back(i);
    }
    if (world_bottom != kInvalidId) kept.push_back(kInvalidId);
    const auto box_of = [&](uint32_t k) {
        const uint32_t i = kept[k];
        if (i == kInvalidId) return cover[world_bottom].whole;
        const InstanceView& iv = instances.instances[i];
        return cover[iv.prototype].world_box(iv.object_to_world);
    };
    // Leaves of one placement: a leaf of several costs one bottom traversal each anyway,
    // and the top node test is what culls them (accel/DECISIONS.md, "one placement per
    // top leaf").
    BinaryTree tree = build_boxes(uint32_t(kept.size()), box_of, BvhSplit::Sah, 1, opt.build_threads);
    tbb::task_arena arena(opt.build_threads > 0 ? opt.build_threads : tbb::task_arena::automatic);
    arena.execute([&] {
        placements_.resize(tree.order.size());
        tbb::parallel_for(tbb::blocked_range<size_t>(0, tree.order.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t k = r.begin(); k < r.end(); ++k) {
                const uint32_t i = kept[tree.order[k].prim];
                Placement& p = placements_[k];
                p = i == kInvalidId ? Placement{Affine3f::identity(), kInvalidId}
                                    : Placement{instances.instances[i].object_to_world.inverse(), i};
            }
        });
        if (!tree.nodes.empty()) {
            bounds_ = tree.nodes[0].bounds();
            collapse_top(tree, top_.nodes);
            // Each leaf lane's count becomes the bottom tree of its one placement.
            tbb::parallel_for(size_t(0), top_.nodes.size(), [&](size_t n) {
                WideNode& w = top_.nodes[n];
                for (int l = 0; l < kWidth; ++l) {
                    if (w.child[l] == WideNode::kEmpty || !(w.child[l] & WideNode::kLeaf)) continue;
                    const uint32_t i = kept[tree.order[w.child[l] & ~WideNode::kLeaf].prim];
                    w.count[l] = i == kInvalidId ? world_bottom : instances.instances[i].prototype;
                }
            });
            const float* lo = &tree.nodes[0].b[0];
            std::copy(lo, lo + 6, top_.root);
            if (top_quantized) compressed &= quantize(top_);
        }
    });
    const TreeFacts f = tree_facts(tree.nodes);
    info_.instances = instances.instances.size();
    info_.nodes += tree.nodes.size();
    info_.leaves += f.leaves;
    info_.depth += f.depth;
    info_.bytes += wide_bytes(top_) + placements_.capacity() * sizeof(Placement) +
                   bottom_wide_.capacity() * sizeof(void*) + geom_base_.capacity() * sizeof(uint32_t);
    const char* split = opt.split == BvhSplit::Sah ? "sah" : opt.split == BvhSplit::Sbvh ? "sbvh" : "midpoint";
    const char* test = opt.triangle == TriangleTest::Watertight ? "watertight" : "fast";
    info_.backend = std::string("custom(") + split + ", " + test + ", " + isa_name(isa) + ", " +
                    layout_name(quantized ? NodeLayout::Quantized : NodeLayout::Float) + (masked_ ? ", masked" : "") +
                    ", two-level, top " + layout_name(top_quantized ? NodeLayout::Quantized : NodeLayout::Float) + ")";
    info_.counts_nodes = true;
    info_.counts_prims = true;
    info_.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return compressed;
}

}  // namespace accel::bvh
