// Collapse of the binary tree into the 8-wide layout and packing of leaf blocks
// (Dammertz et al. 2008; Wald et al. 2008; blocks as Embree's triangle4, Wald et al. 2014).
//
// The collapse runs in parallel and gives the very layout a serial depth-first collapse
// gives, at any thread count: the top of the wide tree is walked serially down to a
// frontier of subtrees (kFrontier primitives or fewer), each frontier subtree is counted
// (wide nodes, blocks) in parallel, the counts give every subtree its place in the
// depth-first order, and the subtrees are then written, blocks included, in parallel
// straight into the final arrays. Counting twice costs less than it saves: no array
// grows, no subtree is copied, and the arrays are written once (the serial collapse
// was ~10 % of the 5M-triangle build; benchmarks/RESULTS.md, issue 13).
#include "accel/bvh/wide.h"

#include <tbb/parallel_for.h>


namespace accel::bvh {
namespace {

/// Subtrees of at most this many primitives are collapsed by one task.
constexpr uint32_t kFrontier = 16384;

class Collapser {
public:
    Collapser(const BinaryTree& t, std::span<const GeometryView> g, TriangleTest test, WideBvh& out)
        : nodes_(t.nodes), order_(t.order), g_(g), test_(test), out_(out) {}

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
        out_.nodes.reserve(next_node);
        out_.blocks.reserve(next_block);
        prepare_fresh(out_.nodes.data(), size_t(next_node) * sizeof(WideNode));
        prepare_fresh(out_.blocks.data(), size_t(next_block) * sizeof(Block));
        out_.nodes.resize(next_node);
        out_.blocks.resize(next_block);
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
        out_.nodes.resize(1);
        out_.blocks.resize(nblocks(c));
        for (int i = 1; i < kWidth; ++i) set_empty(out_.nodes[0], i);
        for (int k = 0; k < 6; ++k) out_.nodes[0].b[k][0] = c.b[k];
        leaf(out_.nodes[0], 0, c, 0);
    }

private:
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
        uint32_t kids[kWidth];
        uint32_t first_block[kWidth];  ///< leaf lanes: placed
        int32_t sub[kWidth];           ///< interior lanes: index into tops_ (>= 0) or ~job
    };

    static uint32_t nblocks(const Node& c) { return (c.count() + kLeafBlock - 1) / kLeafBlock; }

    /// The children of the wide node made from binary interior node `binary`: open the
    /// interior child with the largest surface area (the one most rays would enter)
    /// until kWidth children are gathered.
    int gather(uint32_t binary, uint32_t (&kids)[kWidth]) const {
        kids[0] = nodes_[binary].offset;
        kids[1] = nodes_[binary].offset + 1;
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
        return n;
    }

    /// Primitives under binary node `b`: its leaves cover consecutive slots, from its
    /// leftmost leaf's first to its rightmost leaf's last.
    uint32_t prims_under(uint32_t b) const {
        uint32_t l = b, r = b;
        while (!nodes_[l].is_leaf()) l = nodes_[l].offset;
        while (!nodes_[r].is_leaf()) r = nodes_[r].offset + 1;
        return nodes_[r].offset + nodes_[r].count() - nodes_[l].offset;
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
            if (nodes_[t.kids[i]].is_leaf()) continue;
            if (prims_under(t.kids[i]) > kFrontier) {
                t.sub[i] = top(t.kids[i]);
            } else {
                t.sub[i] = ~int32_t(jobs_.size());
                jobs_.push_back({t.kids[i]});
            }
        }
        tops_[me] = t;
        return me;
    }

    /// Wide nodes and blocks of the wide subtree rooted at binary interior node `binary`.
    void count(uint32_t binary, uint32_t& wide, uint32_t& blocks) const {
        uint32_t kids[kWidth];
        const int n = gather(binary, kids);
        ++wide;
        for (int i = 0; i < n; ++i) {
            const Node& c = nodes_[kids[i]];
            if (c.is_leaf())
                blocks += nblocks(c);
            else
                count(kids[i], wide, blocks);
        }
    }

    /// Gives top node `t` and everything below it their places, in the order the
    /// depth-first walk reaches them.
    void place(int ti, uint32_t& next_node, uint32_t& next_block) {
        Top& t = tops_[ti];
        t.self = next_node++;
        for (int i = 0; i < t.n; ++i) {
            const Node& c = nodes_[t.kids[i]];
            if (c.is_leaf()) {
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
            const Node& c = nodes_[t.kids[i]];
            for (int k = 0; k < 6; ++k) w.b[k][i] = c.b[k];
            if (c.is_leaf()) {
                leaf(w, i, c, t.first_block[i]);
            } else {
                w.count[i] = 0;
                w.child[i] = t.sub[i] >= 0 ? tops_[t.sub[i]].self : jobs_[~t.sub[i]].node_base;
            }
        }
    }

    /// Writes the wide subtree rooted at binary interior node `binary` from wide node
    /// `next_node` and block `next_block` on: the node first, then each lane's subtree
    /// in lane order, each leaf's blocks where the walk reaches it.
    uint32_t emit(uint32_t binary, uint32_t& next_node, uint32_t& next_block) {
        uint32_t kids[kWidth];
        const int n = gather(binary, kids);
        const uint32_t self = next_node++;
        WideNode& w = out_.nodes[self];  // sized once: the reference stays valid
        for (int i = 0; i < kWidth; ++i) {
            if (i >= n) {
                set_empty(w, i);
                continue;
            }
            const Node& c = nodes_[kids[i]];
            for (int k = 0; k < 6; ++k) w.b[k][i] = c.b[k];
            if (c.is_leaf()) {
                leaf(w, i, c, next_block);
                next_block += nblocks(c);
            } else {
                w.count[i] = 0;
                w.child[i] = emit(kids[i], next_node, next_block);
            }
        }
        return self;
    }

    /// Unused lanes hold an inverted box (+inf/-inf) that no ray hits, without NaN:
    /// inf - finite stays inf.
    static void set_empty(WideNode& n, int i) {
        for (int a = 0; a < 3; ++a) n.b[a][i] = kInfinity, n.b[a + 3][i] = -kInfinity;
        n.child[i] = WideNode::kEmpty;
        n.count[i] = 0;
    }

    /// Links lane `lane` of `w` to the leaf's blocks from `first` on and packs them.
    void leaf(WideNode& w, int lane, const Node& c, uint32_t first) {
        const bool spheres = g_[order_[c.offset].geom].type != GeometryType::Triangles;  // one type per leaf
        w.child[lane] = WideNode::kLeaf | first;
        w.count[lane] = nblocks(c) | (spheres ? WideNode::kSpheres : 0u);
        fill_leaf(first, c.offset, c.count());
    }

    void fill_leaf(uint32_t first_block, uint32_t offset, uint32_t count) {
        const uint32_t nb = (count + kLeafBlock - 1) / kLeafBlock;
        for (uint32_t b = 0; b < nb; ++b) {
            Block blk{};
            for (int l = 0; l < 4; ++l) blk.slot[l] = Block::kNone;
            for (uint32_t l = 0; l < 4 && b * 4 + l < count; ++l) {
                const uint32_t slot = offset + b * 4 + l;
                const PrimRef ref = order_[slot];
                const GeometryView& g = g_[ref.geom];
                blk.slot[l] = slot;
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
    std::span<const GeometryView> g_;
    TriangleTest test_;
    WideBvh& out_;
    std::vector<Top> tops_;
    std::vector<Job> jobs_;
};

}  // namespace

WideBvh collapse(const BinaryTree& tree, std::span<const GeometryView> geometry, TriangleTest test) {
    WideBvh w;
    if (tree.nodes.empty()) return w;
    for (int k = 0; k < 6; ++k) w.root[k] = tree.nodes[0].b[k];
    Collapser c(tree, geometry, test, w);
    if (tree.nodes[0].is_leaf())
        c.lone_leaf();
    else
        c.run();
    return w;
}

}  // namespace accel::bvh
