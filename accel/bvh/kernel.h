// The traversal kernel: one template over a SIMD policy, instantiated once per
// instruction set by kernel_sse2.cpp, kernel_avx2.cpp and kernel_avx512.cpp, each compiled
// with its own flags (STYLE.md section 9; Embree's per-ISA kernels, Wald et al. 2014).
// Everything lives in the namespace PT_KERNEL_NS the including file names, so no inline
// function instantiated here can be shared with (and picked by the linker for) another ISA.
//
// Algorithms: the slab test with per-ray near/far planes chosen by the direction's sign
// bits (Williams, Barrus, Morley, Shirley 2005, "An Efficient and Robust Ray-Box
// Intersection Algorithm"), made conservative by scaling the far distance (Ize 2013,
// "Robust BVH Ray Traversal", JCGT 2(2)); ordered traversal of wide nodes with a no-stack
// path for one hit child and stack entries beyond the closest hit dropped on pop (Wald et
// al. 2008, "Getting Rid of Packets"); leaf blocks of four triangles tested by Möller–
// Trumbore 1997 or the watertight test of Woop, Benthin, Wald 2013 (JCGT 2(1)), one block
// per SSE test, two per AVX test, up to four per AVX-512 any-hit test.
#pragma once

#ifndef PT_KERNEL_NS
#error "kernel.h is included by one kernel_ISA.cpp that defines PT_KERNEL_NS"
#endif

#include <emmintrin.h>
#ifdef __AVX__
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>
#include <utility>
#include <limits>

#include "accel/bvh/base.h"
#include "accel/bvh/instanced.h"
#include "accel/sphere.h"
#include "accel/triangle.h"

/// Forced inlining of the per-ray and per-node helpers: with several policies per file
/// (float and quantized nodes) GCC's unit-growth limits otherwise leave some out of line
/// (measured: Planes, LeafRay and the quantized node test became calls, ~40 more
/// instructions per shadow ray).
#define PT_INLINE __attribute__((always_inline))

namespace accel::bvh::PT_KERNEL_NS {

/// gamma(n) = n*u / (1 - n*u), u = 2^-24 (pbrt's notation). A slab distance
/// (b - o) * inv carries three roundings (the difference, 1/d, the product), so a box
/// the ray truly enters can come out with its far distance below its near one; Ize 2013
/// scales the far distance by 1 + 2*gamma(3) to keep it. Here the scale is folded into
/// the inverse direction the far planes use (inv_far = inv * kFarScale, once per ray),
/// a fourth rounding, hence gamma(4): the far distance is then >= its true value times
/// (1 + 2*gamma(4)) * (1 - gamma(4)) >= 1 + gamma(3), the most the near distance can
/// exceed its own. Folding takes the multiply off the end of each node test's
/// dependent chain (see Node8::test).
constexpr float kUnitRoundoff = std::numeric_limits<float>::epsilon() * 0.5f;
constexpr float gamma_n(int n) { return (n * kUnitRoundoff) / (1 - n * kUnitRoundoff); }
constexpr float kFarScale = 1.0f + 2.0f * gamma_n(4);


/// Per-ray slab constants: the origin, the negated inverse direction (BoxConstants says
/// why negated; -1/d is -(1/d) bit for bit), and for each axis which row of the box is
/// the near plane, picked by the sign bit so that -0 behaves like a negative direction.
/// This specialises every box test to the ray's octant without a branch. (A table of the
/// eight octants' rows, indexed by a movmskps of the direction, took ~10 instructions
/// off each ray but put a load before the first node's addresses: shadow rays 2-5 %
/// slower; accel/DECISIONS.md, "octant table (dropped)".)
struct Planes {
    float org[3], neg_inv[3];
    int near[3], far[3];
    PT_INLINE explicit Planes(const Ray& r) {
        for (int a = 0; a < 3; ++a) {
            org[a] = r.org[a];
            neg_inv[a] = -1.0f / r.dir[a];
            const bool neg = std::signbit(r.dir[a]);
            near[a] = neg ? a + 3 : a;
            far[a] = neg ? a : a + 3;
        }
    }
};

/// Broadcast of one float to every lane of V (kernel files add their wider types).
template <class V>
V splat(float x);
template <>
inline __m128 splat<__m128>(float x) { return _mm_set1_ps(x); }
#ifdef __AVX__  // only the files compiled with -mavx2 or wider see 256-bit vectors
template <>
inline __m256 splat<__m256>(float x) { return _mm256_set1_ps(x); }
#endif

/// Per-ray constants of a node test over vectors V: origin, the negated inverse direction
/// for the near planes and, scaled by kFarScale, for the far ones, the near accumulator's
/// start value, the far one's (the closest hit so far times kFarScale, updated by limit()
/// only when a hit shortens the segment, not splat per node) and the near/far rows of
/// Planes. Negated, so that a slab distance is (o - b) * -inv: the node's row is then
/// the subtraction's second operand, which x86 takes straight from memory, one
/// instruction instead of a load and a subtraction (six per node test). The bits are
/// (b - o) * inv's: IEEE negation is exact and subtraction antisymmetric, so o - b is
/// -(b - o) and the two negations cancel in the product; only a zero distance (b = o)
/// changes sign. That sign reaches no result: comparisons treat -0 as +0, and the entry
/// distance t0 can be a zero slab distance only when it exceeds t_min, so never for the
/// t_min >= 0 of every ray here (for a negative t_min, an occlusion ray could order its
/// children differently by order_key, with the same answer). (Per CBbunny camera ray,
/// AVX2 callgrind: accel/DECISIONS.md, "negated slab form".)
template <class V>
struct BoxConstants {
    V o[3], neg_inv[3], neg_inv_far[3], t_min, t_far;
    int nx, ny, nz, fx, fy, fz;
    PT_INLINE BoxConstants(const Planes& p, float tmin, float tmax) {
        for (int a = 0; a < 3; ++a) {
            o[a] = splat<V>(p.org[a]), neg_inv[a] = splat<V>(p.neg_inv[a]);
            neg_inv_far[a] = splat<V>(p.neg_inv[a] * kFarScale);
        }
        t_min = splat<V>(tmin);
        limit(tmax);
        nx = p.near[0], ny = p.near[1], nz = p.near[2], fx = p.far[0], fy = p.far[1], fz = p.far[2];
    }
    /// The far accumulator's start for a segment ending at t.
    PT_INLINE void limit(float t) { t_far = splat<V>(t * kFarScale); }
};

inline __m128 low4(__m128 x) { return x; }
#ifdef __AVX__
inline __m128 low4(__m256 x) { return _mm256_castps256_ps128(x); }
#endif

/// The leaf tests' per-ray constants, as rows of the widest vector the kernel file has:
/// __m256 where it is compiled with AVX, so tri8 reads them whole and tri4 their low
/// half. With __m128 rows, which the 8-lane tests widened per leaf, GCC 12 kept the
/// widened rows live across the traversal loop, and beside the node test's ten rows
/// they did not fit with a leaf test's temporaries, even in AVX-512's 32 registers: on
/// entering every leaf it stored 12-17 registers to the stack and loaded them back on
/// leaving, 35-40 instructions per leaf visit. Now the AVX-512 kernel stores none there
/// and the AVX2 kernel 6 vectors. Per CBbunny camera ray (callgrind, AVX2): 773 -> 748
/// instructions, of them stores 83 -> 62. One thread: AVX-512 +2.5 %, watertight +1.8 %,
/// AVX2 and SSE2 unchanged (accel/DECISIONS.md, "leaf rows held at full width"). Forcing the node test's rows to be
/// read from memory too (an empty asm on the reference every iteration) removed the
/// remaining spills but cost 14-16 %.
/// SSE2 is part of every x86-64, so all ISAs share the four-lane code (the wider files
/// just encode it with VEX); -ffp-contract=off on every kernel file keeps the arithmetic
/// that of triangle.h, so all ISAs and naive return the same t, u, v.
struct LeafRay {
#ifdef __AVX__
    using Row = __m256;
#else
    using Row = __m128;
#endif
    Row o[3], d[3], t_min;
    int kx, ky, kz;
    Row sx, sy, sz;
    PT_INLINE LeafRay(const Ray& r, const WatertightRay& wr) {
        for (int a = 0; a < 3; ++a) o[a] = splat<Row>(r.org[a]), d[a] = splat<Row>(r.dir[a]);
        t_min = splat<Row>(r.t_min);
        kx = wr.kx, ky = wr.ky, kz = wr.kz;
        sx = splat<Row>(wr.sx), sy = splat<Row>(wr.sy), sz = splat<Row>(wr.sz);
    }
};

inline __m128 ld(const float* p) { return _mm_load_ps(p); }

/// Lanes that hold a primitive.
PT_INLINE inline unsigned filled(const Block& b) {
    const __m128i none = _mm_set1_epi32(-1);
    const __m128i s = _mm_load_si128(reinterpret_cast<const __m128i*>(b.prim));
    return unsigned(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(s, none)))) ^ 0xFu;
}

/// Lane-wise float operations for the Möller–Trumbore template below, on 4 lanes (SSE,
/// every ISA) and 8 lanes (AVX, the wider kernels). The comparisons keep SSE's
/// predicates: not-equal is unordered (true on NaN), the others ordered (false on NaN).
struct Ops4 {
    using V = __m128;
    PT_INLINE static V add(V a, V b) { return _mm_add_ps(a, b); }
    PT_INLINE static V sub(V a, V b) { return _mm_sub_ps(a, b); }
    PT_INLINE static V mul(V a, V b) { return _mm_mul_ps(a, b); }
    PT_INLINE static V div(V a, V b) { return _mm_div_ps(a, b); }
    PT_INLINE static V land(V a, V b) { return _mm_and_ps(a, b); }
    PT_INLINE static V lor(V a, V b) { return _mm_or_ps(a, b); }
    PT_INLINE static V andnot(V a, V b) { return _mm_andnot_ps(a, b); }
    PT_INLINE static V eq(V a, V b) { return _mm_cmpeq_ps(a, b); }
    PT_INLINE static V lt(V a, V b) { return _mm_cmplt_ps(a, b); }
    PT_INLINE static V gt(V a, V b) { return _mm_cmpgt_ps(a, b); }
    PT_INLINE static V load(const float* p) { return _mm_loadu_ps(p); }
    PT_INLINE static V set1(float x) { return _mm_set1_ps(x); }
    PT_INLINE static V ne(V a, V b) { return _mm_cmpneq_ps(a, b); }
    PT_INLINE static V ge(V a, V b) { return _mm_cmpge_ps(a, b); }
    PT_INLINE static V le(V a, V b) { return _mm_cmple_ps(a, b); }
    PT_INLINE static unsigned mask(V a) { return unsigned(_mm_movemask_ps(a)); }
    PT_INLINE static void store(float* p, V a) { _mm_storeu_ps(p, a); }
};
#ifdef __AVX__
struct Ops8 {
    using V = __m256;
    PT_INLINE static V add(V a, V b) { return _mm256_add_ps(a, b); }
    PT_INLINE static V sub(V a, V b) { return _mm256_sub_ps(a, b); }
    PT_INLINE static V mul(V a, V b) { return _mm256_mul_ps(a, b); }
    PT_INLINE static V div(V a, V b) { return _mm256_div_ps(a, b); }
    PT_INLINE static V land(V a, V b) { return _mm256_and_ps(a, b); }
    PT_INLINE static V lor(V a, V b) { return _mm256_or_ps(a, b); }
    PT_INLINE static V andnot(V a, V b) { return _mm256_andnot_ps(a, b); }
    PT_INLINE static V eq(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
    PT_INLINE static V lt(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
    PT_INLINE static V gt(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
    PT_INLINE static V load(const float* p) { return _mm256_loadu_ps(p); }
    PT_INLINE static V set1(float x) { return _mm256_set1_ps(x); }
    PT_INLINE static V ne(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_UQ); }
    PT_INLINE static V ge(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
    PT_INLINE static V le(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
    PT_INLINE static unsigned mask(V a) { return unsigned(_mm256_movemask_ps(a)); }
    PT_INLINE static void store(float* p, V a) { _mm256_storeu_ps(p, a); }
};
#endif
#ifdef __AVX512F__
/// 16 lanes (four blocks) for the AVX-512 kernel, comparing into mask registers (the
/// predicates are Ops4's).
struct Ops16 {
    using V = __m512;
    using M = __mmask16;
    PT_INLINE static V add(V a, V b) { return _mm512_add_ps(a, b); }
    PT_INLINE static V sub(V a, V b) { return _mm512_sub_ps(a, b); }
    PT_INLINE static V mul(V a, V b) { return _mm512_mul_ps(a, b); }
    PT_INLINE static V div(V a, V b) { return _mm512_div_ps(a, b); }
    PT_INLINE static M land(M a, M b) { return M(a & b); }
    PT_INLINE static V set1(float x) { return _mm512_set1_ps(x); }
    PT_INLINE static M ne(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ); }
    PT_INLINE static M ge(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
    PT_INLINE static M le(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
    PT_INLINE static unsigned mask(M a) { return unsigned(a); }
    PT_INLINE static void store(float* p, V a) { _mm512_storeu_ps(p, a); }
};
#endif

/// The result of one leaf test over O::V's lanes: the lanes hit in [t_min, t_max] and
/// their t, u, v. Inlined, so an occlusion query that reads only the mask computes no
/// more. Lanes8 (two blocks): lanes 0-3 are the first block's, 4-7 the second's.
template <class O>
struct LanesOf {
    unsigned mask;
    typename O::V t, u, v;
    unsigned store(float* tt, float* uu, float* vv) const {
        if (mask) O::store(tt, t), O::store(uu, u), O::store(vv, v);
        return mask;
    }
};
using Lanes = LanesOf<Ops4>;
#ifdef __AVX__
using Lanes8 = LanesOf<Ops8>;
#endif

/// Möller–Trumbore on a vector of triangles with precomputed edges (v0 in p0, e1, e2,
/// per axis); the same operations, in the same order, as intersect_triangle_mt, so every
/// lane's t, u, v are naive's bits at any width.
template <class O>
PT_INLINE inline LanesOf<O> mt_lanes(const typename O::V (&p0)[3], const typename O::V (&e1)[3],
                                     const typename O::V (&e2)[3], const typename O::V (&o)[3],
                                     const typename O::V (&d)[3], typename O::V t_min, float t_max) {
    using V = typename O::V;
    const V px = O::sub(O::mul(d[1], e2[2]), O::mul(d[2], e2[1]));
    const V py = O::sub(O::mul(d[2], e2[0]), O::mul(d[0], e2[2]));
    const V pz = O::sub(O::mul(d[0], e2[1]), O::mul(d[1], e2[0]));
    const V det = O::add(O::add(O::mul(e1[0], px), O::mul(e1[1], py)), O::mul(e1[2], pz));
    const V inv = O::div(O::set1(1.0f), det);
    const V sx = O::sub(o[0], p0[0]), sy = O::sub(o[1], p0[1]), sz = O::sub(o[2], p0[2]);
    const V u = O::mul(O::add(O::add(O::mul(sx, px), O::mul(sy, py)), O::mul(sz, pz)), inv);
    const V qx = O::sub(O::mul(sy, e1[2]), O::mul(sz, e1[1]));
    const V qy = O::sub(O::mul(sz, e1[0]), O::mul(sx, e1[2]));
    const V qz = O::sub(O::mul(sx, e1[1]), O::mul(sy, e1[0]));
    const V v = O::mul(O::add(O::add(O::mul(d[0], qx), O::mul(d[1], qy)), O::mul(d[2], qz)), inv);
    const V t = O::mul(O::add(O::add(O::mul(e2[0], qx), O::mul(e2[1], qy)), O::mul(e2[2], qz)), inv);
    const V zero = O::set1(0.0f), one = O::set1(1.0f);
    // Ordered comparisons fail on NaN, as the scalar test's do.
    auto ok = O::ne(det, zero);
    ok = O::land(ok, O::land(O::ge(u, zero), O::le(u, one)));
    ok = O::land(ok, O::land(O::ge(v, zero), O::le(O::add(u, v), one)));
    ok = O::land(ok, O::land(O::ge(t, t_min), O::le(t, O::set1(t_max))));
    return {O::mask(ok), t, u, v};
}

/// Möller–Trumbore on the four triangles of one block. No filled(b) in the mask: an
/// unused lane's edges are zero, so det = 0 already rejects it, and the prim row (a
/// tenth of the block's bytes) is not read unless a lane hits.
PT_INLINE inline Lanes tri4_mt(const Block& b, const LeafRay& r, float t_max) {
    const __m128 p0[3] = {ld(b.p[0][0]), ld(b.p[0][1]), ld(b.p[0][2])};
    const __m128 e1[3] = {ld(b.p[1][0]), ld(b.p[1][1]), ld(b.p[1][2])};
    const __m128 e2[3] = {ld(b.p[2][0]), ld(b.p[2][1]), ld(b.p[2][2])};
    const __m128 o[3] = {low4(r.o[0]), low4(r.o[1]), low4(r.o[2])};
    const __m128 d[3] = {low4(r.d[0]), low4(r.d[1]), low4(r.d[2])};
    return mt_lanes<Ops4>(p0, e1, e2, o, d, low4(r.t_min), t_max);
}

/// Woop's test over O::V's lanes; `row(k, a)` loads vertex k's axis-a row of the
/// scene's own vertices straight from the blocks (rows gathered into an array first and
/// then indexed by the ray's axes would go through the stack); o = the origin's rows in
/// the ray's kx, ky, kz order; `live` = the lanes that hold a triangle.
template <class O, class Row>
PT_INLINE inline LanesOf<O> wt_lanes(const Row& row, const typename O::V (&o)[3], typename O::V sx,
                                     typename O::V sy, typename O::V sz, typename O::V t_min, const LeafRay& r,
                                     unsigned live, float t_max) {
    using V = typename O::V;
    constexpr int kN = int(sizeof(V) / sizeof(float));
    V X[3], Y[3], Z[3];
    for (int k = 0; k < 3; ++k) {
        const V ax = O::sub(row(k, r.kx), o[0]);
        const V ay = O::sub(row(k, r.ky), o[1]);
        const V az = O::sub(row(k, r.kz), o[2]);
        X[k] = O::sub(ax, O::mul(sx, az));
        Y[k] = O::sub(ay, O::mul(sy, az));
        Z[k] = az;
    }
    // A = vertex 0, B = vertex 1, C = vertex 2.
    V U = O::sub(O::mul(X[2], Y[1]), O::mul(Y[2], X[1]));
    V W0 = O::sub(O::mul(X[0], Y[2]), O::mul(Y[0], X[2]));
    V W = O::sub(O::mul(X[1], Y[0]), O::mul(Y[1], X[0]));
    const V zero = O::set1(0.0f);
    const unsigned zeros = O::mask(O::lor(O::lor(O::eq(U, zero), O::eq(W0, zero)), O::eq(W, zero))) & live;
    if (zeros) {
        alignas(32) float x[3][kN], y[3][kN], fu[kN], fv[kN], fw[kN];
        for (int k = 0; k < 3; ++k) O::store(x[k], X[k]), O::store(y[k], Y[k]);
        O::store(fu, U), O::store(fv, W0), O::store(fw, W);
        for (int l = 0; l < kN; ++l) {
            if (!(zeros >> l & 1)) continue;
            fu[l] = float(double(x[2][l]) * double(y[1][l]) - double(y[2][l]) * double(x[1][l]));
            fv[l] = float(double(x[0][l]) * double(y[2][l]) - double(y[0][l]) * double(x[2][l]));
            fw[l] = float(double(x[1][l]) * double(y[0][l]) - double(y[1][l]) * double(x[0][l]));
        }
        U = O::load(fu), W0 = O::load(fv), W = O::load(fw);
    }
    const V neg = O::lor(O::lor(O::lt(U, zero), O::lt(W0, zero)), O::lt(W, zero));
    const V pos = O::lor(O::lor(O::gt(U, zero), O::gt(W0, zero)), O::gt(W, zero));
    const V det = O::add(O::add(U, W0), W);
    const V T = O::add(O::add(O::mul(U, O::mul(sz, Z[0])), O::mul(W0, O::mul(sz, Z[1]))), O::mul(W, O::mul(sz, Z[2])));
    const V inv = O::div(O::set1(1.0f), det);
    const V t = O::mul(T, inv);
    V ok = O::andnot(O::land(neg, pos), O::ne(det, zero));
    ok = O::land(ok, O::land(O::ge(t, t_min), O::le(t, O::set1(t_max))));
    return {O::mask(ok) & live, t, O::mul(W0, inv), O::mul(W, inv)};
}

/// Woop 2013 on four triangles; the same operations as intersect_triangle_wt, including
/// its double-precision retry of an edge function that rounds to exactly zero (done per
/// lane, only for the rare lanes that need it).
PT_INLINE inline Lanes tri4_wt(const Block& b, const LeafRay& r, float t_max) {
    const __m128 o[3] = {low4(r.o[r.kx]), low4(r.o[r.ky]), low4(r.o[r.kz])};
    return wt_lanes<Ops4>([&](int k, int a) { return ld(b.p[k][a]); }, o, low4(r.sx), low4(r.sy), low4(r.sz),
                          low4(r.t_min), r, filled(b), t_max);
}

#ifdef __AVX__
/// Two consecutive blocks of one leaf (or a leaf's last block twice, the caller masking
/// the copy) in one 8-lane Möller–Trumbore, for the wider kernels: the operations of
/// tri4_mt lane for lane, so every lane's t, u, v and verdict are the 4-lane test's (and
/// naive's). Leaves of more than one block are where the SAH
/// found no split worth a node (SBVH's needle bundles; the binned SAH's leaves of 5-8):
/// there the leaf tests dominate, ~1400 triangles per shadow ray on the sliver mesh.
PT_INLINE inline Lanes8 tri8_mt(const Block& b0, const Block& b1, const LeafRay& r, float t_max) {
    const auto ld2 = [](const float* lo, const float* hi) {
        return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(lo)), _mm_load_ps(hi), 1);
    };
    __m256 p0[3], e1[3], e2[3];
    for (int a = 0; a < 3; ++a)
        p0[a] = ld2(b0.p[0][a], b1.p[0][a]), e1[a] = ld2(b0.p[1][a], b1.p[1][a]), e2[a] = ld2(b0.p[2][a], b1.p[2][a]);
    return mt_lanes<Ops8>(p0, e1, e2, r.o, r.d, r.t_min, t_max);
}

/// Woop's test on two blocks (or one twice, the caller masking the copy), as tri8_mt:
/// tri4_wt's operations lane for lane, the double-precision retry included, so the
/// watertight guarantee and naive's bits hold at this width too. Against one block at a
/// time with a branch on its hits: shadow rays +17 to +22 %, diffuse +2 to +11 % on the
/// course meshes (accel/DECISIONS.md, "8-lane watertight leaves").
PT_INLINE inline Lanes8 tri8_wt(const Block& b0, const Block& b1, const LeafRay& r, float t_max) {
    const auto ld2 = [](const float* lo, const float* hi) {
        return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm_load_ps(lo)), _mm_load_ps(hi), 1);
    };
    const __m256 o[3] = {r.o[r.kx], r.o[r.ky], r.o[r.kz]};
    return wt_lanes<Ops8>([&](int k, int a) { return ld2(b0.p[k][a], b1.p[k][a]); }, o, r.sx, r.sy, r.sz, r.t_min, r,
                          filled(b0) | filled(b1) << 4, t_max);
}
#endif

#ifdef __AVX512F__
/// Four consecutive blocks of one leaf in one 16-lane Möller–Trumbore (lanes 4k..4k+3:
/// block k), for the AVX-512 kernel's any-hit query: again tri4_mt's operations lane for
/// lane. Leaves of three or four blocks are the SBVH's needle bundles (cap 16, build.h);
/// there one test instead of two 8-lane ones cut the instructions per triangle, not the
/// arithmetic (Zen 4 runs a 512-bit operation as two 256-bit halves): sliver shadow rays
/// +14 to +23 % (accel/DECISIONS.md, "16-lane SBVH leaves"). The binned SAH's leaves (cap 8) never reach it.
/// In the closest-hit loop it gave sliver diffuse rays +10 % but cost the course meshes'
/// camera rays 2-6 %, which never take it, so traverse keeps the 8-lane test.
PT_INLINE inline LanesOf<Ops16> tri16_mt(const Block& b0, const Block& b1, const Block& b2, const Block& b3,
                                         const LeafRay& r, float t_max) {
    const auto ld4 = [&](int k, int a) {
        __m512 x = _mm512_castps128_ps512(_mm_load_ps(b0.p[k][a]));
        x = _mm512_insertf32x4(x, _mm_load_ps(b1.p[k][a]), 1);
        x = _mm512_insertf32x4(x, _mm_load_ps(b2.p[k][a]), 2);
        return _mm512_insertf32x4(x, _mm_load_ps(b3.p[k][a]), 3);
    };
    // The ray's rows are splats: any lane will do (and _mm512_broadcast_f32x4 draws a
    // false "may be used uninitialized" from GCC 12's own header).
    const auto wide = [](__m256 x) { return _mm512_set1_ps(_mm256_cvtss_f32(x)); };
    __m512 p0[3], e1[3], e2[3], o[3], d[3];
    for (int a = 0; a < 3; ++a) {
        p0[a] = ld4(0, a), e1[a] = ld4(1, a), e2[a] = ld4(2, a);
        o[a] = wide(r.o[a]), d[a] = wide(r.d[a]);
    }
    return mt_lanes<Ops16>(p0, e1, e2, o, d, wide(r.t_min), t_max);
}

#endif

template <TriangleTest Test>
PT_INLINE inline Lanes tri4(const Block& b, const LeafRay& r, float t_max) {
    if constexpr (Test == TriangleTest::Watertight) return tri4_wt(b, r, t_max);
    return tri4_mt(b, r, t_max);
}
#ifdef __AVX__
template <TriangleTest Test>
PT_INLINE inline Lanes8 tri8(const Block& b0, const Block& b1, const LeafRay& r, float t_max) {
    if constexpr (Test == TriangleTest::Watertight) return tri8_wt(b0, b1, r, t_max);
    return tri8_mt(b0, b1, r, t_max);
}
#endif

/// Sphere in lane l of a sphere block (centre in p[0], radius in p[1][0]) hit in
/// [ray.t_min, t]; its distance in ts.
inline bool sphere_lane(const Block& b, int l, const Ray& ray, float t, float& ts) {
    return intersect_sphere(ray, Vec3f(b.p[0][0][l], b.p[0][1][l], b.p[0][2][l]), b.p[1][0][l], t, ts);
}

/// The order key of a hit lane's entry distance for occlusion rays: its top 16 bits
/// (a hit lane's distance is never negative, so the bits order like the floats; keys
/// agree to 1/128 of the distance). The 8-lane kernels find the smallest key with one
/// phminposuw (node8.h); every ISA uses the same key, so all visit the same nodes.
inline uint32_t order_key(float d) {
    uint32_t b;
    std::memcpy(&b, &d, 4);
    return b >> 16;
}

/// Portable child selection for policies without a vector form (SSE2): the first hit
/// lane with the smallest order key, and the other hit lanes pushed in lane order.
PT_INLINE inline int nearest_scalar(const float* dist, unsigned mask) {
    int best = __builtin_ctz(mask);
    uint32_t best_key = order_key(dist[best]);
    for (mask &= mask - 1; mask; mask &= mask - 1) {
        const int i = __builtin_ctz(mask);
        const uint32_t k = order_key(dist[i]);
        if (k < best_key) best = i, best_key = k;
    }
    return best;
}
template <class N>
PT_INLINE inline unsigned push_scalar(const N& n, unsigned mask, uint32_t* ref, uint32_t* count) {
    unsigned k = 0;
    for (; mask; mask &= mask - 1, ++k) {
        const int i = __builtin_ctz(mask);
        ref[k] = n.child[i], count[k] = n.count[i];
    }
    return k;
}

/// The node array a policy's test reads: P::Node is WideNode (float child boxes) or
/// QuantNode (compressed, Ylitie et al. 2017); both share the child/count encoding.
template <class Node>
inline const Node* node_array(const WideBvh& w) {
    if constexpr (std::is_same_v<Node, QuantNode>)
        return w.qnodes.empty() ? nullptr : w.qnodes.data();
    else
        return w.nodes.empty() ? nullptr : w.nodes.data();
}

/// Starts the fetch of a subtree the traversal pushed, so that its cache misses overlap
/// the descent into the nearer child instead of following it. Policies choose: kPrefetch
/// for closest-hit traversal, kPrefetchShadow for occlusion. The compressed layout (trees
/// far beyond the caches) prefetches in both; the float layout only for closest hits,
/// where it measured +1-2 % on diffuse rays of the course meshes, whose trees (2-3 MB)
/// overflow the 1 MB L2; for shadow rays, which stop at the first hit, it cost 5-11 %
/// (accel/DECISIONS.md, "node-line prefetch"). Interior children: the node's lines; leaves: the first block's.
template <bool kOn, class P>
PT_INLINE inline void prefetch_child(const typename P::Node* nodes, const Block* blocks, uint32_t ref) {
    if constexpr (kOn) {
        const char* p = ref & WideNode::kLeaf ? reinterpret_cast<const char*>(blocks + (ref & ~WideNode::kLeaf))
                                              : reinterpret_cast<const char*>(nodes + ref);
        constexpr int kLines = int(std::max(sizeof(typename P::Node), sizeof(Block)) + 63) / 64;
        for (int k = 0; k < kLines; ++k) _mm_prefetch(p + 64 * k, _MM_HINT_T0);
    }
}

/// Starts the fetch of a bottom node's leaf blocks as the traversal enters that node, so
/// the blocks arrive with the node instead of one memory latency after it. `hint` is the
/// node's lane `count` in its parent (WideNode::kHint*: the blocks under a child whose
/// lanes are all leaves, contiguous in the depth-first layout; 0 for any other child,
/// and for every child of a tree whose blocks fit the caches: wide.h, kLeafHintBytes).
/// The bottom of the tree is where a ray's dependent chain of misses ends: a node, then
/// the block it selects. Measured on the 5M sphere (A/B, 3 rounds, medians of the ratio
/// to Embree): camera 1.13 -> 1.27, shadow 1.06 -> 1.29, diffuse 0.98 -> 1.05; on 1M
/// triangles, float nodes: 1.27 -> 1.43, 1.06 -> 1.17, 1.05 -> 1.17. Prefetching into L2
/// only, or also when a subtree is pushed, gained less (accel/DECISIONS.md, "leaf prefetch").
PT_INLINE inline void prefetch_leaves(const Block* blocks, uint32_t hint) {
    if (!hint) return;
    const Block* first = blocks + (hint & (WideNode::kHintBlocks - 1));
    const char* p = reinterpret_cast<const char*>(first);
    const char* end = reinterpret_cast<const char*>(first + (hint >> WideNode::kHintShift));
    for (; p < end; p += 64) _mm_prefetch(p, _MM_HINT_T0);
}

/// What a hit filter is told besides the hit (HitFilter): the caller's world-space ray,
/// the instance, and what turns a tree's geometry ids into the caller's (a prototype's
/// tree numbers its geometries from 0). The Masked traversals take a FilterArgs; the
/// opaque ones NoFilter, an empty class, which the x86-64 SysV ABI passes in no register
/// at all, so their instructions stay those they had before instances existed.
struct NoFilter {};
struct FilterArgs {
    const Ray* world;
    uint32_t inst;
    uint32_t geom_base;
};

/// The hit filter of masked geometry (GeometryView::filter) for a hit in lane `lane` of
/// block `b`: true when the lane's geometry is opaque or its filter keeps the hit. Only
/// the Masked instantiations below call it, so a scene without masked geometry runs
/// kernels that contain no trace of it. Written here rather than through lane_primitive
/// (wide.h), whose out-of-line copy this file's flags could make the linker's pick.
PT_INLINE inline bool keep_hit(const WideBvh& w, const Block& b, int lane, float u, float v, const FilterArgs& f) {
    const uint32_t geom = w.lane_geom.empty() ? w.one_geom : w.lane_geom[size_t(&b - w.blocks.data()) * 4 + size_t(lane)];
    const GeometryView& g = w.geometry[geom];
    return !g.filter || g.filter(g.filter_user, geom + f.geom_base, b.prim[lane], f.inst, u, v, *f.world);
}
/// Never called (Masked is false wherever NoFilter is passed); it lets the opaque
/// instantiations compile the filter's branch, which `!Masked ||` then removes.
PT_INLINE inline bool keep_hit(const WideBvh&, const Block&, int, float, float, NoFilter) { return true; }

/// Whether some hit lane of a leaf test (lanes 4k..4k+3 from block b[k]) survives the
/// filter: the any-hit query's test on masked scenes.
template <class L>
PT_INLINE inline bool any_kept(const L& lanes, unsigned hit, const Block* b, const WideBvh& w, const FilterArgs& f) {
    alignas(64) float tt[16], uu[16], vv[16];
    lanes.store(tt, uu, vv);
    for (; hit; hit &= hit - 1) {
        const int l = __builtin_ctz(hit);
        if (keep_hit(w, b[l >> 2], l & 3, uu[l], vv[l], f)) return true;
    }
    return false;
}
template <class L>
PT_INLINE inline bool any_kept(const L&, unsigned, const Block*, const WideBvh&, NoFilter) { return true; }

/// The closest hit traverse found: its distance, barycentrics, and the block and lane
/// of its primitive (BvhBase::finish takes the ids and the normal from there, not from
/// the slot map or the scene's arrays); at.block is null when nothing was hit. Returned
/// by value, not through four reference parameters, which GCC kept in registers across
/// the whole traversal loop and so spilled the node test's row offsets instead.
struct Closest {
    float t, u, v;
    BlockLane at;
};

/// The closest primitive hit in [ray.t_min, ray.t_max], shrinking the segment as hits
/// are found.
///
/// Counting (only when Count; the timed path is its own instantiation and counts
/// nothing): nodes_visited = 1 per wide node whose child boxes are tested (the root's
/// always); prim_tests = filled lanes of every leaf block tested.
///
/// No scalar test of the scene box first: the root node's eight boxes turn away a ray
/// that misses the scene just as well, and the scalar test (three divisions, then a
/// dependent chain of six slab distances and a branch, before any SIMD work could
/// start) measured 10-25 % of a shadow or diffuse ray on the course meshes, whose rays
/// all start inside the scene box (accel/DECISIONS.md, "no scalar root test").
///
/// Masked (scenes with some GeometryView::filter, WideBvh::geometry set): a lane that
/// would become the closest hit is kept only if keep_hit says so; a dropped one leaves
/// the segment as it was, so traversal goes on behind it. The views come through w, not
/// as an argument, so that the opaque instantiations keep the signature, and so the
/// instructions, they had before filters existed.
template <class P, TriangleTest Test, bool Count, bool HasSpheres, bool Masked = false, class F = NoFilter>
Closest traverse(const WideBvh& w, const Ray& ray_in, TraceStats& stats, F f = {}) {
    const typename P::Node* nodes = node_array<typename P::Node>(w);
    if (!nodes) return {};
    // A local copy: through a reference every store to t could alias the ray and the
    // node data (all floats), forcing reloads in the innermost loop.
    const Ray ray = ray_in;
    float t = ray.t_max, u = 0.0f, v = 0.0f;
    uint64_t boxes = 0, tests = 0;
    BlockLane at{};  // at.block stays null until a hit is found
    const auto finish = [&]() {
        if constexpr (Count) stats.nodes_visited += boxes, stats.prim_tests += tests;
        return Closest{t, u, v, at};
    };
    const Planes pl(ray);
    const WatertightRay wr = Test == TriangleTest::Watertight ? WatertightRay(ray.dir) : WatertightRay();
    typename P::Box box(pl, ray.t_min, t);
    const LeafRay lr(ray, wr);
    float t_far = t * kFarScale;
    const Block* blocks = w.blocks.data();

    struct Entry {
        uint32_t ref, count;
        float t;
    };
    // Each wide level pushes at most kWidth - 1 entries and is no deeper than the
    // binary tree, whose depth the build bounds by kStackSize.
    Entry stack[(kWidth - 1) * kStackSize];
    uint32_t sp = 0;
    uint32_t ref = 0, count = 0;  // the root WideNode (interior)
    for (;;) {
        if (ref & WideNode::kLeaf) {
            const Block* b = blocks + (ref & ~WideNode::kLeaf);
            const Block* end = b + WideNode::leaf_blocks(count);
            // Every block of the leaf is tested: its tests are the primitive count the
            // leaf lane carries. Counted block by block (the filled lanes of each), the
            // counting instantiation traced a CBbunny render's rays 4-8 % slower than the
            // uncounted one (accel/DECISIONS.md, "leaf tests counted from the lane").
            if constexpr (Count) tests += WideNode::leaf_prims(count);
            for (; b != end; ++b) {
                if (HasSpheres && (count & WideNode::kSpheres)) {
                    for (int l = 0; l < 4 && b->prim[l] != Block::kNone; ++l) {
                        float ts;
                        if (sphere_lane(*b, l, ray, t, ts)) t = ts, u = v = 0.0f, at = {b, l};
                    }
                    continue;
                }
#ifdef __AVX__
                {
                    // Two blocks per 8-lane test (Möller–Trumbore or Woop), both modes;
                    // a leaf's last single block is tested
                    // twice over, its upper copy masked off. A branch on "one block or
                    // two" followed the data and mispredicted: diffuse +1 to +5 %, camera
                    // 0 to +2 % without it (accel/DECISIONS.md, "8-lane leaf tests"). The second block's
                    // lanes were tested against the segment before the first block's hits
                    // shortened it; the check below drops those that the shortened segment
                    // excludes, as testing in turn would. (This loop and the 4-lane one
                    // below are kept apart: one lambda for both, capturing t, u, v by
                    // reference, measured 10-25 % slower on camera and diffuse rays:
                    // accel/DECISIONS.md, "separate 8-lane and 4-lane leaf loops".)
                    const bool two = end - b >= 2;
                    const Block& b1 = two ? b[1] : b[0];
                    alignas(32) float tt[8], uu[8], vv[8];
                    unsigned hit = tri8<Test>(b[0], b1, lr, t).store(tt, uu, vv) & (two ? 0xFFu : 0x0Fu);
                    while (hit) {
                        const int l = __builtin_ctz(hit);
                        hit &= hit - 1;
                        const Block* hb = b + (l >> 2);
                        if (tt[l] <= t && (!Masked || keep_hit(w, *hb, l & 3, uu[l], vv[l], f)))
                            t = tt[l], u = uu[l], v = vv[l], at = {hb, l & 3};
                    }
                    b += two;
                    continue;
                }
#endif
                alignas(16) float tt[4], uu[4], vv[4];
                unsigned hit = tri4<Test>(*b, lr, t).store(tt, uu, vv);
                if (!hit) continue;
                // In lane order, each lane accepted if not beyond the best so far: what
                // the scalar loop over the same triangles would keep.
                do {
                    const int l = __builtin_ctz(hit);
                    hit &= hit - 1;
                    if (tt[l] <= t && (!Masked || keep_hit(w, *b, l, uu[l], vv[l], f)))
                        t = tt[l], u = uu[l], v = vv[l], at = {b, l};
                } while (hit);
            }
            // Once per leaf, not per hit lane or per node: the node test's and the pop's
            // far limit follow the closest hit.
            box.limit(t);
            t_far = t * kFarScale;
        } else {
            prefetch_leaves(blocks, count);
            const auto& n = nodes[ref];
            // The child and count rows share the node's last cache line (the second of a
            // QuantNode), which the box test does not read: without this its fetch would
            // start only once the test has chosen a lane, one more latency in the chain.
            _mm_prefetch(reinterpret_cast<const char*>(n.child), _MM_HINT_T0);
            if constexpr (Count) ++boxes;
            alignas(32) float dist[kWidth];
            unsigned mask = P::test(n, box, dist);
            if (mask) {
                int i = __builtin_ctz(mask);
                mask &= mask - 1;
                if (!mask) {  // one child hit: no stack traffic at all
                    ref = n.child[i];
                    count = n.count[i];
                    continue;
                }
                int j = __builtin_ctz(mask);
                mask &= mask - 1;
                if (!mask) {  // two children, the most common case: order them by select
                    const bool swap = dist[j] < dist[i];
                    const int nearc = swap ? j : i, farc = swap ? i : j;
                    stack[sp++] = {n.child[farc], n.count[farc], dist[farc]};
                    prefetch_child<P::kPrefetch, P>(nodes, blocks, n.child[farc]);
                    ref = n.child[nearc];
                    count = n.count[nearc];
                    continue;
                }
                // Three or more: insertion sort into the stack top, farthest deepest, so
                // the nearest is visited next and the others are likely culled on pop.
                const uint32_t base = sp;
                mask |= 1u << j;
                for (;;) {
                    const Entry e{n.child[i], n.count[i], dist[i]};
                    prefetch_child<P::kPrefetch, P>(nodes, blocks, e.ref);
                    uint32_t k = sp++;
                    while (k > base && stack[k - 1].t < e.t) {
                        stack[k] = stack[k - 1];
                        --k;
                    }
                    stack[k] = e;
                    if (!mask) break;
                    i = __builtin_ctz(mask);
                    mask &= mask - 1;
                }
                const Entry& nearest = stack[--sp];
                ref = nearest.ref;
                count = nearest.count;
                continue;
            }
        }
        // Pop the next subtree whose box entry is not beyond the closest hit.
        for (;;) {
            if (sp == 0) return finish();
            const Entry& e = stack[--sp];
            if (e.t <= t_far) {  // the box test's own tolerance
                ref = e.ref;
                count = e.count;
                break;
            }
        }
    }
}

/// Any-hit query: true when some primitive is hit in [ray.t_min, ray.t_max]. Its own
/// function, not a flag of traverse: the segment never shrinks, so the stack holds only
/// child references (no distances, no culling on pop), children are pushed by the
/// policy's branch-free compaction (P::push), and the leaf test's t, u, v are dead code.
/// Order: the nearest hit child is entered first (P::nearest, branch-free; on the 8-lane
/// kernels nearest to 1/128 of the distance), the others stay in lane order; a full sort
/// measured slower for shadow rays, and no order at all (lane order) 17-20 % slower on
/// CBbunny, though 10-13 % faster on cow and bunny (accel/DECISIONS.md, "nearest child first"). Lane
/// order only where two children are hit, or only in bottom nodes, lost 1-10 % on
/// every mesh (same decision). Counting as in traverse.
/// Masked: as in traverse, a hit lane occludes only if keep_hit keeps it.
template <class P, TriangleTest Test, bool Count, bool HasSpheres, bool Masked = false, class F = NoFilter>
bool occlude(const WideBvh& w, const Ray& ray_in, TraceStats& stats, F f = {}) {
    const typename P::Node* nodes = node_array<typename P::Node>(w);
    if (!nodes) return false;
    const Ray ray = ray_in;
    const float t = ray.t_max;
    uint64_t boxes = 0, tests = 0;
    const auto finish = [&](bool hit) {
        if constexpr (Count) stats.nodes_visited += boxes, stats.prim_tests += tests;
        return hit;
    };
    const Planes pl(ray);
    const WatertightRay wr = Test == TriangleTest::Watertight ? WatertightRay(ray.dir) : WatertightRay();
    const typename P::Box box(pl, ray.t_min, t);
    const LeafRay lr(ray, wr);
    const Block* blocks = w.blocks.data();
    // P::push stores a whole vector of kWidth references; the slack keeps the last one
    // inside the arrays.
    constexpr uint32_t kEntries = (kWidth - 1) * kStackSize + kWidth;
    alignas(32) uint32_t stack_ref[kEntries], stack_count[kEntries];
    uint32_t sp = 0;
    uint32_t ref = 0, count = 0;
    for (;;) {
        if (ref & WideNode::kLeaf) {
            const Block* b = blocks + (ref & ~WideNode::kLeaf);
            const Block* end = b + WideNode::leaf_blocks(count);
            // Counted from the leaf lane's primitive count, as in traverse. A hit ends the
            // walk before the blocks after its group are tested; a leaf's blocks are
            // filled in order, all but its last full, so the blocks up to `tested_end`
            // hold min(prims, 4 * blocks) primitives, and the rest is taken back.
            const Block* const leaf_first = b;
            const uint32_t leaf_prims = WideNode::leaf_prims(count);
            if constexpr (Count) tests += leaf_prims;
            const auto hit_before = [&](const Block* tested_end) {
                if constexpr (Count)
                    tests -= leaf_prims - std::min(leaf_prims, 4u * uint32_t(tested_end - leaf_first));
                return finish(true);
            };
            for (; b != end; ++b) {
                if (HasSpheres && (count & WideNode::kSpheres)) {
                    float ts;
                    for (int l = 0; l < 4 && b->prim[l] != Block::kNone; ++l)
                        if (sphere_lane(*b, l, ray, t, ts)) return hit_before(b + 1);
                    continue;
                }
#ifdef __AVX__
                {  // as in traverse, which says why
#ifdef __AVX512F__
                    // Three or four blocks (SBVH leaves of 9-16), fast mode: one 16-lane
                    // test, the third block standing in for a missing fourth, masked off.
                    if (Test == TriangleTest::Fast && end - b >= 3) {
                        const bool four = end - b >= 4;
                        const Block& b3 = four ? b[3] : b[2];
                        // Masked or not, two statements: the opaque one written as it
                        // was before filters, so it compiles to the same instructions.
                        if constexpr (!Masked) {
                            if (tri16_mt(b[0], b[1], b[2], b3, lr, t).mask & (four ? 0xFFFFu : 0x0FFFu))
                                return hit_before(b + 3 + four);
                        } else {
                            const auto lanes = tri16_mt(b[0], b[1], b[2], b3, lr, t);
                            const unsigned hit = lanes.mask & (four ? 0xFFFFu : 0x0FFFu);
                            if (hit && any_kept(lanes, hit, b, w, f)) return hit_before(b + 3 + four);
                        }
                        b += 2 + four;
                        continue;
                    }
#endif
                    const bool two = end - b >= 2;
                    const Block& b1 = two ? b[1] : b[0];
                    if constexpr (!Masked) {  // as above
                        if (tri8<Test>(b[0], b1, lr, t).mask & (two ? 0xFFu : 0x0Fu)) return hit_before(b + 1 + two);
                    } else {
                        const auto lanes = tri8<Test>(b[0], b1, lr, t);
                        const unsigned hit = lanes.mask & (two ? 0xFFu : 0x0Fu);
                        if (hit && any_kept(lanes, hit, b, w, f)) return hit_before(b + 1 + two);
                    }
                    b += two;
                    continue;
                }
#endif
                if constexpr (!Masked) {  // as above
                    if (tri4<Test>(*b, lr, t).mask) return hit_before(b + 1);
                } else {
                    const auto lanes = tri4<Test>(*b, lr, t);
                    if (lanes.mask && any_kept(lanes, lanes.mask, b, w, f)) return hit_before(b + 1);
                }
            }
        } else {
            prefetch_leaves(blocks, count);
            const auto& n = nodes[ref];
            _mm_prefetch(reinterpret_cast<const char*>(n.child), _MM_HINT_T0);  // as in traverse
            if constexpr (Count) ++boxes;
            alignas(32) float dist[kWidth];
            unsigned mask = P::test(n, box, dist);
            if (mask) {
                // No branch on how many children were hit: P::nearest also finds the one
                // lane of a one-bit mask (every hit lane's key is below the 0xFFFF of the
                // others), and pushing an empty mask adds nothing. That branch followed
                // the data and mispredicted: shadow rays +4.5 to +6.2 % on the course
                // meshes without it (accel/DECISIONS.md, "branch-free occlusion push").
                // Masked trees hold their lanes largest first (wide.cpp, gather): the
                // likeliest occluder first, where each candidate costs an alpha lookup.
                int i;
                if constexpr (Masked)
                    i = __builtin_ctz(mask);
                else
                    i = P::nearest(dist, mask);
                ref = n.child[i];
                count = n.count[i];
                mask &= ~(1u << i);
                if constexpr (P::kPrefetchShadow)
                    for (unsigned m = mask; m; m &= m - 1)
                        prefetch_child<true, P>(nodes, blocks, n.child[__builtin_ctz(m)]);
                sp += P::push(n, mask, stack_ref + sp, stack_count + sp);
                continue;
            }
        }
        if (sp == 0) return finish(false);
        --sp;
        ref = stack_ref[sp];
        count = stack_count[sp];
    }
}

/// The accelerator for one ISA and triangle test; intersect/occluded are the only
/// virtual calls. The counting instantiation runs only when the caller asks for counts.
/// A scene without masked geometry gets this class, whose traversals are the unfiltered
/// instantiations (Masked = false: no filter code at all); one with masked geometry gets
/// MaskedKernel (below), chosen once when the accelerator is made (make_bvh).
template <class P, TriangleTest Test>
class Kernel final : public BvhBase {
public:
    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        const Closest c = stats.counting ? (has_spheres_ ? traverse<P, Test, true, true>(wide_, ray, stats)
                                                         : traverse<P, Test, true, false>(wide_, ray, stats))
                          : has_spheres_ ? traverse<P, Test, false, true>(wide_, ray, stats)
                                         : traverse<P, Test, false, false>(wide_, ray, stats);
        if (!c.at.block) return false;
        finish(c.at, ray, c.t, c.u, c.v, hit);
        return true;
    }
    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        if (stats.counting)
            return has_spheres_ ? occlude<P, Test, true, true>(wide_, ray, stats)
                                : occlude<P, Test, true, false>(wide_, ray, stats);
        return has_spheres_ ? occlude<P, Test, false, true>(wide_, ray, stats)
                            : occlude<P, Test, false, false>(wide_, ray, stats);
    }
};

/// Kernel for scenes with masked geometry: the Masked traversals, which call the filter
/// of a hit lane's geometry when it has one. Spheres are handled whether or not the
/// scene has any (one check per leaf), to halve the instantiations.
template <class P, TriangleTest Test>
class MaskedKernel final : public BvhBase {
public:
    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        const FilterArgs f{&ray, kInvalidId, 0};
        const Closest c = stats.counting ? traverse<P, Test, true, true, true>(wide_, ray, stats, f)
                                         : traverse<P, Test, false, true, true>(wide_, ray, stats, f);
        if (!c.at.block) return false;
        finish(c.at, ray, c.t, c.u, c.v, hit);
        return true;
    }
    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        const FilterArgs f{&ray, kInvalidId, 0};
        return stats.counting ? occlude<P, Test, true, true, true>(wide_, ray, stats, f)
                              : occlude<P, Test, false, true, true>(wide_, ray, stats, f);
    }
};

/// The closest hit over the two-level BVH (instanced.h): the placement it lies in, and
/// the bottom tree's Closest.
struct TopClosest {
    Closest c;
    const Placement* at;
    uint32_t bottom;
};

/// to_object_ray (accel/primitive.h) in this file's namespace, the same operations in the
/// same order (so the same bits, -ffp-contract=off): the Affine3f members are inline
/// functions of a shared header, whose out-of-line copy from this file could be the one
/// the linker keeps (tests/bvh/kernel_symbols.cmake). Four lanes at once, a coordinate per
/// lane: 30 fewer instructions per instance entry than the scalar sums (accel/DECISIONS.md,
/// "instance ray transform in four lanes").
PT_INLINE inline Ray object_ray(const Affine3f& a, const Ray& r, float t) {
    // The three rows transposed into columns, so that each lane computes one coordinate in
    // the scalar expression's order: ((m0 x + m1 y) + m2 z) + m3.
    __m128 c0 = _mm_loadu_ps(a.m[0]), c1 = _mm_loadu_ps(a.m[1]), c2 = _mm_loadu_ps(a.m[2]), c3 = _mm_setzero_ps();
    _MM_TRANSPOSE4_PS(c0, c1, c2, c3);
    const __m128 org = _mm_add_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(r.org.x)),
                                                        _mm_mul_ps(c1, _mm_set1_ps(r.org.y))),
                                             _mm_mul_ps(c2, _mm_set1_ps(r.org.z))),
                                  c3);
    const __m128 dir = _mm_add_ps(_mm_add_ps(_mm_mul_ps(c0, _mm_set1_ps(r.dir.x)), _mm_mul_ps(c1, _mm_set1_ps(r.dir.y))),
                                  _mm_mul_ps(c2, _mm_set1_ps(r.dir.z)));
    float f[7];
    _mm_storeu_ps(f, org);
    _mm_storeu_ps(f + 3, dir);
    Ray o;
    o.org = {f[0], f[1], f[2]};
    o.dir = {f[3], f[4], f[5]};
    o.t_min = r.t_min;
    o.t_max = t;
    return o;
}

/// The bottom tree of placement p, traced with the segment [ray.t_min, t]: the ray goes
/// into the instance's object space first (to_object_ray: t keeps its meaning, so the
/// bottom traversal's t is the world one), unless p is the world-space geometry. The
/// filter is told the world ray, the instance and the prototype's first geometry id.
template <class P, TriangleTest Test, bool Count, bool Masked>
PT_INLINE inline Closest trace_bottom(const InstancedBase& s, const Placement& p, uint32_t bottom, const Ray& ray,
                                      float t, TraceStats& stats) {
    const Ray local = p.inst == kInvalidId ? Ray{ray.org, ray.dir, ray.t_min, t} : object_ray(p.world_to_object, ray, t);
    const WideBvh& w = *s.bottom_wide_[bottom];
    if constexpr (Masked)
        return traverse<P, Test, Count, true, true>(w, local, stats, FilterArgs{&ray, p.inst, s.geom_base_[bottom]});
    else
        return traverse<P, Test, Count, true>(w, local, stats);
}

/// Closest hit of the two-level BVH: the top tree's nodes are tested as a flat tree's
/// (P::test, ordered, entries beyond the closest hit dropped on pop), and a leaf's
/// placements each run the flat traversal (traverse) of their bottom tree, the segment
/// shrinking across them. Counting: nodes of both levels, and the bottom's leaf lanes.
/// Flattened: the bottom traversal is inlined here, so entering an instance is no call (no
/// realigned 11 KB frame, no vzeroupper, no spill of the top walk's vectors around it;
/// accel/DECISIONS.md, "bottom walk inlined into the top").
template <class PT, class P, TriangleTest Test, bool Count, bool Masked>
[[gnu::flatten]] TopClosest traverse_top(const InstancedBase& s, const Ray& ray, TraceStats& stats) {
    const typename PT::Node* nodes = node_array<typename PT::Node>(s.top_);
    TopClosest best{{ray.t_max, 0.0f, 0.0f, {}}, nullptr, 0};
    if (!nodes) return best;
    float t = ray.t_max;
    uint64_t boxes = 0;
    const Planes pl(ray);
    typename PT::Box box(pl, ray.t_min, t);
    float t_far = t * kFarScale;
    struct Entry {
        uint32_t ref, count;
        float t;
    };
    Entry stack[(kWidth - 1) * kStackSize];
    uint32_t sp = 0, ref = 0, count = 0;
    for (;;) {
        if (ref & WideNode::kLeaf) {
            // One placement per leaf lane, its bottom tree in the lane's count.
            const Placement* p = s.placements_.data() + (ref & ~WideNode::kLeaf);
            const Closest c = trace_bottom<P, Test, Count, Masked>(s, *p, count, ray, t, stats);
            if (c.at.block) t = c.t, best = {c, p, count};
            box.limit(t);
            t_far = t * kFarScale;
        } else {
            const auto& n = nodes[ref];
            if constexpr (Count) ++boxes;
            alignas(32) float dist[kWidth];
            unsigned mask = PT::test(n, box, dist);
            if (mask) {
                // One or two hit children without the sort, as traverse does
                // (accel/DECISIONS.md, "top-level one- and two-child paths").
                int i = __builtin_ctz(mask);
                mask &= mask - 1;
                if (!mask) {
                    ref = n.child[i];
                    count = n.count[i];
                    continue;
                }
                const int j = __builtin_ctz(mask);
                if (!(mask & (mask - 1))) {
                    const bool swap = dist[j] < dist[i];
                    const int nearc = swap ? j : i, farc = swap ? i : j;
                    stack[sp++] = {n.child[farc], n.count[farc], dist[farc]};
                    ref = n.child[nearc];
                    count = n.count[nearc];
                    continue;
                }
                mask |= 1u << i;
                // Three or more: every hit child onto the stack by insertion, farthest
                // deepest; the nearest is popped at once (traverse's same case).
                const uint32_t base = sp;
                for (; mask; mask &= mask - 1) {
                    i = __builtin_ctz(mask);
                    const Entry e{n.child[i], n.count[i], dist[i]};
                    uint32_t k = sp++;
                    while (k > base && stack[k - 1].t < e.t) {
                        stack[k] = stack[k - 1];
                        --k;
                    }
                    stack[k] = e;
                }
                const Entry& e = stack[--sp];
                ref = e.ref;
                count = e.count;
                continue;
            }
        }
        for (;;) {
            if (sp == 0) {
                if constexpr (Count) stats.nodes_visited += boxes;
                return best;
            }
            const Entry& e = stack[--sp];
            if (e.t <= t_far) {
                ref = e.ref;
                count = e.count;
                break;
            }
        }
    }
}

/// Any hit of the two-level BVH: the top tree walked with the hit child of the lowest
/// lane first, which the top collapse makes the largest by surface area (wide.cpp, collapse_top),
/// P::push for the rest (not the flat occlude's nearest-first: shadow rays 1.4-2.0x
/// faster on instanced forests and fields; accel/DECISIONS.md, "top-level any-hit
/// order"), each placement's bottom tree by occlude, inlined here as in traverse_top.
template <class PT, class P, TriangleTest Test, bool Count, bool Masked>
[[gnu::flatten]] bool occlude_top(const InstancedBase& s, const Ray& ray, TraceStats& stats) {
    const typename PT::Node* nodes = node_array<typename PT::Node>(s.top_);
    if (!nodes) return false;
    uint64_t boxes = 0;
    const auto finish = [&](bool hit) {
        if constexpr (Count) stats.nodes_visited += boxes;
        return hit;
    };
    const Planes pl(ray);
    const typename PT::Box box(pl, ray.t_min, ray.t_max);
    constexpr uint32_t kEntries = (kWidth - 1) * kStackSize + kWidth;
    alignas(32) uint32_t stack_ref[kEntries], stack_count[kEntries];
    uint32_t sp = 0, ref = 0, count = 0;
    for (;;) {
        if (ref & WideNode::kLeaf) {
            const Placement* p = s.placements_.data() + (ref & ~WideNode::kLeaf);
            const Ray local = p->inst == kInvalidId ? ray : object_ray(p->world_to_object, ray, ray.t_max);
            const WideBvh& w = *s.bottom_wide_[count];
            bool hit;
            if constexpr (Masked)
                hit = occlude<P, Test, Count, true, true>(w, local, stats, FilterArgs{&ray, p->inst, s.geom_base_[count]});
            else
                hit = occlude<P, Test, Count, true>(w, local, stats);
            if (hit) return finish(true);
        } else {
            const auto& n = nodes[ref];
            if constexpr (Count) ++boxes;
            alignas(32) float dist[kWidth];
            unsigned mask = PT::test(n, box, dist);
            if (mask) {
                const int i = __builtin_ctz(mask);
                ref = n.child[i];
                count = n.count[i];
                mask &= ~(1u << i);
                sp += PT::push(n, mask, stack_ref + sp, stack_count + sp);
                continue;
            }
        }
        if (sp == 0) return finish(false);
        --sp;
        ref = stack_ref[sp];
        count = stack_count[sp];
    }
}

/// The two-level accelerator for one ISA, triangle test and masking; the flat kernels'
/// counterpart (Kernel, MaskedKernel). PT is the top tree's node policy, P the bottom
/// trees': the top tree is most of a large instanced scene's memory and has its own
/// layout (InstancedBase::build says when it is compressed).
template <class PT, class P, TriangleTest Test, bool Masked>
class InstancedKernel final : public InstancedBase {
public:
    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        const TopClosest c = stats.counting ? traverse_top<PT, P, Test, true, Masked>(*this, ray, stats)
                                            : traverse_top<PT, P, Test, false, Masked>(*this, ray, stats);
        if (!c.at) return false;
        finish(*c.at, c.bottom, c.c.at, ray, c.c.t, c.c.u, c.c.v, hit);
        return true;
    }
    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        return stats.counting ? occlude_top<PT, P, Test, true, Masked>(*this, ray, stats)
                              : occlude_top<PT, P, Test, false, Masked>(*this, ray, stats);
    }
};

template <class PT, class P>
std::unique_ptr<InstancedBase> make_instanced(TriangleTest test, bool masked) {
    if (masked) {
        if (test == TriangleTest::Watertight) return std::make_unique<InstancedKernel<PT, P, TriangleTest::Watertight, true>>();
        return std::make_unique<InstancedKernel<PT, P, TriangleTest::Fast, true>>();
    }
    if (test == TriangleTest::Watertight) return std::make_unique<InstancedKernel<PT, P, TriangleTest::Watertight, false>>();
    return std::make_unique<InstancedKernel<PT, P, TriangleTest::Fast, false>>();
}

template <class P>
std::unique_ptr<BvhBase> make_kernel(TriangleTest test, bool masked) {
    if (masked) {
        if (test == TriangleTest::Watertight) return std::make_unique<MaskedKernel<P, TriangleTest::Watertight>>();
        return std::make_unique<MaskedKernel<P, TriangleTest::Fast>>();
    }
    if (test == TriangleTest::Watertight) return std::make_unique<Kernel<P, TriangleTest::Watertight>>();
    return std::make_unique<Kernel<P, TriangleTest::Fast>>();
}

}  // namespace accel::bvh::PT_KERNEL_NS
