// The SSE2 kernel: the x86-64 baseline, runs on every CPU. The 8-wide node is tested as
// two 4-lane halves. Compiled with -ffp-contract=off only (accel/CMakeLists.txt).
#define PT_KERNEL_NS sse2
#include "accel/bvh/kernel.h"
#include "accel/bvh/dispatch.h"

namespace accel::bvh::sse2 {
namespace {

struct Sse2 {
    using Box = BoxConstants<__m128>;
    /// Slab test of the eight child boxes; returns the hit mask, entry distances in dist.
    /// _mm_max_ps/_mm_min_ps return their SECOND operand when either is NaN, so the
    /// possibly-NaN slab distance goes first and the never-NaN accumulator second.
    static unsigned test(const WideNode& n, const Box& r, float t, float* dist) {
        const __m128 vt = _mm_set1_ps(t);
        unsigned mask = 0;
        for (int q = 0; q < kWidth; q += 4) {
            const __m128 tnx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[r.nx] + q), r.o[0]), r.inv[0]);
            const __m128 tny = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[r.ny] + q), r.o[1]), r.inv[1]);
            const __m128 tnz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[r.nz] + q), r.o[2]), r.inv[2]);
            const __m128 tfx = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[r.fx] + q), r.o[0]), r.inv[0]);
            const __m128 tfy = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[r.fy] + q), r.o[1]), r.inv[1]);
            const __m128 tfz = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(n.b[r.fz] + q), r.o[2]), r.inv[2]);
            const __m128 t0 = _mm_max_ps(tnx, _mm_max_ps(tny, _mm_max_ps(tnz, r.t_min)));
            const __m128 t1 = _mm_mul_ps(_mm_min_ps(tfx, _mm_min_ps(tfy, _mm_min_ps(tfz, vt))), r.scale);
            mask |= unsigned(_mm_movemask_ps(_mm_cmple_ps(t0, t1))) << q;
            _mm_store_ps(dist + q, t0);
        }
        return mask;
    }
    static int nearest(const float* dist, unsigned mask) { return nearest_scalar(dist, mask); }
    static unsigned push(const WideNode& n, unsigned mask, uint32_t* ref, uint32_t* count) {
        return push_scalar(n, mask, ref, count);
    }
};

}  // namespace
}  // namespace accel::bvh::sse2

namespace accel::bvh {
std::unique_ptr<BvhBase> make_kernel_sse2(TriangleTest test) { return sse2::make_kernel<sse2::Sse2>(test); }
}  // namespace accel::bvh
