// Collapse of the binary tree into the 8-wide layout and packing of leaf blocks
// (Dammertz et al. 2008; Wald et al. 2008; blocks as Embree's triangle4, Wald et al. 2014).
#include "accel/bvh/wide.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace accel::bvh {
namespace {

class Collapser {
public:
    Collapser(const BinaryTree& t, std::span<const GeometryView> g, TriangleTest test, WideBvh& out)
        : t_(t), g_(g), test_(test), out_(out) {}

    /// Emits binary interior node `binary` as one WideNode; children follow their
    /// parent depth-first, and each leaf's blocks are appended as the leaf is reached.
    uint32_t node(uint32_t binary) {
        const std::vector<Node>& nodes = t_.nodes;
        uint32_t kids[kWidth] = {nodes[binary].offset, nodes[binary].offset + 1};
        int n = 2;
        // Open the interior child with the largest surface area (the one most rays
        // would enter) until kWidth children are gathered.
        while (n < kWidth) {
            int best = -1;
            float best_area = -1.0f;
            for (int i = 0; i < n; ++i) {
                const Node& c = nodes[kids[i]];
                if (!c.is_leaf() && c.bounds().surface_area() > best_area) {
                    best = i;
                    best_area = c.bounds().surface_area();
                }
            }
            if (best < 0) break;
            const uint32_t open = kids[best];
            kids[best] = nodes[open].offset;
            kids[n++] = nodes[open].offset + 1;
        }
        const uint32_t self = uint32_t(out_.nodes.size());
        out_.nodes.emplace_back();
        for (int i = 0; i < kWidth; ++i) {
            if (i >= n) {
                set_empty(self, i);
                continue;
            }
            const Node& c = nodes[kids[i]];
            for (int k = 0; k < 6; ++k) out_.nodes[self].b[k][i] = c.b[k];
            if (c.is_leaf()) {
                leaf(self, i, c);
            } else {
                out_.nodes[self].count[i] = 0;
                const uint32_t ci = node(kids[i]);  // may reallocate: no reference kept
                out_.nodes[self].child[i] = ci;
            }
        }
        return self;
    }

    /// A tree that is one leaf still gets a WideNode around it.
    void lone_leaf() {
        out_.nodes.emplace_back();
        for (int i = 1; i < kWidth; ++i) set_empty(0, i);
        for (int k = 0; k < 6; ++k) out_.nodes[0].b[k][0] = t_.nodes[0].b[k];
        leaf(0, 0, t_.nodes[0]);
    }

private:
    /// Unused lanes hold an inverted box (+inf/-inf) that no ray hits, without NaN:
    /// inf - finite stays inf.
    void set_empty(uint32_t w, int i) {
        WideNode& n = out_.nodes[w];
        for (int a = 0; a < 3; ++a) n.b[a][i] = kInfinity, n.b[a + 3][i] = -kInfinity;
        n.child[i] = WideNode::kEmpty;
        n.count[i] = 0;
    }

    /// Reserves the leaf's blocks and links them; fill() writes them later, in parallel.
    void leaf(uint32_t w, int lane, const Node& c) {
        const uint32_t first = next_block_;
        const uint32_t nblocks = (c.count() + kLeafBlock - 1) / kLeafBlock;
        next_block_ += nblocks;
        leaves_.push_back({first, c.offset, c.count()});
        const bool spheres = g_[t_.order[c.offset].geom].type != GeometryType::Triangles;  // one type per leaf
        out_.nodes[w].child[lane] = WideNode::kLeaf | first;
        out_.nodes[w].count[lane] = nblocks | (spheres ? WideNode::kSpheres : 0u);
    }

public:
    /// Packs every leaf's primitives into its blocks (independent, so in parallel).
    void fill() {
        out_.blocks.resize(next_block_);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, leaves_.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
            for (size_t i = r.begin(); i < r.end(); ++i) fill_leaf(leaves_[i]);
        });
    }

private:
    struct Leaf {
        uint32_t first_block, offset, count;
    };

    void fill_leaf(const Leaf& f) {
        const uint32_t nblocks = (f.count + kLeafBlock - 1) / kLeafBlock;
        for (uint32_t b = 0; b < nblocks; ++b) {
            Block blk{};
            for (int l = 0; l < 4; ++l) blk.slot[l] = Block::kNone;
            for (uint32_t l = 0; l < 4 && b * 4 + l < f.count; ++l) {
                const uint32_t slot = f.offset + b * 4 + l;
                const PrimRef ref = t_.order[slot];
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
            out_.blocks[f.first_block + b] = blk;
        }
    }

    const BinaryTree& t_;
    std::span<const GeometryView> g_;
    TriangleTest test_;
    WideBvh& out_;
    uint32_t next_block_ = 0;
    std::vector<Leaf> leaves_;
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
        c.node(0);
    c.fill();                 // blocks: sized exactly once, no slack
    w.nodes.shrink_to_fit();  // growth left up to 2x slack (and 2 MiB rounding)
    return w;
}

}  // namespace accel::bvh
