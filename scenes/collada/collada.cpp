// STUB: replaced by the COLLADA loader.
#include "scenes/collada/collada.h"
namespace scenes {
Scene load_collada(const std::string& path) { throw SceneError(path + ": COLLADA loader not built yet"); }
Scene load_collada_memory(const void*, size_t, const std::string& name) { throw SceneError(name + ": COLLADA loader not built yet"); }
}  // namespace scenes
