// Ray-triangle intersectors shared by every backend of ours (naive, custom BVH, and
// Embree's counting mode), so that they differ only in which triangles they test.
#pragma once

#include <cmath>
#include <utility>

#include "accel/math.h"
#include "accel/ray.h"

namespace accel {

/// Per-ray constants for the watertight test (Woop, Benthin, Wald 2013, "Watertight
/// Ray/Triangle Intersection", JCGT 2(1)): the axis permutation and shear that map the
/// ray onto +z. Computed once per ray, reused for every triangle.
struct WatertightRay {
    int kx = 0, ky = 1, kz = 2;
    float sx = 0, sy = 0, sz = 1;

    WatertightRay() = default;
    /// Always inlined: the per-ISA BVH kernels construct it, and an out-of-line copy would
    /// be a weak symbol the linker could take from the AVX2 object for every caller
    /// (tests/bvh/kernel_symbols.cmake).
    [[gnu::always_inline]] explicit WatertightRay(const Vec3f& dir) {
        kz = max_dimension(vabs(dir));
        kx = kz + 1 == 3 ? 0 : kz + 1;
        ky = kx + 1 == 3 ? 0 : kx + 1;
        // Swapping keeps the winding (and so the sign of U, V, W) consistent.
        if (dir[kz] < 0.0f) std::swap(kx, ky);
        sx = dir[kx] / dir[kz];
        sy = dir[ky] / dir[kz];
        sz = 1.0f / dir[kz];
    }
};

/// Result of one ray-triangle test: t and barycentrics of v1 (u) and v2 (v).
struct TriangleHit {
    float t, u, v;
};

/// Möller–Trumbore 1997, "Fast, Minimum Storage Ray/Triangle Intersection". The
/// comparisons are written so that NaN fails them. A ray exactly parallel to the plane
/// (det == 0) misses; we deliberately use no epsilon on det, which would depend on the
/// scene's scale. Not watertight: a ray through a shared edge can slip between both
/// triangles by rounding.
inline bool intersect_triangle_mt(const Ray& ray, const Vec3f& v0, const Vec3f& v1,
                                  const Vec3f& v2, float t_max, TriangleHit& out) {
    const Vec3f e1 = v1 - v0, e2 = v2 - v0;
    const Vec3f p = cross(ray.dir, e2);
    const float det = dot(e1, p);
    if (det == 0.0f) return false;
    const float inv_det = 1.0f / det;
    const Vec3f s = ray.org - v0;
    const float u = dot(s, p) * inv_det;
    if (!(u >= 0.0f && u <= 1.0f)) return false;
    const Vec3f q = cross(s, e1);
    const float v = dot(ray.dir, q) * inv_det;
    if (!(v >= 0.0f && u + v <= 1.0f)) return false;
    const float t = dot(e2, q) * inv_det;
    if (!(t >= ray.t_min && t <= t_max)) return false;
    out = {t, u, v};
    return true;
}

/// Woop, Benthin, Wald 2013. Edge functions are evaluated in a sheared, ray-aligned
/// frame; an edge function that rounds to exactly 0 is recomputed in double so that two
/// triangles sharing an edge always agree on which side the ray passes (no ray slips
/// between them). Edge hits (U, V or W == 0) count as hits on both sides.
inline bool intersect_triangle_wt(const Ray& ray, const WatertightRay& wr, const Vec3f& v0,
                                  const Vec3f& v1, const Vec3f& v2, float t_max,
                                  TriangleHit& out) {
    const Vec3f A = v0 - ray.org, B = v1 - ray.org, C = v2 - ray.org;
    const float Ax = A[wr.kx] - wr.sx * A[wr.kz], Ay = A[wr.ky] - wr.sy * A[wr.kz];
    const float Bx = B[wr.kx] - wr.sx * B[wr.kz], By = B[wr.ky] - wr.sy * B[wr.kz];
    const float Cx = C[wr.kx] - wr.sx * C[wr.kz], Cy = C[wr.ky] - wr.sy * C[wr.kz];
    float U = Cx * By - Cy * Bx;
    float V = Ax * Cy - Ay * Cx;
    float W = Bx * Ay - By * Ax;
    if (U == 0.0f || V == 0.0f || W == 0.0f) {
        U = float(double(Cx) * double(By) - double(Cy) * double(Bx));
        V = float(double(Ax) * double(Cy) - double(Ay) * double(Cx));
        W = float(double(Bx) * double(Ay) - double(By) * double(Ax));
    }
    if ((U < 0.0f || V < 0.0f || W < 0.0f) && (U > 0.0f || V > 0.0f || W > 0.0f))
        return false;
    const float det = U + V + W;
    if (!(det != 0.0f)) return false;  // also rejects NaN
    const float Az = wr.sz * A[wr.kz], Bz = wr.sz * B[wr.kz], Cz = wr.sz * C[wr.kz];
    const float T = U * Az + V * Bz + W * Cz;
    const float inv_det = 1.0f / det;
    const float t = T * inv_det;
    if (!(t >= ray.t_min && t <= t_max)) return false;
    out = {t, V * inv_det, W * inv_det};
    return true;
}

/// Unnormalised geometric normal, following the winding v0 -> v1 -> v2.
inline Vec3f triangle_normal(const Vec3f& v0, const Vec3f& v1, const Vec3f& v2) {
    return cross(v1 - v0, v2 - v0);
}

/// True for triangles no ray can meaningfully hit: non-finite coordinates or zero area.
inline bool triangle_is_degenerate(const Vec3f& v0, const Vec3f& v1, const Vec3f& v2) {
    if (!is_finite(v0) || !is_finite(v1) || !is_finite(v2)) return true;
    const Vec3f n = triangle_normal(v0, v1, v2);
    // Largest component rather than dot(n, n), which underflows for tiny triangles.
    return !(max_component(vabs(n)) > 0.0f);
}

inline Bounds3f triangle_bounds(const Vec3f& v0, const Vec3f& v1, const Vec3f& v2) {
    Bounds3f b;
    b.extend(v0);
    b.extend(v1);
    b.extend(v2);
    return b;
}

}  // namespace accel
