// Picks the traversal kernel by CPUID at run time. Compiled for baseline x86-64.
#include "accel/bvh/dispatch.h"

#include "accel/bvh/bvh.h"

namespace accel {

const char* isa_name(Isa isa) {
    switch (isa) {
        case Isa::Sse2: return "sse2";
        case Isa::Avx2: return "avx2";
        case Isa::Avx512: return "avx512";
        default: return "auto";
    }
}

bool parse_isa(const std::string& s, Isa& out) {
    for (Isa i : {Isa::Auto, Isa::Sse2, Isa::Avx2, Isa::Avx512})
        if (s == isa_name(i)) return out = i, true;
    return false;
}

bool cpu_has(Isa isa) {
    // GCC's cpu model also checks that the OS saves the wider registers (XGETBV).
    __builtin_cpu_init();
    switch (isa) {
        case Isa::Sse2: return true;
        case Isa::Avx2: return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
        case Isa::Avx512:
            return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                   __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw") &&
                   __builtin_cpu_supports("fma");
        default: return true;
    }
}

Isa resolve_isa(Isa isa) {
    if (isa != Isa::Auto) return isa;
    // AVX-512 where the CPU has it: the nodes stay 8 wide (256-bit vectors), but the
    // any-hit query pushes its hit children by vpcompressd and picks the nearest by a
    // masked minimum, one instruction each, and the compares land in mask registers:
    // shadow rays 4-7 % faster, closest-hit even to 3 % faster on the course meshes,
    // within noise on the 5M sphere (accel/DECISIONS.md, "AVX-512 by default").
    if (cpu_has(Isa::Avx512)) return Isa::Avx512;
    return cpu_has(Isa::Avx2) ? Isa::Avx2 : Isa::Sse2;
}

std::vector<Isa> supported_isas() {
    std::vector<Isa> out;
    for (Isa i : {Isa::Sse2, Isa::Avx2, Isa::Avx512})
        if (cpu_has(i)) out.push_back(i);
    return out;
}

namespace bvh {

std::unique_ptr<BvhBase> make_kernel(Isa isa, TriangleTest test, bool quantized, bool masked) {
    isa = resolve_isa(isa);
    if (!cpu_has(isa)) throw AccelError(std::string("this CPU cannot run the ") + isa_name(isa) + " BVH kernel");
    switch (isa) {
        case Isa::Avx2: return make_kernel_avx2(test, quantized, masked);
        case Isa::Avx512: return make_kernel_avx512(test, quantized, masked);
        default: return make_kernel_sse2(test, quantized, masked);
    }
}

std::unique_ptr<InstancedBase> make_instanced(Isa isa, TriangleTest test, bool top_quantized, bool quantized,
                                              bool masked) {
    isa = resolve_isa(isa);
    if (!cpu_has(isa)) throw AccelError(std::string("this CPU cannot run the ") + isa_name(isa) + " BVH kernel");
    switch (isa) {
        case Isa::Avx2: return make_instanced_avx2(test, top_quantized, quantized, masked);
        case Isa::Avx512: return make_instanced_avx512(test, top_quantized, quantized, masked);
        default: return make_instanced_sse2(test, top_quantized, quantized, masked);
    }
}

}  // namespace bvh
}  // namespace accel
