// glTF 2.0 (.gltf, .glb) loader.
#pragma once

#include <cstddef>
#include <string>

#include "scenes/scene.h"

namespace scenes {

/// Loads a .gltf or .glb file. Throws SceneError naming the file and the element
/// (node, mesh, accessor, ...) on bad input.
Scene load_gltf(const std::string& path);

/// Same, from memory (fuzzing, tests). `name` stands for the file in messages; external
/// URIs are resolved relative to `base_dir`. `binary` selects GLB.
Scene load_gltf_memory(const void* data, size_t size, const std::string& name,
                       const std::string& base_dir, bool binary);

}  // namespace scenes
