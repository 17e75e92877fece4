// libFuzzer target for the COLLADA loader: any input must either load or throw
// SceneError; crashes, hangs, sanitizer reports and memory blow-ups are bugs.
#include <cstddef>
#include <cstdint>

#include "scenes/collada/collada.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    // Tighter expansion limits than the defaults: the fuzzer runs under ASan with a
    // 2 GB RSS cap, and a legitimate-but-huge instanced scene is not a bug.
    scenes::ColladaLimits limits;
    limits.max_triangles = uint64_t(1) << 20;
    limits.max_node_visits = uint64_t(1) << 14;
    limits.max_node_depth = 64;
    limits.max_instances = uint64_t(1) << 20;
    try {
        scenes::Scene s = scenes::load_collada_memory(data, size, "fuzz.dae", limits);
        // Touch the result so the optimiser cannot drop the work.
        volatile uint64_t sink = s.num_triangles() + s.spheres.size() + s.lights.size();
        (void)sink;
    } catch (const scenes::SceneError&) {
    }
    return 0;
}
