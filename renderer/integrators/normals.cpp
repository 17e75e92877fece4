// Normal shading (the course's Part 1 check): colour = shading normal * 0.5 + 0.5.
#include "renderer/integrators/normals.h"

#include "renderer/interaction.h"

namespace renderer {

Vec3f NormalsIntegrator::li(const accel::Ray& ray, SampleContext& ctx) const {
    accel::Hit hit;
    if (!ctx.accel.intersect(ray, hit, ctx.stats)) return Vec3f(0.0f);
    const Interaction it = make_interaction(scene_, geometry_, ray, hit);
    ctx.aov.normal = it.ns;
    ctx.aov.depth = it.t;
    if (it.material < scene_.materials.size()) ctx.aov.albedo = scene_.materials[it.material].albedo;
    return it.ns * 0.5f + Vec3f(0.5f);
}

}  // namespace renderer
