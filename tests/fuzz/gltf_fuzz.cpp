// libFuzzer target for the glTF loader. Each input is tried three ways: as .gltf JSON,
// as raw .glb bytes (exercises the container checks), and as the JSON chunk of a
// well-formed GLB (exercises the GLB code path past the header with arbitrary JSON).
// Anything but scenes::SceneError escaping, a crash, a hang or an OOM is a finding.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <vector>

#include "scenes/gltf/gltf.h"

namespace {

// External URIs must not resolve to anything on the fuzzing machine.
constexpr const char* kBaseDir = "/nonexistent-gltf-fuzz-dir";

void try_load(const void* data, size_t size, bool binary) {
    // A lower instance limit than the product's (2^27 instances are 7 GB): the fuzzer runs
    // under ASan with a 2 GB RSS cap, and a legitimate-but-huge instanced scene is not a bug.
    scenes::GltfLimits limits;
    limits.max_instances = uint64_t(1) << 20;
    try {
        scenes::Scene s = scenes::load_gltf_memory(data, size, binary ? "fuzz.glb" : "fuzz.gltf",
                                                   kBaseDir, binary, limits);
        // Touch the result so invariants are exercised, not just construction.
        for (const scenes::Mesh& m : s.meshes)
            for (uint32_t i : m.indices)
                if (i >= m.num_vertices()) __builtin_trap();
        for (const scenes::Instance& i : s.instances)
            if (i.prototype >= s.prototypes.size() || !i.object_to_world.finite()) __builtin_trap();
        for (const scenes::Prototype& p : s.prototypes)
            if (p.num_meshes == 0 || uint64_t(p.first_mesh) + p.num_meshes > s.meshes.size()) __builtin_trap();
    } catch (const scenes::SceneError&) {
    }
}

void put32(std::vector<uint8_t>& v, uint32_t x) {
    for (int i = 0; i < 4; ++i) v.push_back(uint8_t(x >> (8 * i)));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    try_load(data, size, false);
    try_load(data, size, true);
    std::vector<uint8_t> glb;
    size_t padded = (size + 3) & ~size_t(3);
    glb.reserve(20 + padded);
    glb.insert(glb.end(), {'g', 'l', 'T', 'F'});
    put32(glb, 2);
    put32(glb, uint32_t(20 + padded));
    put32(glb, uint32_t(padded));
    put32(glb, 0x4E4F534Au);
    glb.insert(glb.end(), data, data + size);
    glb.resize(20 + padded, ' ');
    if (size > 0) try_load(glb.data(), glb.size(), true);
    return 0;
}
