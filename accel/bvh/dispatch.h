// Run-time choice of the traversal kernel (STYLE.md section 9; Embree's getCPUFeatures
// + SELECT_SYMBOL): each kernel_ISA.cpp is compiled with its own flags, and one CPUID
// check picks the factory.
#pragma once

#include <memory>

#include "accel/bvh/base.h"
#include "accel/bvh/instanced.h"

namespace accel::bvh {

/// `quantized`: the kernel reads WideBvh::qnodes (QuantNode) instead of nodes.
/// `masked`: the kernel filters hits on masked geometry (GeometryView::filter); opaque
/// scenes get one that has no filter code at all.
std::unique_ptr<BvhBase> make_kernel_sse2(TriangleTest test, bool quantized, bool masked);
std::unique_ptr<BvhBase> make_kernel_avx2(TriangleTest test, bool quantized, bool masked);
std::unique_ptr<BvhBase> make_kernel_avx512(TriangleTest test, bool quantized, bool masked);

/// The kernel for `isa` (Auto resolved first); throws AccelError if this CPU lacks it.
std::unique_ptr<BvhBase> make_kernel(Isa isa, TriangleTest test, bool quantized, bool masked = false);

/// The two-level kernel for `isa` (instanced.h), as make_kernel.
std::unique_ptr<InstancedBase> make_instanced(Isa isa, TriangleTest test, bool top_quantized, bool quantized,
                                              bool masked);

}  // namespace accel::bvh
