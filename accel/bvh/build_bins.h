// What the binned-SAH builders share (build.cpp, build_sbvh.cpp): the centroid bins of
// Wald 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies", the SAH
// constants and the sweep over bin borders. Internal to the builders.
#pragma once

#include <cstdint>
#include <limits>

#include "accel/bvh/build.h"
#include "accel/math.h"

namespace accel::bvh::binned {

// Bin the centroids into K equal intervals per axis, evaluate the SAH at the K-1 borders.
constexpr int kBins = 32;
// SAH constants for both the build decision and the reported cost: C_trav = C_isect = 1.
constexpr double kCostTraversal = 1.0;
constexpr double kCostIntersect = 1.0;
/// Below this depth splits are free; from it on, object medians (see kStackSize).
constexpr uint32_t kMaxFreeDepth = 90;

/// SIMD blocks a leaf of n primitives fills: what the leaf kernel pays for it.
inline double blocks(uint32_t n) { return double((n + kLeafBlock - 1) / kLeafBlock); }

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

/// Maps a coordinate to its bin; the same function classifies for counting and for
/// partitioning, so the partition matches the evaluated split exactly.
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

/// The cheapest split between bins: cost = SA(left) * blocks(left) + SA(right) *
/// blocks(right) (the SAH without the 1/SA(parent) factor and C_trav).
struct Sweep {
    double cost = std::numeric_limits<double>::infinity();
    int axis = -1, split = 0;  ///< bins < split go left
    Bounds3f left, right;      ///< the two children's boxes at the best split (if asked for)
    uint32_t n_left = 0, n_right = 0;
};

/// `lcount`/`rcount` per bin: what enters the left and the right side when the border is
/// right of / left of that bin (the same counts for object bins; entries and exits for
/// spatial bins, Stich et al. 2009). Axes with `usable[a]` false are skipped.
inline void sweep(const Bounds3f (&b)[3][kBins], const uint32_t (&lcount)[3][kBins],
                  const uint32_t (&rcount)[3][kBins], const bool (&usable)[3], Sweep& best,
                  bool boxes = true) {
    for (int a = 0; a < 3; ++a) {
        if (!usable[a]) continue;
        // Right-to-left: area and count of everything at or right of bin i (plain
        // floats: this runs for every node, and most nodes are small).
        float right_area[kBins];
        uint32_t right_n[kBins];
        Bounds3f acc;
        uint32_t cnt = 0;
        for (int i = kBins - 1; i > 0; --i) {
            acc.extend(b[a][i]);
            cnt += rcount[a][i];
            right_area[i] = acc.surface_area();
            right_n[i] = cnt;
        }
        acc = Bounds3f{};
        cnt = 0;
        for (int i = 1; i < kBins; ++i) {
            acc.extend(b[a][i - 1]);
            cnt += lcount[a][i - 1];
            if (cnt == 0 || right_n[i] == 0) continue;
            const double cost = double(acc.surface_area()) * blocks(cnt) + double(right_area[i]) * blocks(right_n[i]);
            if (cost < best.cost) {
                best.cost = cost, best.axis = a, best.split = i;
                best.n_left = cnt, best.n_right = right_n[i];
            }
        }
    }
    if (!boxes || best.axis < 0) return;
    best.left = best.right = Bounds3f{};
    for (int i = 0; i < kBins; ++i) (i < best.split ? best.left : best.right).extend(b[best.axis][i]);
}

}  // namespace accel::bvh::binned
