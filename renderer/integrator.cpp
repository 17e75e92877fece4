#include "renderer/integrator.h"

#include <stdexcept>

#include "renderer/integrators/normals.h"

namespace renderer {

std::unique_ptr<Integrator> make_integrator(const IntegratorSettings& s, const scenes::Scene& scene,
                                            const SceneGeometry& geometry) {
    if (s.name == "normals") return std::make_unique<NormalsIntegrator>(scene, geometry);
    if (s.name == "direct" || s.name == "path")
        throw std::invalid_argument("--integrator=" + s.name +
                                    " is not available yet in this build (use --integrator=normals)");
    throw std::invalid_argument("unknown integrator '" + s.name +
                                "' (expected normals, direct or path)");
}

}  // namespace renderer
