// The AVX-512 kernel (F + VL + DQ + BW): the same 8-lane node test, compared into a mask
// register, and any-hit leaves of three or four blocks in one 16-lane test (kernel.h,
// tri16_mt). Compiled with -mavx512f -mavx512vl -mavx512dq -mavx512bw -mfma -ffp-contract=off
// (accel/CMakeLists.txt); auto picks it wherever the CPU has it (dispatch.cpp says why).
#define PT_KERNEL_NS avx512
#include <immintrin.h>

#include "accel/bvh/kernel.h"
#include "accel/bvh/dispatch.h"

namespace accel::bvh::avx512 {
namespace {

#define PT_NODE8_MASK(t0, t1) unsigned(_mm256_cmp_ps_mask(t0, t1, _CMP_LE_OQ))
#include "accel/bvh/node8.h"

}  // namespace
}  // namespace accel::bvh::avx512

namespace accel::bvh {
std::unique_ptr<BvhBase> make_kernel_avx512(TriangleTest test, bool quantized, bool masked) {
    return quantized ? avx512::make_kernel<avx512::QNode8>(test, masked) : avx512::make_kernel<avx512::Node8>(test, masked);
}
std::unique_ptr<InstancedBase> make_instanced_avx512(TriangleTest test, bool top_quantized, bool quantized,
                                                   bool masked) {
    if (top_quantized)
        return quantized ? avx512::make_instanced<avx512::QNode8, avx512::QNode8>(test, masked) : avx512::make_instanced<avx512::QNode8, avx512::Node8>(test, masked);
    return quantized ? avx512::make_instanced<avx512::Node8, avx512::QNode8>(test, masked) : avx512::make_instanced<avx512::Node8, avx512::Node8>(test, masked);
}
}  // namespace accel::bvh
