// Collapse of the binary tree into the 8-wide layout and packing of leaf blocks
// (Dammertz et al. 2008; Wald et al. 2008; blocks as Embree's triangle4, Wald et al. 2014).
// Which binary nodes become wide nodes and which subtrees leaves is decided first, for
// the whole tree, by the SAH-optimal dynamic programme of Ylitie et al. 2017 (Plan).
//
// The collapse runs in parallel and gives the very layout a serial depth-first collapse
// gives, at any thread count: the top of the wide tree is walked serially down to a
// frontier of subtrees (kFrontier primitives or fewer), each frontier subtree is counted
// (wide nodes, blocks) in parallel, the counts give every subtree its place in the
// depth-first order, and the subtrees are then written, blocks included, in parallel
// straight into the final arrays. Counting twice costs less than it saves: no array
// grows, no subtree is copied, and the arrays are written once (the serial collapse
// was ~10 % of the 5M-triangle build; accel/DECISIONS.md, "parallel build").
#include "accel/bvh/wide.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <array>


namespace accel::bvh {
namespace {

/// Subtrees of at most this many primitives are collapsed by one task.
constexpr uint32_t kFrontier = 16384;

/// Which binary subtrees become wide nodes and which become leaves: the SAH-optimal
/// conversion of a binary BVH into a wide one by dynamic programming (Ylitie, Karras,
/// Laine 2017, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
/// BVHs", section 4). For each binary node n and each i of 1..kWidth, cost(n, i) is the
/// least SAH cost of n's subtree given i lanes of its parent wide node:
/// - one lane: n is a leaf (if it has at most `max_leaf` primitives of one type) or a
///   wide node of its own (its area times the node cost, plus its best kWidth-lane
///   distribution);
/// - i lanes: the best of i - 1 lanes and every split of the i lanes between n's two
///   children.
/// Against the greedy collapse (open the largest child until eight are gathered) this
/// fills the wide nodes (the greedy one left most bottom nodes with 2-4 children, as
/// each binary node with two leaf children became one) and merges sibling leaves into
/// one leaf of up to two blocks where one 8-lane test costs less than a node.
class Plan {
public:
    Plan(const std::vector<Node>& nodes, const std::vector<PrimRef>& order, std::span<const GeometryView> g,
         uint32_t max_leaf)
        : nodes_(nodes), order_(order), g_(g), max_leaf_(max_leaf), d_(nodes.size()) {
        if (!nodes.empty() && !nodes[0].is_leaf()) solve(0, 0);
    }

    /// The lanes of the wide node made from interior node n, in the plan's order: binary
    /// leaves, and interior nodes given one lane (see leaf()). Returns their number.
    int lanes_of(uint32_t n, uint32_t (&out)[kWidth]) const {
        int k = 0;
        share(nodes_[n].offset, d_[n][0], out, k);
        share(nodes_[n].offset + 1, kWidth - d_[n][0], out, k);
        return k;
    }
    /// Interior node n given one lane: a leaf of all its primitives (else a wide node).
    bool leaf(uint32_t n) const { return nodes_[n].is_leaf() || d_[n][1] != 0; }

private:
    /// Appends the lanes binary node b takes when given `lanes` of them: d_[b][i] is, for
    /// i >= 2, the lanes for its left child, or 0 when it uses only i - 1 of them.
    void share(uint32_t b, int lanes, uint32_t (&out)[kWidth], int& k) const {
        if (!nodes_[b].is_leaf()) {
            while (lanes >= 2 && d_[b][lanes] == 0) --lanes;
            if (lanes >= 2) {
                const int left = d_[b][lanes];
                share(nodes_[b].offset, left, out, k);
                share(nodes_[b].offset + 1, lanes - left, out, k);
                return;
            }
        }
        out[k++] = b;
    }

    struct Costs {
        float c[kWidth + 1];
        uint32_t prims;
        uint32_t types;  ///< bit per GeometryType under the node
    };

    Costs solve(uint32_t n, int depth) {
        const Node& b = nodes_[n];
        Costs r;
        const float area = b.bounds().surface_area();
        if (b.is_leaf()) {
            r.prims = b.count();
            r.types = g_.empty() ? 1u : 1u << unsigned(g_[order_[b.offset].geom].type);
            for (int i = 1; i <= kWidth; ++i) r.c[i] = area * CollapseCost::leaf(r.prims);
            return r;
        }
        Costs l, rt;
        if (depth < kParallelDepth)
            tbb::parallel_invoke([&] { l = solve(b.offset, depth + 1); }, [&] { rt = solve(b.offset + 1, depth + 1); });
        else
            l = solve(b.offset, depth + 1), rt = solve(b.offset + 1, depth + 1);
        r.prims = l.prims + rt.prims;
        r.types = l.types | rt.types;
        auto& d = d_[n];
        float dist[kWidth + 1];
        int8_t at[kWidth + 1];
        for (int j = 2; j <= kWidth; ++j) {
            dist[j] = kInfinity, at[j] = 1;
            for (int k = 1; k < j; ++k) {
                const float c = l.c[k] + rt.c[j - k];
                if (c < dist[j]) dist[j] = c, at[j] = int8_t(k);
            }
        }
        d[0] = at[kWidth];
        const float as_node = area * CollapseCost::kNode + dist[kWidth];
        const bool one_type = (r.types & (r.types - 1)) == 0;
        const float as_leaf = r.prims <= max_leaf_ && one_type ? area * CollapseCost::leaf(r.prims) : kInfinity;
        d[1] = as_leaf <= as_node;
        r.c[1] = std::min(as_leaf, as_node);
        for (int i = 2; i <= kWidth; ++i) {
            if (dist[i] < r.c[i - 1])
                r.c[i] = dist[i], d[i] = at[i];
            else
                r.c[i] = r.c[i - 1], d[i] = 0;
        }
        return r;
    }

    /// Subtrees above this binary depth are solved as parallel tasks (2^12 at most).
    static constexpr int kParallelDepth = 12;

    const std::vector<Node>& nodes_;
    const std::vector<PrimRef>& order_;
    std::span<const GeometryView> g_;
    uint32_t max_leaf_;
    std::vector<std::array<int8_t, kWidth + 1>> d_;
};

/// Orders the lanes of a wide node by surface area, largest first (stable): the any-hit
/// walks of masked trees and of the top tree enter the lowest hit lane first, and a ray
/// meets a box with a chance that grows with its area (the SAH's own argument, MacDonald
/// and Booth 1990), so the likeliest occluder comes first (accel/DECISIONS.md, "any-hit
/// order of masked trees", "top-level any-hit order"). The closest-hit walks order by
/// distance and are unaffected. (By hand: std::sort over eight lanes trips GCC 12's
/// -Warray-bounds.)
void by_area(const std::vector<Node>& nodes, uint32_t* lanes, int k) {
    for (int i = 1; i < k; ++i)
        for (int j = i; j > 0 && nodes[lanes[j]].bounds().surface_area() > nodes[lanes[j - 1]].bounds().surface_area(); --j)
            std::swap(lanes[j], lanes[j - 1]);
}

/// Unused lanes hold an inverted box (+inf/-inf) that no ray hits, without NaN:
/// inf - finite stays inf.
void set_empty(WideNode& n, int i) {
    for (int a = 0; a < 3; ++a) n.b[a][i] = kInfinity, n.b[a + 3][i] = -kInfinity;
    n.child[i] = WideNode::kEmpty;
    n.count[i] = 0;
}

class Collapser {
public:
    Collapser(const BinaryTree& t, const Plan& plan, std::span<const GeometryView> g, TriangleTest test,
              LeafPrefetch prefetch, WideBvh& out)
        : nodes_(t.nodes), order_(t.order), plan_(plan), g_(g), test_(test), prefetch_(prefetch), out_(out) {
        out_.one_geom = order_.empty() ? 0 : order_[0].geom;
        several_ = std::any_of(order_.begin(), order_.end(), [&](const PrimRef& r) { return r.geom != out_.one_geom; });
        area_order_ = std::any_of(g_.begin(), g_.end(), [](const GeometryView& v) { return v.filter != nullptr; });
    }

    /// Builds the whole wide tree from binary interior node 0.
    void run() {
        top(0);
        tbb::parallel_for(size_t(0), jobs_.size(), [&](size_t i) {
            Job& j = jobs_[i];
            count(j.binary, j.nodes, j.blocks);
        });
        // Places in depth-first order: the walk node() makes, with each frontier
        // subtree taking the room it counted.
        uint32_t next_node = 0, next_block = 0;
        place(0, next_node, next_block);
        out_.leaf_hints = prefetch_ == LeafPrefetch::On ||
                          (prefetch_ == LeafPrefetch::Auto && uint64_t(next_block) * sizeof(Block) >= kLeafHintBytes);
        out_.nodes.reserve(next_node);
        out_.blocks.reserve(next_block);
        prepare_fresh(out_.nodes.data(), size_t(next_node) * sizeof(WideNode));
        prepare_fresh(out_.blocks.data(), size_t(next_block) * sizeof(Block));
        out_.nodes.resize(next_node);
        out_.blocks.resize(next_block);
        if (several_) out_.lane_geom.resize(size_t(next_block) * 4);
        for (const Top& t : tops_) write_top(t);
        tbb::parallel_for(size_t(0), jobs_.size(), [&](size_t i) {
            const Job& j = jobs_[i];
            uint32_t n = j.node_base, b = j.block_base;
            emit(j.binary, n, b);
        });
    }

    /// A tree that is one leaf still gets a WideNode around it.
    void lone_leaf() {
        const Node& c = nodes_[0];
        const Kid k{0, true, c.offset, c.count()};
        out_.nodes.resize(1);
        out_.blocks.resize(nblocks(k));
        if (several_) out_.lane_geom.resize(size_t(nblocks(k)) * 4);
        for (int i = 1; i < kWidth; ++i) set_empty(out_.nodes[0], i);
        for (int a = 0; a < 6; ++a) out_.nodes[0].b[a][0] = c.b[a];
        leaf(out_.nodes[0], 0, k, 0);
    }

private:
    /// One lane of a wide node: binary node `binary`, either a leaf of the primitives in
    /// slots [offset, offset + count) (a binary leaf, or a subtree the plan made one
    /// leaf) or an interior node that becomes a wide node of its own.
    struct Kid {
        uint32_t binary;
        bool leaf;
        uint32_t offset = 0, count = 0;  ///< leaves only
    };

    /// A subtree written by one task: binary interior node `binary` and all below it.
    struct Job {
        uint32_t binary;
        uint32_t nodes = 0, blocks = 0;           ///< counted
        uint32_t node_base = 0, block_base = 0;  ///< placed
    };
    /// A wide node above the frontier: its children as gathered, and for each interior
    /// one either the top node or the job that holds it.
    struct Top {
        uint32_t binary, self = 0;
        int n = 0;
        Kid kids[kWidth];
        uint32_t first_block[kWidth];  ///< leaf lanes: placed
        int32_t sub[kWidth];           ///< interior lanes: index into tops_ (>= 0) or ~job
    };

    static uint32_t nblocks(const Kid& c) { return (c.count + kLeafBlock - 1) / kLeafBlock; }

    /// The lanes of the wide node made from binary interior node `binary`, as the plan
    /// shares them out.
    int gather(uint32_t binary, Kid (&kids)[kWidth]) const {
        uint32_t lanes[kWidth];
        const int n = plan_.lanes_of(binary, lanes);
        // Trees with masked geometry: lanes by surface area (by_area). Opaque trees keep
        // the plan's order, and so their layout.
        if (area_order_) by_area(nodes_, lanes, n);
        for (int i = 0; i < n; ++i) {
            const uint32_t b = lanes[i];
            const Node& c = nodes_[b];
            if (c.is_leaf()) {
                kids[i] = {b, true, c.offset, c.count()};
            } else {
                kids[i] = {b, plan_.leaf(b)};
                if (kids[i].leaf) slots_under(b, kids[i].offset, kids[i].count);
            }
        }
        return n;
    }

    /// The slots under binary node `b`: its leaves cover consecutive slots, from its
    /// leftmost leaf's first to its rightmost leaf's last.
    void slots_under(uint32_t b, uint32_t& offset, uint32_t& count) const {
        uint32_t l = b, r = b;
        while (!nodes_[l].is_leaf()) l = nodes_[l].offset;
        while (!nodes_[r].is_leaf()) r = nodes_[r].offset + 1;
        offset = nodes_[l].offset;
        count = nodes_[r].offset + nodes_[r].count() - offset;
    }
    uint32_t prims_under(uint32_t b) const {
        uint32_t offset, count;
        slots_under(b, offset, count);
        return count;
    }

    /// Walks the wide nodes of more than kFrontier primitives, in depth-first order,
    /// and makes a job of every interior child below that size.
    int top(uint32_t binary) {
        const int me = int(tops_.size());
        tops_.emplace_back();
        Top t;
        t.binary = binary;
        t.n = gather(binary, t.kids);
        for (int i = 0; i < t.n; ++i) {
            if (t.kids[i].leaf) continue;
            if (prims_under(t.kids[i].binary) > kFrontier) {
                t.sub[i] = top(t.kids[i].binary);
            } else {
                t.sub[i] = ~int32_t(jobs_.size());
                jobs_.push_back({t.kids[i].binary});
            }
        }
        tops_[me] = t;
        return me;
    }

    /// Wide nodes and blocks of the wide subtree rooted at binary interior node `binary`.
    void count(uint32_t binary, uint32_t& wide, uint32_t& blocks) const {
        Kid kids[kWidth];
        const int n = gather(binary, kids);
        ++wide;
        for (int i = 0; i < n; ++i) {
            if (kids[i].leaf)
                blocks += nblocks(kids[i]);
            else
                count(kids[i].binary, wide, blocks);
        }
    }

    /// Gives top node `t` and everything below it their places, in the order the
    /// depth-first walk reaches them.
    void place(int ti, uint32_t& next_node, uint32_t& next_block) {
        Top& t = tops_[ti];
        t.self = next_node++;
        for (int i = 0; i < t.n; ++i) {
            const Kid& c = t.kids[i];
            if (c.leaf) {
                t.first_block[i] = next_block;
                next_block += nblocks(c);
            } else if (t.sub[i] >= 0) {
                place(t.sub[i], next_node, next_block);
            } else {
                Job& j = jobs_[~t.sub[i]];
                j.node_base = next_node;
                j.block_base = next_block;
                next_node += j.nodes;
                next_block += j.blocks;
            }
        }
    }

    void write_top(const Top& t) {
        WideNode& w = out_.nodes[t.self];
        for (int i = 0; i < kWidth; ++i) {
            if (i >= t.n) {
                set_empty(w, i);
                continue;
            }
            const Kid& c = t.kids[i];
            for (int k = 0; k < 6; ++k) w.b[k][i] = nodes_[c.binary].b[k];
            if (c.leaf) {
                leaf(w, i, c, t.first_block[i]);
            } else if (t.sub[i] >= 0) {
                w.count[i] = 0;  // a top node has more than kFrontier primitives: never a bottom node
                w.child[i] = tops_[t.sub[i]].self;
            } else {
                // A job of one wide node is a bottom node, its blocks all the job's.
                const Job& j = jobs_[~t.sub[i]];
                w.count[i] = out_.leaf_hints && j.nodes == 1 ? WideNode::leaves_hint(j.block_base, j.blocks) : 0u;
                w.child[i] = j.node_base;
            }
        }
    }

    /// Writes the wide subtree rooted at binary interior node `binary` from wide node
    /// `next_node` and block `next_block` on: the node first, then each lane's subtree
    /// in lane order, each leaf's blocks where the walk reaches it.
    uint32_t emit(uint32_t binary, uint32_t& next_node, uint32_t& next_block) {
        Kid kids[kWidth];
        const int n = gather(binary, kids);
        const uint32_t self = next_node++;
        WideNode& w = out_.nodes[self];  // sized once: the reference stays valid
        for (int i = 0; i < kWidth; ++i) {
            if (i >= n) {
                set_empty(w, i);
                continue;
            }
            const Kid& c = kids[i];
            for (int k = 0; k < 6; ++k) w.b[k][i] = nodes_[c.binary].b[k];
            if (c.leaf) {
                leaf(w, i, c, next_block);
                next_block += nblocks(c);
            } else {
                // A subtree of one wide node is a bottom node (an interior lane would
                // have added another), its blocks all the subtree's: as in write_top.
                const uint32_t node0 = next_node, block0 = next_block;
                w.child[i] = emit(c.binary, next_node, next_block);
                w.count[i] = out_.leaf_hints && next_node - node0 == 1
                                 ? WideNode::leaves_hint(block0, next_block - block0)
                                 : 0u;
            }
        }
        return self;
    }

    /// Links lane `lane` of `w` to the leaf's blocks from `first` on and packs them.
    void leaf(WideNode& w, int lane, const Kid& c, uint32_t first) {
        const bool spheres = g_[order_[c.offset].geom].type != GeometryType::Triangles;  // one type per leaf
        w.child[lane] = WideNode::kLeaf | first;
        w.count[lane] = WideNode::leaf_count(nblocks(c), c.count, spheres);
        fill_leaf(first, c.offset, c.count);
    }

    void fill_leaf(uint32_t first_block, uint32_t offset, uint32_t count) {
        const uint32_t nb = (count + kLeafBlock - 1) / kLeafBlock;
        for (uint32_t b = 0; b < nb; ++b) {
            Block blk{};
            for (int l = 0; l < 4; ++l) blk.prim[l] = Block::kNone;
            for (uint32_t l = 0; l < 4 && b * 4 + l < count; ++l) {
                const PrimRef ref = order_[offset + b * 4 + l];
                const GeometryView& g = g_[ref.geom];
                blk.prim[l] = ref.prim;
                if (several_) out_.lane_geom[size_t(first_block + b) * 4 + l] = ref.geom;
                Vec3f v[3];
                if (g.type == GeometryType::Triangles) {
                    triangle_vertices(g, ref.prim, v[0], v[1], v[2]);
                    if (test_ == TriangleTest::Fast) v[1] = v[1] - v[0], v[2] = v[2] - v[0];
                } else {
                    v[0] = sphere_center(g, ref.prim);
                    v[1] = Vec3f(sphere_radius(g, ref.prim), 0.0f, 0.0f);
                    v[2] = Vec3f(0.0f);
                }
                for (int k = 0; k < 3; ++k)
                    for (int a = 0; a < 3; ++a) blk.p[k][a][l] = v[k][a];
            }
            out_.blocks[first_block + b] = blk;
        }
    }

    const decltype(BinaryTree::nodes)& nodes_;
    const decltype(BinaryTree::order)& order_;
    const Plan& plan_;
    std::span<const GeometryView> g_;
    TriangleTest test_;
    LeafPrefetch prefetch_;
    WideBvh& out_;
    bool several_ = false;  ///< primitives of more than one geometry: lanes record theirs
    bool area_order_ = false;  ///< some geometry is masked: lanes by area (gather)
    std::vector<Top> tops_;
    std::vector<Job> jobs_;
};

}  // namespace

double wide_sah_cost(const WideBvh& w) {
    if (w.nodes.empty()) return 0.0;
    const double root = Bounds3f{{w.root[0], w.root[1], w.root[2]}, {w.root[3], w.root[4], w.root[5]}}.surface_area();
    double cost = 0.0;
    struct Item {
        uint32_t node;
        double area;
    };
    std::vector<Item> stack{{0, root}};
    while (!stack.empty()) {
        const Item it = stack.back();
        stack.pop_back();
        cost += it.area * CollapseCost::kNode;
        const WideNode& n = w.nodes[it.node];
        for (int i = 0; i < kWidth; ++i) {
            if (n.child[i] == WideNode::kEmpty) continue;
            const double a = Bounds3f{{n.b[0][i], n.b[1][i], n.b[2][i]}, {n.b[3][i], n.b[4][i], n.b[5][i]}}.surface_area();
            if (!(n.child[i] & WideNode::kLeaf)) {
                stack.push_back({n.child[i], a});
                continue;
            }
            cost += a * CollapseCost::leaf(WideNode::leaf_prims(n.count[i]));
        }
    }
    return cost / root;
}

WideBvh collapse(const BinaryTree& tree, std::span<const GeometryView> geometry, TriangleTest test,
                 uint32_t max_leaf, LeafPrefetch prefetch) {
    WideBvh w;
    if (tree.nodes.empty()) return w;
    for (int k = 0; k < 6; ++k) w.root[k] = tree.nodes[0].b[k];
    const Plan plan(tree.nodes, tree.order, geometry, max_leaf);
    Collapser c(tree, plan, geometry, test, prefetch, w);
    if (tree.nodes[0].is_leaf())
        c.lone_leaf();
    else
        c.run();
    return w;
}

void collapse_top(const BinaryTree& tree, TraversalVector<WideNode>& out) {
    out.clear();
    if (tree.nodes.empty()) return;
    const std::vector<Node>& nodes = tree.nodes;
    // max_leaf 0: no interior node becomes a leaf, so the plan only shares lanes out,
    // filling the wide nodes where the greedy collapse left them half empty.
    const Plan plan(nodes, tree.order, {}, 0);
    const auto make = [&](auto& self, uint32_t n) -> uint32_t {
        uint32_t lanes[kWidth];
        int k = 0;
        if (nodes[n].is_leaf())
            lanes[k++] = n;
        else
            k = plan.lanes_of(n, lanes);
        by_area(nodes, lanes, k);
        const uint32_t me = uint32_t(out.size());
        out.emplace_back();
        for (int i = 0; i < kWidth; ++i) {
            if (i >= k) {
                set_empty(out[me], i);
                continue;
            }
            const Node& b = nodes[lanes[i]];
            for (int r = 0; r < 6; ++r) out[me].b[r][i] = b.b[r];
            if (b.is_leaf()) {
                out[me].child[i] = WideNode::kLeaf | b.offset;
                out[me].count[i] = b.count();
            } else {
                const uint32_t c = self(self, lanes[i]);  // may grow out: index again
                out[me].child[i] = c;
                out[me].count[i] = 0;
            }
        }
        return me;
    };
    // A full wide node takes seven binary interior nodes (n - 1 of them for n leaves):
    // about 1/14 of the binary nodes; the array is cut to size after.
    out.reserve(nodes.size() / 13 + 1);
    make(make, 0);
    out.shrink_to_fit();
}

}  // namespace accel::bvh
