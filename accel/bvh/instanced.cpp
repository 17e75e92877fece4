// The two-level BVH's build (instanced.h): bottom trees by the flat build, the top tree
// by the same binned SAH over the placements' world boxes, collapsed into 8-wide nodes.
#include "accel/bvh/instanced.h"

#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>

#include "accel/bvh/bvh.h"
#include "accel/bvh/dispatch.h"
#include "accel/primitive.h"

namespace accel::bvh {

InstancedBase::InstancedBase() = default;
InstancedBase::~InstancedBase() = default;
const BuildInfo& InstancedBase::info() const { return info_; }
Bounds3f InstancedBase::bounds() const { return bounds_; }

void InstancedBase::finish(const Placement& p, BlockLane at, const Ray& ray, float t, float u, float v, Hit& hit) const {
    bottoms_[p.bottom]->finish(at, ray, t, u, v, hit);
    hit.geom_id += geom_base_[p.bottom];
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
    std::vector<Bounds3f> bottom_box(bottoms_.size());
    for (size_t b = 0; b < bottoms_.size(); ++b) bottom_box[b] = bottoms_[b]->bounds();
    std::vector<uint32_t> kept;  // instance indices (kInvalidId: the world)
    kept.reserve(instances.instances.size() + 1);
    for (uint32_t i = 0; i < instances.instances.size(); ++i) {
        const uint32_t proto = instances.instances[i].prototype;
        info_.instanced_primitives += bottoms_[proto]->info_.primitives;
        if (!bottom_box[proto].empty()) kept.push_back(i);
    }
    if (world_bottom != kInvalidId) kept.push_back(kInvalidId);
    const auto box_of = [&](uint32_t k) {
        const uint32_t i = kept[k];
        if (i == kInvalidId) return bottom_box[world_bottom];
        const InstanceView& iv = instances.instances[i];
        return iv.object_to_world.bounds(bottom_box[iv.prototype]);
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
                if (i == kInvalidId) {
                    p = {Affine3f::identity(), world_bottom, kInvalidId};
                } else {
                    const InstanceView& iv = instances.instances[i];
                    p = {iv.object_to_world.inverse(), iv.prototype, i};
                }
            }
        });
        for (uint32_t k = 0; k < kept.size(); ++k) bounds_.extend(box_of(k));
        if (!tree.nodes.empty()) {
            collapse_top(tree, top_.nodes);
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
