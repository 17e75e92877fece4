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

bool backend_traces_instances(const std::string& name) {
    return name == "naive" || name == "custom" || name == "embree";
}

namespace {
/// The checks every backend relies on: prototypes are disjoint ranges of triangle
/// geometry, instances name a prototype and carry a finite, invertible transform.
void check_instances(std::span<const GeometryView> geometry, const InstanceSet& inst) {
    std::vector<uint8_t> owner(geometry.size(), 0);
    for (size_t p = 0; p < inst.prototypes.size(); ++p) {
        const PrototypeView& pv = inst.prototypes[p];
        if (uint64_t(pv.first_geom) + pv.num_geoms > geometry.size())
            throw AccelError("prototype " + std::to_string(p) + ": geometry range beyond the views");
        for (uint32_t g = pv.first_geom; g < pv.first_geom + pv.num_geoms; ++g) {
            if (owner[g]) throw AccelError("prototype " + std::to_string(p) + ": geometry " + std::to_string(g) +
                                           " already belongs to another prototype");
            owner[g] = 1;
            if (geometry[g].type != GeometryType::Triangles)
                throw AccelError("prototype " + std::to_string(p) + ": instanced geometry must be triangles");
        }
    }
    for (size_t i = 0; i < inst.instances.size(); ++i) {
        const InstanceView& iv = inst.instances[i];
        if (iv.prototype >= inst.prototypes.size())
            throw AccelError("instance " + std::to_string(i) + ": no prototype " + std::to_string(iv.prototype));
        if (!iv.object_to_world.finite() || !iv.object_to_world.inverse().finite())
            throw AccelError("instance " + std::to_string(i) + ": transform not finite or not invertible");
    }
}
}  // namespace

std::unique_ptr<Accelerator> create_accelerator(const std::string& name,
                                                std::span<const GeometryView> geometry,
                                                const AccelOptions& options, const InstanceSet& instances) {
    // A filter sees one candidate per primitive; a sphere has two (entry and exit), and
    // no backend offers the second after the first is dropped, so only triangles mask.
    for (size_t i = 0; i < geometry.size(); ++i)
        if (geometry[i].masked() && geometry[i].type != GeometryType::Triangles)
            throw AccelError("geometry " + std::to_string(i) + ": hit filters apply to triangles only");
    if (!instances.empty()) check_instances(geometry, instances);
    if (name.rfind("plugin:", 0) == 0) {
        if (!instances.empty())
            throw AccelError("plugin backends do not trace instances: flatten them (--instancing=flatten)");
        return make_plugin(name.substr(7), geometry);
    }
    if (name == "naive") return make_naive(geometry, options, instances);
    if (name == "custom") return make_bvh(geometry, options, instances);
#ifdef PT_HAVE_EMBREE
    if (name == "embree") return make_embree(geometry, options, instances);
#else
    if (name == "embree") throw AccelError("this build has no Embree (PT_ENABLE_EMBREE=OFF)");
#endif
    throw AccelError("unknown accelerator '" + name + "' (expected naive, custom, embree or plugin:PATH[:OPTIONS])");
}

}  // namespace accel
