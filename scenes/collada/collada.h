// CS184 COLLADA 1.4.1 dialect loader (see ../shared/scenes/README.md).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "scenes/scene.h"

namespace scenes {

/// Caps on what a document may expand to. Everything a document holds is already bounded
/// by its size; these bound what it can multiply (instance_node reuse, deep nesting),
/// so a small hostile file cannot exhaust memory or the stack.
struct ColladaLimits {
    /// Unique triangles, whole scene: a geometry kept as a prototype counts once however
    /// often it is placed; a flattened copy counts as its own.
    uint64_t max_triangles = uint64_t(1) << 26;
    uint32_t max_node_depth = 256;  ///< node nesting incl. instance_node
    uint64_t max_node_visits = uint64_t(1) << 18;
    uint64_t max_instances = kMaxInstances;  ///< Scene::instances, counted apart from triangles
};

/// Loads a .dae file. Throws SceneError naming the file and the element on bad input.
/// A <geometry> placed more than once with the same material binding (by several
/// <instance_geometry>, or through an <instance_node> used more than once) becomes one
/// Prototype in object space and one Instance per placement; one placed once is loaded in
/// world space. Spheres, lights and cameras are always placed in world space.
Scene load_collada(const std::string& path);

/// Same, from memory (fuzzing, tests). `name` stands for the file in messages.
Scene load_collada_memory(const void* data, size_t size, const std::string& name);

/// Same with explicit limits (the fuzzer lowers them to stay inside its memory budget).
Scene load_collada_memory(const void* data, size_t size, const std::string& name,
                          const ColladaLimits& limits);

}  // namespace scenes
