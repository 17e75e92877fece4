// glTF 2.0 (.gltf, .glb) loader.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "scenes/scene.h"

namespace scenes {

/// Bounds on what a file may make the loader build, against hostile files: unique
/// decoded geometry (vertex, index, normal and uv elements, each mesh counted once however
/// often it is placed) and instances, counted apart, as scenes/scene.h's kMaxInstances
/// says. Past either the load fails with a SceneError naming the node. The defaults are
/// the product's; tests and the fuzzer lower them.
struct GltfLimits {
    uint64_t max_elements = uint64_t(1) << 28;
    uint64_t max_instances = kMaxInstances;
};

/// Loads a .gltf or .glb file. A mesh the scene places more than once (several nodes, or
/// EXT_mesh_gpu_instancing) becomes one Prototype in object space and one Instance per
/// placement; a mesh placed once is loaded in world space. Throws SceneError naming the
/// file and the element (node, mesh, accessor, ...) on bad input.
Scene load_gltf(const std::string& path);

/// Same, from memory (fuzzing, tests). `name` stands for the file in messages; external
/// URIs are resolved relative to `base_dir`. `binary` selects GLB.
Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir, bool binary);

/// Same with explicit limits.
Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir, bool binary, const GltfLimits& limits);

}  // namespace scenes
