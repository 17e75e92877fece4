// The SSE2 kernel: the x86-64 baseline, runs on every CPU. The 8-wide node is tested as
// two 4-lane halves. Compiled with -ffp-contract=off only (accel/CMakeLists.txt).
#define PT_KERNEL_NS sse2
#include "accel/bvh/kernel.h"
#include "accel/bvh/dispatch.h"

#include <cstring>

namespace accel::bvh::sse2 {
namespace {

/// Slab test of four child boxes given their near (n) and far (f) planes per axis;
/// returns the hit mask, entry distances in dist. The operations of Node8::test (node8.h)
/// in the same order, NaN handling included, so every ISA tests the same boxes.
PT_INLINE inline unsigned test4(const __m128 n[3], const __m128 f[3], const BoxConstants<__m128>& r, float* dist) {
    const __m128 tnx = _mm_mul_ps(_mm_sub_ps(r.o[0], n[0]), r.neg_inv[0]);
    const __m128 tny = _mm_mul_ps(_mm_sub_ps(r.o[1], n[1]), r.neg_inv[1]);
    const __m128 tnz = _mm_mul_ps(_mm_sub_ps(r.o[2], n[2]), r.neg_inv[2]);
    const __m128 tfx = _mm_mul_ps(_mm_sub_ps(r.o[0], f[0]), r.neg_inv_far[0]);
    const __m128 tfy = _mm_mul_ps(_mm_sub_ps(r.o[1], f[1]), r.neg_inv_far[1]);
    const __m128 tfz = _mm_mul_ps(_mm_sub_ps(r.o[2], f[2]), r.neg_inv_far[2]);
    const __m128 t0 = _mm_max_ps(_mm_max_ps(tnx, tny), _mm_max_ps(tnz, r.t_min));
    const __m128 t1 = _mm_min_ps(_mm_min_ps(tfx, tfy), _mm_min_ps(tfz, r.t_far));
    _mm_store_ps(dist, t0);
    return unsigned(_mm_movemask_ps(_mm_cmple_ps(t0, t1)));
}

struct Sse2 {
    using Node = WideNode;
    static constexpr bool kPrefetch = false;
    static constexpr bool kPrefetchShadow = false;
    using Box = BoxConstants<__m128>;
    /// The eight child boxes as two 4-lane halves.
    PT_INLINE static unsigned test(const WideNode& n, const Box& r, float* dist) {
        unsigned mask = 0;
        for (int q = 0; q < kWidth; q += 4) {
            const __m128 near[3] = {_mm_load_ps(n.b[r.nx] + q), _mm_load_ps(n.b[r.ny] + q), _mm_load_ps(n.b[r.nz] + q)};
            const __m128 far[3] = {_mm_load_ps(n.b[r.fx] + q), _mm_load_ps(n.b[r.fy] + q), _mm_load_ps(n.b[r.fz] + q)};
            mask |= test4(near, far, r, dist + q) << q;
        }
        return mask;
    }
    PT_INLINE static int nearest(const float* dist, unsigned mask) { return nearest_scalar(dist, mask); }
    template <class N>
    PT_INLINE static unsigned push(const N& n, unsigned mask, uint32_t* ref, uint32_t* count) {
        return push_scalar(n, mask, ref, count);
    }
};

/// The compressed node (QuantNode, Ylitie et al. 2017) on SSE2, which has no byte to
/// int widening of its own (pmovzxbd is SSE4.1): two unpacks with zero. Each bound is
/// origin + q * 2^e in the float operations quantize.cpp checked, then Sse2's test.
struct Sse2Q : Sse2 {
    using Node = QuantNode;
    static constexpr bool kPrefetch = true;
    static constexpr bool kPrefetchShadow = true;
    PT_INLINE static unsigned test(const QuantNode& n, const Box& r, float* dist) {
        __m128 s[3], org[3];
        for (int a = 0; a < 3; ++a) {
            float step;
            const uint32_t bits = uint32_t(n.exp[a]) << 23;
            std::memcpy(&step, &bits, 4);
            s[a] = _mm_set1_ps(step), org[a] = _mm_set1_ps(n.origin[a]);
        }
        const __m128i zero = _mm_setzero_si128();
        const int rows[6] = {r.nx, r.ny, r.nz, r.fx, r.fy, r.fz};
        __m128 lo[6], hi[6];  // the plane values of lanes 0-3 and 4-7
        for (int k = 0; k < 6; ++k) {
            const int a = k % 3;
            const __m128i w = _mm_unpacklo_epi8(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(n.q[rows[k]])), zero);
            lo[k] = _mm_add_ps(_mm_mul_ps(_mm_cvtepi32_ps(_mm_unpacklo_epi16(w, zero)), s[a]), org[a]);
            hi[k] = _mm_add_ps(_mm_mul_ps(_mm_cvtepi32_ps(_mm_unpackhi_epi16(w, zero)), s[a]), org[a]);
        }
        const unsigned mask = test4(lo, lo + 3, r, dist) | test4(hi, hi + 3, r, dist + 4) << 4;
        return mask & n.valid;
    }
};

}  // namespace
}  // namespace accel::bvh::sse2

namespace accel::bvh {
std::unique_ptr<BvhBase> make_kernel_sse2(TriangleTest test, bool quantized, bool masked) {
    return quantized ? sse2::make_kernel<sse2::Sse2Q>(test, masked) : sse2::make_kernel<sse2::Sse2>(test, masked);
}
std::unique_ptr<InstancedBase> make_instanced_sse2(TriangleTest test, bool top_quantized, bool quantized,
                                                   bool masked) {
    if (top_quantized)
        return quantized ? sse2::make_instanced<sse2::Sse2Q, sse2::Sse2Q>(test, masked) : sse2::make_instanced<sse2::Sse2Q, sse2::Sse2>(test, masked);
    return quantized ? sse2::make_instanced<sse2::Sse2, sse2::Sse2Q>(test, masked) : sse2::make_instanced<sse2::Sse2, sse2::Sse2>(test, masked);
}
}  // namespace accel::bvh
