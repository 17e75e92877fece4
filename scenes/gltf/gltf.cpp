// STUB: replaced by the glTF loader.
#include "scenes/gltf/gltf.h"
namespace scenes {
Scene load_gltf(const std::string& path) { throw SceneError(path + ": glTF loader not built yet"); }
Scene load_gltf_memory(const void*, size_t, const std::string& name, const std::string&, bool) { throw SceneError(name + ": glTF loader not built yet"); }
}  // namespace scenes
