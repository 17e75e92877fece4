// Rebuilds what integrators need at a hit from the small Hit record and the scene.
#pragma once

#include "accel/ray.h"
#include "renderer/scene_geometry.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec2f;
using accel::Vec3f;

struct Interaction {
    Vec3f p;        ///< hit point
    Vec3f ng;       ///< unit geometric normal (triangle winding / sphere outward)
    Vec3f ns;       ///< unit shading normal: interpolated file normals, else ng
    Vec2f uv;       ///< texture coordinates if the mesh stores them
    uint32_t material = 0;
    float t = 0;
    bool sphere = false;  ///< analytic sphere (emits on both sides)
};

/// Texture value at uv (nearest texel, wrapping); white for kNoTexture.
Vec3f texel(const scenes::Scene& scene, uint32_t texture, const Vec2f& uv);

Interaction make_interaction(const scenes::Scene& scene, const SceneGeometry& geometry,
                             const accel::Ray& ray, const accel::Hit& hit);

}  // namespace renderer
