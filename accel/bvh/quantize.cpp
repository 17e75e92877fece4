// The compressed wide nodes (Ylitie, Karras, Laine 2017, "Efficient Incoherent Ray
// Traversal on GPUs Through Compressed Wide BVHs", HPG; section 3.1): a post-pass over
// the collapsed float tree, so the collapse itself (wide.cpp) knows nothing of it.
//
// Per node and axis the grid is origin + q * 2^e with q in 0..255: origin is the low
// corner of the union of the children's boxes, e the smallest exponent whose 255 steps
// reach the high corner. Each child bound is rounded outward on that grid, and checked
// against the float value the kernel will compute (origin + q * 2^e rounds once: the
// product of an 8-bit integer and a power of two is exact), so every dequantised box
// contains its float box in float arithmetic, not merely in exact arithmetic.
#include <atomic>
#include <cmath>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "accel/bvh/wide.h"

namespace accel::bvh {
namespace {

/// 2^(biased - 127), a normal float for biased in 1..254.
float step(int biased) {
    return std::ldexp(1.0f, biased - 127);
}

/// The kernel's dequantisation, in the same float operations (an FMA or mul + add:
/// identical, because the product is exact).
float grid(float origin, int q, float s) {
    return origin + float(q) * s;
}

/// Quantises one axis of node `n` into `out`; false if no exponent fits.
bool axis(const WideNode& n, int a, int lanes, QuantNode& out) {
    float lo = kInfinity, hi = -kInfinity;
    for (int i = 0; i < lanes; ++i) {
        if (!std::isfinite(n.b[a][i]) || !std::isfinite(n.b[a + 3][i])) return false;
        lo = std::min(lo, n.b[a][i]);
        hi = std::max(hi, n.b[a + 3][i]);
    }
    if (lanes == 0) lo = hi = 0.0f;
    out.origin[a] = lo;
    // The smallest exponent that could reach hi in 255 steps; rounding of the grid
    // additions may need one or two more, found by the loop. 246 keeps 255 * 2^e finite.
    const double extent = double(hi) - double(lo);
    int e = 1;
    if (extent > 0) e = std::max(1, std::ilogb(extent / 255.0) + 127);
    for (; e <= 246; ++e) {
        const float s = step(e);
        bool fits = true;
        for (int i = 0; i < lanes && fits; ++i) {
            const float blo = n.b[a][i], bhi = n.b[a + 3][i];
            int qlo = int(std::clamp(std::floor((double(blo) - double(lo)) / s), 0.0, 255.0));
            while (qlo > 0 && grid(lo, qlo, s) > blo) --qlo;  // q = 0 is lo itself: always below
            int qhi = int(std::clamp(std::ceil((double(bhi) - double(lo)) / s), 0.0, 255.0));
            while (qhi < 255 && grid(lo, qhi, s) < bhi) ++qhi;
            fits = grid(lo, qhi, s) >= bhi;
            out.q[a][i] = uint8_t(qlo);
            out.q[a + 3][i] = uint8_t(qhi);
        }
        if (fits) {
            out.exp[a] = uint8_t(e);
            return true;
        }
    }
    return false;
}

}  // namespace

void dequantize(const QuantNode& n, int lane, float box[6]) {
    for (int a = 0; a < 3; ++a) {
        const float s = step(n.exp[a]);
        box[a] = grid(n.origin[a], n.q[a][lane], s);
        box[a + 3] = grid(n.origin[a], n.q[a + 3][lane], s);
    }
}

bool quantize(WideBvh& w, bool keep_float) {
    TraversalVector<QuantNode> q(w.nodes.size());
    // Nodes are independent: in parallel, on the caller's arena (the build's threads).
    std::atomic<bool> ok{true};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, w.nodes.size(), 4096), [&](const tbb::blocked_range<size_t>& r) {
        for (size_t k = r.begin(); k < r.end(); ++k) {
            const WideNode& n = w.nodes[k];
            QuantNode& o = q[k];
            o = QuantNode{};
            // The collapse fills lanes from 0 and leaves the rest empty.
            int lanes = 0;
            while (lanes < kWidth && n.child[lanes] != WideNode::kEmpty) ++lanes;
            o.valid = uint8_t((1u << lanes) - 1);
            for (int i = 0; i < kWidth; ++i) o.child[i] = n.child[i], o.count[i] = n.count[i];
            for (int a = 0; a < 3; ++a)
                if (!axis(n, a, lanes, o)) ok = false;
        }
    });
    if (!ok) return false;
    w.qnodes = std::move(q);
    if (!keep_float) TraversalVector<WideNode>().swap(w.nodes);
    return true;
}

}  // namespace accel::bvh
