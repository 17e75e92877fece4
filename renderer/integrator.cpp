#include "renderer/integrator.h"

#include <stdexcept>

#include "renderer/integrators/normals.h"
#include "renderer/integrators/path.h"

namespace renderer {

std::unique_ptr<Integrator> make_integrator(const IntegratorSettings& s, const scenes::Scene& scene,
                                            const SceneGeometry& geometry, const LightSet* lights) {
    if (s.name == "normals") return std::make_unique<NormalsIntegrator>(scene, geometry);
    if (s.name == "direct" || s.name == "path") {
        if (!lights) throw std::invalid_argument("--integrator=" + s.name + " needs the scene's lights");
        return std::make_unique<PathIntegrator>(scene, geometry, *lights, s);
    }
    throw std::invalid_argument("unknown integrator '" + s.name +
                                "' (expected normals, direct or path)");
}

}  // namespace renderer
