// The AVX2 kernel: one 8-lane slab test per 256-byte node. Compiled with -mavx2 -mfma
// -ffp-contract=off (accel/CMakeLists.txt); chosen at run time only on CPUs with both.
#define PT_KERNEL_NS avx2
#include <immintrin.h>

#include "accel/bvh/kernel.h"
#include "accel/bvh/dispatch.h"

namespace accel::bvh::avx2 {
namespace {

#define PT_NODE8_MASK(t0, t1) unsigned(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ)))
#include "accel/bvh/node8.h"

}  // namespace
}  // namespace accel::bvh::avx2

namespace accel::bvh {
std::unique_ptr<BvhBase> make_kernel_avx2(TriangleTest test, bool quantized, bool masked) {
    return quantized ? avx2::make_kernel<avx2::QNode8>(test, masked) : avx2::make_kernel<avx2::Node8>(test, masked);
}
std::unique_ptr<InstancedBase> make_instanced_avx2(TriangleTest test, bool top_quantized, bool quantized,
                                                   bool masked) {
    if (top_quantized)
        return quantized ? avx2::make_instanced<avx2::QNode8, avx2::QNode8>(test, masked) : avx2::make_instanced<avx2::QNode8, avx2::Node8>(test, masked);
    return quantized ? avx2::make_instanced<avx2::Node8, avx2::QNode8>(test, masked) : avx2::make_instanced<avx2::Node8, avx2::Node8>(test, masked);
}
}  // namespace accel::bvh
