// Scene loading by file extension, and the scene summary.
#pragma once

#include <cstdint>
#include <string>

#include "scenes/scene.h"

namespace scenes {

/// Loads .dae, .gltf or .glb. Throws SceneError (message names the file) on a missing,
/// unreadable, unknown-format or malformed file.
Scene load_scene(const std::string& path);

/// Bytes the scene's data occupies (capacities of its arrays).
uint64_t scene_bytes(const Scene& scene);

/// Multi-line human summary: counts (triangles, spheres, lights by kind, materials,
/// textures), replaced materials and memory.
std::string scene_summary(const Scene& scene);

}  // namespace scenes
