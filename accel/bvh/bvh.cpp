// Our own BVH backend ("custom"): the build (build.h), the wide layout (wide.h) and the
// run-time kernel choice (dispatch.h) put together; inspect_bvh checks what they made.
#include "accel/bvh/bvh.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <unordered_map>

#include <tbb/task_arena.h>

#include "accel/bvh/base.h"
#include "accel/bvh/dispatch.h"
#include "accel/bvh/instanced.h"
#include "accel/primitive.h"

namespace accel {
namespace bvh {

BvhBase::BvhBase() = default;
BvhBase::~BvhBase() = default;
const BuildInfo& BvhBase::info() const { return info_; }
Bounds3f BvhBase::bounds() const {
    if (wide_.nodes.empty() && wide_.qnodes.empty()) return Bounds3f{};
    const float* r = wide_.root;
    return {{r[0], r[1], r[2]}, {r[3], r[4], r[5]}};
}

void BvhBase::finish(BlockLane at, const Ray& ray, float t, float u, float v, Hit& hit) const {
    Hit h;
    h.t = t, h.u = u, h.v = v;
    const PrimRef ref = lane_primitive(wide_, *at.block, at.lane);
    h.geom_id = ref.geom;
    h.prim_id = ref.prim;
    const Block& b = *at.block;
    const int l = at.lane;
    const auto lane = [&](int row) { return Vec3f(b.p[row][0][l], b.p[row][1][l], b.p[row][2][l]); };
    if (geometry_[ref.geom].type == GeometryType::Triangles)
        h.ng = edges_ ? cross(lane(1), lane(2)) : triangle_normal(lane(0), lane(1), lane(2));
    else
        h.ng = sphere_normal(ray, h.t, lane(0));
    hit = h;
}

bool BvhBase::build(std::span<const GeometryView> geometry, const AccelOptions& opt, const char* kernel,
                    bool quantized) {
    const auto start = std::chrono::steady_clock::now();
    geometry_.assign(geometry.begin(), geometry.end());
    edges_ = opt.triangle == TriangleTest::Fast;
    leaf_size_ = std::clamp<uint32_t>(opt.leaf_size ? opt.leaf_size : default_leaf_size(opt.split), 1u,
                                      Node::kCountMask);
    const std::vector<PrimRef> refs = collect_primitives(geometry_, info_.dropped);
    for (const PrimRef& r : refs) has_spheres_ |= geometry_[r.geom].type == GeometryType::Spheres;
    tree_ = opt.split == BvhSplit::Sbvh ? build_sbvh(geometry_, refs, leaf_size_, opt.build_threads)
                                        : build_binary(geometry_, refs, opt.split, leaf_size_, opt.build_threads);
    // The block packing runs in parallel: on the build's threads, like the build (a small
    // tree on this thread: an arena costs more than its packing, build.cpp says).
    bool compressed = false;
    const auto pack = [&] {
        wide_ = collapse(tree_, geometry_, opt.triangle, leaf_size_, opt.leaf_prefetch);
        compressed = quantized && quantize(wide_);
    };
    if (refs.size() < 4096) {
        pack();
    } else {
        tbb::task_arena arena(opt.build_threads > 0 ? opt.build_threads : tbb::task_arena::automatic);
        arena.execute(pack);
    }

    const TreeFacts f = tree_facts(tree_.nodes);
    const char* split = opt.split == BvhSplit::Sah ? "sah" : opt.split == BvhSplit::Sbvh ? "sbvh" : "midpoint";
    const char* test = opt.triangle == TriangleTest::Watertight ? "watertight" : "fast";
    bool masked = false;
    for (const GeometryView& g : geometry_) masked |= g.masked();
    // geometry_ is never resized after this, and a move (adopt) keeps its array.
    wide_.geometry = masked ? geometry_.data() : nullptr;
    info_.backend = std::string("custom(") + split + ", " + test + ", " + kernel + ", " +
                    layout_name(compressed ? NodeLayout::Quantized : NodeLayout::Float) +
                    (masked ? ", masked" : "") + ")";
    info_.primitives = refs.size();
    info_.nodes = tree_.nodes.size();
    info_.leaves = f.leaves;
    info_.depth = f.depth;
    info_.sah_cost = f.sah_cost;
    // What the accelerator keeps: the traversal arrays, and the binary tree with its slot
    // map only when asked to (inspection).
    if (!opt.keep_binary_tree) tree_ = BinaryTree{};
    info_.bytes = tree_.nodes.capacity() * sizeof(Node) + tree_.order.capacity() * sizeof(PrimRef) +
                  wide_bytes(wide_) + geometry_.capacity() * sizeof(GeometryView);
    info_.counts_nodes = true;
    info_.counts_prims = true;
    info_.build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return compressed == quantized;
}

void BvhBase::adopt(BvhBase&& o) {
    geometry_ = std::move(o.geometry_);
    tree_ = std::move(o.tree_);
    wide_ = std::move(o.wide_);
    has_spheres_ = o.has_spheres_;
    edges_ = o.edges_;
    leaf_size_ = o.leaf_size_;
    info_ = std::move(o.info_);
}

}  // namespace bvh

const char* layout_name(NodeLayout layout) {
    switch (layout) {
        case NodeLayout::Float: return "float";
        case NodeLayout::Quantized: return "quantized";
        default: return "auto";
    }
}

bool parse_layout(const std::string& s, NodeLayout& out) {
    for (NodeLayout l : {NodeLayout::Auto, NodeLayout::Float, NodeLayout::Quantized})
        if (s == layout_name(l)) return out = l, true;
    return false;
}

NodeLayout resolve_layout(NodeLayout layout, uint64_t primitives) {
    if (layout != NodeLayout::Auto) return layout;
    return primitives >= kQuantizeFrom ? NodeLayout::Quantized : NodeLayout::Float;
}

std::unique_ptr<Accelerator> make_bvh(std::span<const GeometryView> geometry, const AccelOptions& options,
                                      const InstanceSet& instances) {
    const Isa isa = resolve_isa(options.isa);
    if (!instances.empty()) {
        // The top tree keeps float nodes under Auto, at any size: on the 10^7-instance
        // forest they trace camera rays 8 % faster than compressed ones, for 97 bytes per
        // instance against 75 (the goal is 100). The bottom trees take the layout of the
        // largest prototype's size, as a flat tree (accel/DECISIONS.md, "two-level node
        // layouts").
        uint64_t most = 0;
        bool masked = false;
        for (const PrototypeView& p : instances.prototypes) {
            uint64_t n = 0;
            for (uint32_t g = 0; g < p.num_geoms; ++g) n += geometry[p.first_geom + g].num_prims;
            most = std::max(most, n);
        }
        uint64_t world = 0;
        for (const GeometryView& g : geometry) masked |= g.masked(), world += g.num_prims;
        most = std::max(most, world);  // (an upper bound of the world tree's)
        const bool top_q = options.nodes == NodeLayout::Quantized;
        const bool q = resolve_layout(options.nodes, most) == NodeLayout::Quantized;
        std::unique_ptr<bvh::InstancedBase> b = bvh::make_instanced(isa, options.triangle, top_q, q, masked);
        if (b->build(geometry, options, instances, isa, top_q, q)) return b;
        // Some box beyond an 8-bit grid's reach: float nodes at both levels.
        b = bvh::make_instanced(isa, options.triangle, false, false, masked);
        b->build(geometry, options, instances, isa, false, false);
        return b;
    }
    uint64_t prims = 0;
    bool masked = false;
    for (const GeometryView& g : geometry) prims += g.num_prims, masked |= g.masked();
    const bool quantized = resolve_layout(options.nodes, prims) == NodeLayout::Quantized;
    std::unique_ptr<bvh::BvhBase> b = bvh::make_kernel(isa, options.triangle, quantized, masked);
    if (!b->build(geometry, options, isa_name(isa), quantized)) {
        std::unique_ptr<bvh::BvhBase> f = bvh::make_kernel(isa, options.triangle, false, masked);
        f->adopt(std::move(*b));
        return f;
    }
    return b;
}

std::optional<BvhReport> inspect_bvh(const Accelerator& accel) {
    using namespace bvh;
    const auto* b = dynamic_cast<const BvhBase*>(&accel);
    if (!b || (b->tree_.nodes.empty() && b->info_.primitives > 0)) return std::nullopt;
    BvhReport r;
    auto fail = [&](bool& flag, std::string msg) {
        flag = false;
        if (r.errors.size() < 16) r.errors.push_back(std::move(msg));
    };
    const auto& nodes = b->tree_.nodes;
    const auto& order = b->tree_.order;
    const TreeFacts f = tree_facts(nodes);
    r.nodes = nodes.size();
    r.leaves = f.leaves;
    r.depth = f.depth;
    r.max_leaf_size = f.max_leaf;
    r.leaf_size_limit = b->leaf_size_;
    r.sah_cost = f.sah_cost;
    const bool spatial = b->tree_.spatial;
    r.references = order.size();
    auto overlaps = [](const Bounds3f& a, const Bounds3f& c) {
        return !(a.hi.x < c.lo.x || c.hi.x < a.lo.x || a.hi.y < c.lo.y || c.hi.y < a.lo.y || a.hi.z < c.lo.z ||
                 c.hi.z < a.lo.z);
    };
    // sbvh: the leaf boxes that hold each triangle, for the coverage check below.
    std::unordered_map<uint64_t, std::vector<uint32_t>> leaves_of;
    auto key = [](const PrimRef& p) { return uint64_t(p.geom) << 32 | p.prim; };

    // Every leaf-order slot covered by exactly one leaf, and the slots hold exactly the
    // primitives collect_primitives keeps (each once).
    std::vector<uint32_t> covered(order.size(), 0);
    for (uint32_t i = 0; i < nodes.size(); ++i) {
        const Node& n = nodes[i];
        const Bounds3f nb = n.bounds();
        if (n.is_leaf()) {
            if (n.count() > b->leaf_size_)
                fail(r.leaf_size_ok, "leaf " + std::to_string(i) + " holds " + std::to_string(n.count()) +
                                         " primitives");
            if (uint64_t(n.offset) + n.count() > covered.size()) {
                fail(r.prims_once, "leaf " + std::to_string(i) + " range out of bounds");
                continue;
            }
            for (uint32_t k = n.offset; k < n.offset + n.count(); ++k) {
                ++covered[k];
                const PrimRef ref = order[k];
                const Bounds3f pb = primitive_bounds(b->geometry_[ref.geom], ref.prim);
                if (spatial) leaves_of[key(ref)].push_back(i);
                if (spatial ? !overlaps(nb, pb) : !nb.contains(pb))
                    fail(r.leaves_contain_prims,
                         "leaf " + std::to_string(i) + " does not contain prim " + std::to_string(ref.prim));
            }
        } else {
            if (n.offset <= i || uint64_t(n.offset) + 1 >= nodes.size()) {
                fail(r.siblings_adjacent, "node " + std::to_string(i) + " child index bad");
                continue;
            }
            for (int k = 0; k < 2; ++k)
                if (!nb.contains(nodes[n.offset + k].bounds()))
                    fail(r.children_inside, "child " + std::to_string(n.offset + k) + " of node " +
                                                std::to_string(i) + " sticks out");
        }
    }
    for (size_t k = 0; k < covered.size(); ++k)
        if (covered[k] != 1)
            fail(r.prims_once, "slot " + std::to_string(k) + " in " + std::to_string(covered[k]) + " leaves");
    uint64_t dropped = 0;
    std::vector<PrimRef> expect = collect_primitives(b->geometry_, dropped);
    std::vector<PrimRef> got = order;
    auto less = [](const PrimRef& a, const PrimRef& c) { return a.geom != c.geom ? a.geom < c.geom : a.prim < c.prim; };
    std::sort(expect.begin(), expect.end(), less);
    std::sort(got.begin(), got.end(), less);
    if (spatial)  // duplicates are the point of spatial splits: compare the distinct set
        got.erase(std::unique(got.begin(), got.end(),
                              [](const PrimRef& a, const PrimRef& c) { return a.geom == c.geom && a.prim == c.prim; }),
                  got.end());
    r.primitives = got.size();
    const bool same_set = expect.size() == got.size() &&
                          std::equal(expect.begin(), expect.end(), got.begin(),
                                     [](const PrimRef& a, const PrimRef& c) { return a.geom == c.geom && a.prim == c.prim; });
    if (!same_set) fail(r.prims_once, "leaf primitives differ from the collected set");

    // sbvh: no point of a triangle may fall outside every leaf box that holds it, or a
    // ray through that point would miss the triangle. Points in double, boxes widened by
    // a hair (1e-9 of the scene size) for the rounding of the barycentric sums.
    if (spatial && !nodes.empty()) {
        const Bounds3f root = nodes[0].bounds();
        const double tol = 1e-9 * std::max(1.0, double(max_component(root.diagonal())));
        for (const auto& [k, leaves] : leaves_of) {
            const GeometryView& g = b->geometry_[uint32_t(k >> 32)];
            if (g.type != GeometryType::Triangles) continue;
            Vec3f v0, v1, v2;
            triangle_vertices(g, uint32_t(k), v0, v1, v2);
            for (int i = 0; i <= 6; ++i)
                for (int j = 0; i + j <= 6; ++j) {
                    const double u = i / 6.0, w = j / 6.0;
                    double p[3];
                    for (int a = 0; a < 3; ++a) p[a] = (1.0 - u - w) * v0[a] + u * v1[a] + w * v2[a];
                    bool in = false;
                    for (uint32_t li : leaves) {
                        const Bounds3f lb = nodes[li].bounds();
                        bool inside = true;
                        for (int a = 0; a < 3; ++a) inside &= p[a] >= lb.lo[a] - tol && p[a] <= lb.hi[a] + tol;
                        if ((in = inside)) break;
                    }
                    if (!in)
                        fail(r.leaves_contain_prims, "prim " + std::to_string(uint32_t(k)) +
                                                         ": a point of it lies in none of its leaves");
                }
        }
    }

    // The wide traversal tree: its block lanes name exactly the primitives of the leaf
    // slots (as many times: sbvh repeats some), every
    // lane box inside the box its parent lane gave, leaf lanes containing their
    // primitives, and each block lane holding the scene's data (fast mode: the edges
    // the scalar test would compute, bit for bit).
    // Quantized nodes are not nested (a child's grid may round past its parent's), so
    // there each leaf's primitives are checked against every box on their path: the
    // intersection of the ancestors' lane boxes is what `parent` carries down.
    const WideBvh& w = b->wide_;
    const bool quant = !w.qnodes.empty();
    r.quantized = quant;
    r.leaf_hints = w.leaf_hints;
    const size_t wide_count = quant ? w.qnodes.size() : w.nodes.size();
    r.wide_nodes = wide_count;
    r.blocks = w.blocks.size();
    r.filled_lanes = w.blocks.empty() ? 0.0 : double(order.size()) / (4.0 * double(w.blocks.size()));
    const bool edges = b->info().backend.find("fast") != std::string::npos;
    if (nodes.empty() != (wide_count == 0)) fail(r.wide_ok, "wide tree missing or extra");
    if (quant && !w.nodes.empty()) fail(r.wide_ok, "both float and quantized nodes kept");
    if (wide_count != 0) {
        std::vector<uint64_t> lane_keys;
        lane_keys.reserve(order.size());
        if (!w.lane_geom.empty() && w.lane_geom.size() != 4 * w.blocks.size())
            fail(r.wide_ok, "lane geometry table does not match the blocks");
        std::vector<uint32_t> block_uses(w.blocks.size(), 0);
        struct Item {
            uint32_t idx;
            Bounds3f parent;
        };
        std::vector<Item> stack{{0, nodes[0].bounds()}};
        uint64_t visited = 0;
        while (!stack.empty() && visited <= wide_count) {
            const Item it = stack.back();
            stack.pop_back();
            ++visited;
            const uint32_t* child = quant ? w.qnodes[it.idx].child : w.nodes[it.idx].child;
            const uint32_t* count = quant ? w.qnodes[it.idx].count : w.nodes[it.idx].count;
            for (int i = 0; i < kWidth; ++i) {
                if (quant && ((w.qnodes[it.idx].valid >> i & 1) != (child[i] != WideNode::kEmpty)))
                    fail(r.wide_ok, "quantized valid mask disagrees with the children");
                if (child[i] == WideNode::kEmpty) continue;
                float bx[6];
                if (quant)
                    dequantize(w.qnodes[it.idx], i, bx);
                else
                    for (int k = 0; k < 6; ++k) bx[k] = w.nodes[it.idx].b[k][i];
                Bounds3f lb{{bx[0], bx[1], bx[2]}, {bx[3], bx[4], bx[5]}};
                if (quant) {
                    lb.lo = vmax(lb.lo, it.parent.lo), lb.hi = vmin(lb.hi, it.parent.hi);
                } else if (!it.parent.contains(lb)) {
                    fail(r.wide_ok, "wide lane sticks out of its parent");
                }
                if (!(child[i] & WideNode::kLeaf)) {
                    if (child[i] <= it.idx || child[i] >= wide_count) {
                        fail(r.wide_ok, "wide child index bad");
                        continue;
                    }
                    stack.push_back({child[i], lb});
                    // The lane's count is the child's leaf-block hint exactly when the
                    // child is a bottom node: its blocks, in one contiguous run.
                    const uint32_t* cc = quant ? w.qnodes[child[i]].child : w.nodes[child[i]].child;
                    const uint32_t* cn = quant ? w.qnodes[child[i]].count : w.nodes[child[i]].count;
                    bool bottom = true;
                    uint32_t first = UINT32_MAX, end = 0, total = 0;
                    for (int l = 0; l < kWidth; ++l) {
                        if (cc[l] == WideNode::kEmpty) continue;
                        if (!(cc[l] & WideNode::kLeaf)) {
                            bottom = false;
                            break;
                        }
                        const uint32_t f = cc[l] & ~WideNode::kLeaf, nb = WideNode::leaf_blocks(cn[l]);
                        first = std::min(first, f), end = std::max(end, f + nb), total += nb;
                    }
                    const uint32_t want =
                        w.leaf_hints && bottom && total == end - first ? WideNode::leaves_hint(first, total) : 0u;
                    if (count[i] != want)
                        fail(r.wide_ok, "interior lane's leaf-block hint is not its bottom child's blocks");
                    continue;
                }
                const uint32_t first = child[i] & ~WideNode::kLeaf;
                const uint32_t nb = WideNode::leaf_blocks(count[i]);
                const bool spheres = count[i] & WideNode::kSpheres;
                if (nb == 0 || uint64_t(first) + nb > w.blocks.size()) {
                    fail(r.wide_ok, "wide leaf block range bad");
                    continue;
                }
                uint32_t prims = 0;  // the blocks' filled lanes, which the lane's count must carry
                for (uint32_t k = first; k < first + nb; ++k) {
                    ++block_uses[k];
                    const Block& blk = w.blocks[k];
                    for (int l = 0; l < 4; ++l) {
                        if (blk.prim[l] == Block::kNone) continue;
                        ++prims;
                        const PrimRef ref = lane_primitive(w, blk, l);
                        if (ref.geom >= b->geometry_.size() || ref.prim >= b->geometry_[ref.geom].num_prims) {
                            fail(r.wide_ok, "block lane names no primitive");
                            continue;
                        }
                        lane_keys.push_back(key(ref));
                        const GeometryView& g = b->geometry_[ref.geom];
                        if (spatial ? !overlaps(lb, primitive_bounds(g, ref.prim))
                                    : !lb.contains(primitive_bounds(g, ref.prim)))
                            fail(r.wide_ok, "wide leaf does not contain its primitive");
                        auto lane = [&](int row) { return Vec3f(blk.p[row][0][l], blk.p[row][1][l], blk.p[row][2][l]); };
                        bool same;
                        if (g.type == GeometryType::Triangles) {
                            Vec3f v[3], want[3];
                            triangle_vertices(g, ref.prim, want[0], want[1], want[2]);
                            if (edges) want[1] = want[1] - want[0], want[2] = want[2] - want[0];
                            for (int q = 0; q < 3; ++q) v[q] = lane(q);
                            same = !spheres && std::memcmp(v, want, sizeof v) == 0;
                        } else {
                            same = spheres && lane(0) == sphere_center(g, ref.prim) &&
                                   blk.p[1][0][l] == sphere_radius(g, ref.prim);
                        }
                        if (!same)
                            fail(r.gathered_ok, "primitive " + std::to_string(ref.prim) + " of geometry " +
                                                    std::to_string(ref.geom) + ": block data differs");
                    }
                }
                if (WideNode::leaf_prims(count[i]) != prims)
                    fail(r.wide_ok, "wide leaf's primitive count is not its blocks' filled lanes");
            }
        }
        if (visited != wide_count) fail(r.wide_ok, "wide nodes unreachable or shared");
        std::vector<uint64_t> slot_keys(order.size());
        for (size_t k = 0; k < order.size(); ++k) slot_keys[k] = key(order[k]);
        std::sort(lane_keys.begin(), lane_keys.end());
        std::sort(slot_keys.begin(), slot_keys.end());
        if (lane_keys != slot_keys) fail(r.wide_ok, "the wide tree's primitives are not the leaves' (one lost or repeated)");
        for (uint32_t c : block_uses)
            if (c != 1) {
                fail(r.wide_ok, "a leaf block is used " + std::to_string(c) + " times");
                break;
            }
    }
    return r;
}

}  // namespace accel
