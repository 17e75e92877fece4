// A glTF test file's text, and that text (edited or not) loaded under the file's name:
// the tests that check how the loader refuses a bad value change one field of a good file.
#pragma once

#include <fstream>
#include <sstream>
#include <string>

#include "scenes/gltf/gltf.h"

namespace gltf_text {

inline std::string read(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

/// Loads `text` as the file `name` (no folder for external files: they are refused).
inline scenes::Scene load(const std::string& text, const std::string& name) {
    return scenes::load_gltf_memory(text.data(), text.size(), name, "/nonexistent", false);
}

}  // namespace gltf_text
