// Run-time choice of the traversal kernel (STYLE.md section 9; Embree's getCPUFeatures
// + SELECT_SYMBOL): each kernel_ISA.cpp is compiled with its own flags, and one CPUID
// check picks the factory.
#pragma once

#include <memory>

#include "accel/bvh/base.h"

namespace accel::bvh {

std::unique_ptr<BvhBase> make_kernel_sse2(TriangleTest test);
std::unique_ptr<BvhBase> make_kernel_avx2(TriangleTest test);
std::unique_ptr<BvhBase> make_kernel_avx512(TriangleTest test);

/// The kernel for `isa` (Auto resolved first); throws AccelError if this CPU lacks it.
std::unique_ptr<BvhBase> make_kernel(Isa isa, TriangleTest test);

}  // namespace accel::bvh
