// The 8-lane node test shared by the AVX2 and AVX-512 kernels (included inside each
// kernel's namespace after kernel.h; PT_NODE8_MASK turns the t0 <= t1 compare into a lane
// mask: movemask on AVX2, a mask-register compare on AVX-512).
#pragma once

#ifndef __AVX512VL__
/// Lane compaction for AVX2, which has no compress instruction: for each 8-bit mask, the
/// source lanes of the set bits packed in 4-bit fields (the usual permutation-table
/// substitute for vpcompressd; one 1 KiB table, L1-resident in a traversal loop).
struct CompressTable {
    uint32_t lanes[256];
    constexpr CompressTable() : lanes() {
        for (unsigned m = 0; m < 256; ++m) {
            unsigned k = 0;
            for (unsigned l = 0; l < 8; ++l)
                if (m >> l & 1) lanes[m] |= l << (4 * k++);
        }
    }
};
inline constexpr CompressTable kCompress{};
#endif

struct Node8 {
    using Node = WideNode;
    static constexpr bool kPrefetch = true;
    static constexpr bool kPrefetchShadow = false;
    using Box = BoxConstants<__m256>;
    /// The subtract-then-multiply form (not an FMA of precomputed org*inv): its
    /// roundings are what the far-distance scale (kernel.h, kFarScale) is proven for;
    /// written (o - b) * -inv, the same bits, so that the row is a memory operand
    /// (kernel.h, BoxConstants). The distances reduce as a tree, two max (min) levels
    /// instead of three in a row, and the far scale is folded into neg_inv_far: by count, about 3 of the ~40 cycles from
    /// a node's load to its child's on the course meshes (shadow and diffuse +2 to +4 %,
    /// 5M sphere +2 to +9 %; accel/DECISIONS.md, "node test as a tree"). NaN (0 * inf: a zero direction
    /// component, the origin on that plane): vmaxps/vminps return their second operand
    /// when either is NaN. The accumulator (t_min, the segment's end) is second in the
    /// second pair, so that pair is never NaN, and the root returns it when the first
    /// pair is: t0 and t1 are never NaN. A NaN in y drops x's distance too, which only
    /// widens [t0, t1]: no box the ray enters is culled.
    PT_INLINE static unsigned test(const WideNode& n, const Box& r, float* dist) {
        const auto slab = [&](int row, int a, __m256 neg_inv) {
            return _mm256_mul_ps(_mm256_sub_ps(r.o[a], _mm256_load_ps(n.b[row])), neg_inv);
        };
        const __m256 tnx = slab(r.nx, 0, r.neg_inv[0]), tny = slab(r.ny, 1, r.neg_inv[1]);
        const __m256 tnz = slab(r.nz, 2, r.neg_inv[2]);
        const __m256 tfx = slab(r.fx, 0, r.neg_inv_far[0]), tfy = slab(r.fy, 1, r.neg_inv_far[1]);
        const __m256 tfz = slab(r.fz, 2, r.neg_inv_far[2]);
        const __m256 t0 = _mm256_max_ps(_mm256_max_ps(tnx, tny), _mm256_max_ps(tnz, r.t_min));
        const __m256 t1 = _mm256_min_ps(_mm256_min_ps(tfx, tfy), _mm256_min_ps(tfz, r.t_far));
        _mm256_store_ps(dist, t0);
        return PT_NODE8_MASK(t0, t1);
    }

    /// The first hit lane with the smallest order key (kernel.h, order_key), for occlusion
    /// rays, which need a good order but not the exact one: the other lanes' keys are
    /// 0xFFFF, and one phminposuw finds the smallest and its lane. Half the latency of a
    /// full-precision horizontal minimum (three shuffle-min steps, a compare, a movemask),
    /// on the path from a node's test to the fetch of the next node: shadow rays +2 to
    /// +5 % on the course meshes (accel/DECISIONS.md, "16-bit nearest key").
    PT_INLINE static int nearest(const float* dist, unsigned mask) {
        const __m256i bits = _mm256_srli_epi32(_mm256_castps_si256(_mm256_load_ps(dist)), 16);
#ifdef __AVX512VL__
        const __m256i keys = _mm256_mask_mov_epi32(_mm256_set1_epi32(0xFFFF), __mmask8(mask), bits);
#else
        const __m256i lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        const __m256i sel = _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(mask)), lane_bits), lane_bits);
        const __m256i keys = _mm256_blendv_epi8(_mm256_set1_epi32(0xFFFF), bits, sel);
#endif
#ifdef __AVX512VL__
        // One truncating move (vpmovdw) instead of an extract and a pack: the keys fit 16
        // bits. Shadow rays +1 to +3 % on every mesh measured ("16-bit nearest key").
        const __m128i packed = _mm256_cvtepi32_epi16(keys);
#else
        const __m128i packed = _mm_packus_epi32(_mm256_castsi256_si128(keys), _mm256_extracti128_si256(keys, 1));
#endif
        return int(unsigned(_mm_cvtsi128_si32(_mm_minpos_epu16(packed))) >> 16 & 7u);
    }

    /// Stores the references of the hit lanes in `mask`, in lane order, as one vector
    /// each for child and count (the stack has kWidth entries of slack); returns how many.
    template <class N>
    PT_INLINE static unsigned push(const N& n, unsigned mask, uint32_t* ref, uint32_t* count) {
        const __m256i c = _mm256_load_si256(reinterpret_cast<const __m256i*>(n.child));
        const __m256i k = _mm256_load_si256(reinterpret_cast<const __m256i*>(n.count));
#ifdef __AVX512VL__
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(ref), _mm256_maskz_compress_epi32(__mmask8(mask), c));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(count), _mm256_maskz_compress_epi32(__mmask8(mask), k));
#else
        // permutevar8x32 reads only the low three bits of each index.
        const __m256i sel = _mm256_srlv_epi32(_mm256_set1_epi32(int(kCompress.lanes[mask])),
                                              _mm256_setr_epi32(0, 4, 8, 12, 16, 20, 24, 28));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(ref), _mm256_permutevar8x32_epi32(c, sel));
        _mm256_storeu_si256(reinterpret_cast<__m256i*>(count), _mm256_permutevar8x32_epi32(k, sel));
#endif
        return unsigned(__builtin_popcount(mask));
    }
};


/// The compressed node (QuantNode, Ylitie et al. 2017): each child bound is dequantised
/// to the float the build checked (origin + q * 2^e: one rounding, the product being
/// exact, so the FMA gives the same bits as quantize.cpp's mul + add), then tested by
/// Node8's slab test. Half the bytes of WideNode (two cache lines) for about 20 more
/// instructions per node: it pays only where node fetches miss the caches (accel/DECISIONS.md, "quantized-node threshold").
struct QNode8 : Node8 {
    using Node = QuantNode;
    static constexpr bool kPrefetch = true;
    static constexpr bool kPrefetchShadow = true;
    PT_INLINE static unsigned test(const QuantNode& n, const Box& r, float* dist) {
        // The grid steps: each biased exponent byte shifted into a float's exponent
        // field (lane 3 holds `valid` and is not used).
        int32_t e;
        std::memcpy(&e, n.exp, 4);
        const __m128 s4 = _mm_castsi128_ps(_mm_slli_epi32(_mm_cvtepu8_epi32(_mm_cvtsi32_si128(e)), 23));
        const __m256 s[3] = {_mm256_broadcastss_ps(s4), _mm256_broadcastss_ps(_mm_shuffle_ps(s4, s4, 0x55)),
                             _mm256_broadcastss_ps(_mm_shuffle_ps(s4, s4, 0xAA))};
        const auto slab = [&](int row, int a, __m256 neg_inv) {
            const __m128i q8 = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(n.q[row]));
            const __m256 b = _mm256_fmadd_ps(_mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(q8)), s[a],
                                             _mm256_broadcast_ss(&n.origin[a]));
            return _mm256_mul_ps(_mm256_sub_ps(r.o[a], b), neg_inv);
        };
        const __m256 tnx = slab(r.nx, 0, r.neg_inv[0]), tny = slab(r.ny, 1, r.neg_inv[1]);
        const __m256 tnz = slab(r.nz, 2, r.neg_inv[2]);
        const __m256 tfx = slab(r.fx, 0, r.neg_inv_far[0]), tfy = slab(r.fy, 1, r.neg_inv_far[1]);
        const __m256 tfz = slab(r.fz, 2, r.neg_inv_far[2]);
        const __m256 t0 = _mm256_max_ps(_mm256_max_ps(tnx, tny), _mm256_max_ps(tnz, r.t_min));
        const __m256 t1 = _mm256_min_ps(_mm256_min_ps(tfx, tfy), _mm256_min_ps(tfz, r.t_far));
        _mm256_store_ps(dist, t0);
        return PT_NODE8_MASK(t0, t1) & n.valid;
    }
};
