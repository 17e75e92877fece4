#include "accel/accelerator.h"
#include "accel/bvh/bvh.h"
#include "accel/naive/naive.h"
#include "accel/plugin/host.h"
#ifdef PT_HAVE_EMBREE
#include "accel/embree/embree.h"
#endif

namespace accel {

std::vector<std::string> available_backends() {
    std::vector<std::string> names{"naive", "custom"};
#ifdef PT_HAVE_EMBREE
    names.push_back("embree");
#endif
    return names;
}

bool is_backend_name(const std::string& name) {
    if (name.rfind("plugin:", 0) == 0) return name.size() > 7;
    for (const std::string& b : available_backends())
        if (b == name) return true;
    return false;
}

std::unique_ptr<Accelerator> create_accelerator(const std::string& name,
                                                std::span<const GeometryView> geometry,
                                                const AccelOptions& options) {
    // A filter sees one candidate per primitive; a sphere has two (entry and exit), and
    // no backend offers the second after the first is dropped, so only triangles mask.
    for (size_t i = 0; i < geometry.size(); ++i)
        if (geometry[i].masked() && geometry[i].type != GeometryType::Triangles)
            throw AccelError("geometry " + std::to_string(i) + ": hit filters apply to triangles only");
    if (name.rfind("plugin:", 0) == 0) return make_plugin(name.substr(7), geometry);
    if (name == "naive") return make_naive(geometry, options);
    if (name == "custom") return make_bvh(geometry, options);
#ifdef PT_HAVE_EMBREE
    if (name == "embree") return make_embree(geometry, options);
#else
    if (name == "embree") throw AccelError("this build has no Embree (PT_ENABLE_EMBREE=OFF)");
#endif
    throw AccelError("unknown accelerator '" + name + "' (expected naive, custom, embree or plugin:PATH[:OPTIONS])");
}

}  // namespace accel
