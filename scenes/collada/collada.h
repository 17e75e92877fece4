// CS184 COLLADA 1.4.1 dialect loader (see ../shared/scenes/README.md).
#pragma once

#include <cstddef>
#include <string>

#include "scenes/scene.h"

namespace scenes {

/// Loads a .dae file. Throws SceneError naming the file and the element on bad input.
Scene load_collada(const std::string& path);

/// Same, from memory (fuzzing, tests). `name` stands for the file in messages.
Scene load_collada_memory(const void* data, size_t size, const std::string& name);

}  // namespace scenes
