// The 8-lane node test shared by the AVX2 and AVX-512 kernels (included inside each
// kernel's namespace after kernel.h; PT_NODE8_MASK turns the t0 <= t1 compare into a lane
// mask: movemask on AVX2, a mask-register compare on AVX-512).
#pragma once

struct Node8 {
    using Box = BoxConstants<__m256>;
    /// The subtract-then-multiply form (not an FMA of precomputed org*inv): its two
    /// roundings are what Ize's far-distance scale is proven for. NaN operands go first
    /// in max/min so the accumulator wins (vmaxps returns the second operand on NaN).
    static unsigned test(const WideNode& n, const Box& r, float t, float* dist) {
        const __m256 tnx = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.b[r.nx]), r.o[0]), r.inv[0]);
        const __m256 tny = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.b[r.ny]), r.o[1]), r.inv[1]);
        const __m256 tnz = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.b[r.nz]), r.o[2]), r.inv[2]);
        const __m256 tfx = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.b[r.fx]), r.o[0]), r.inv[0]);
        const __m256 tfy = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.b[r.fy]), r.o[1]), r.inv[1]);
        const __m256 tfz = _mm256_mul_ps(_mm256_sub_ps(_mm256_load_ps(n.b[r.fz]), r.o[2]), r.inv[2]);
        const __m256 t0 = _mm256_max_ps(tnx, _mm256_max_ps(tny, _mm256_max_ps(tnz, r.t_min)));
        const __m256 t1f = _mm256_min_ps(tfx, _mm256_min_ps(tfy, _mm256_min_ps(tfz, r.inf)));
        const __m256 t1 = _mm256_mul_ps(_mm256_min_ps(t1f, _mm256_set1_ps(t)), r.scale);
        _mm256_store_ps(dist, t0);
        return PT_NODE8_MASK(t0, t1);
    }
};

