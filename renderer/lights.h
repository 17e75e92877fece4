// Everything that emits, in one list the integrators sample: rectangular area lights,
// emissive meshes (sampled by area), emissive spheres, point, spot and directional
// lights, and a constant environment. Built once per scene; only the kinds present cost
// anything.
#pragma once

#include <string>
#include <vector>

#include "accel/math.h"
#include "renderer/envmap.h"
#include "renderer/rng.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec3f;

struct LightSample {
    Vec3f radiance;       ///< emitted radiance (area) or intensity-derived radiance (delta)
    Vec3f target;         ///< point on the light (finite lights)
    /// Rounding bound on |target - the light's exact surface| and the light's unit
    /// normal there (zero for point and spot lights, which are exact points and no
    /// surface): shadow segments stop short of the light's own surface with them
    /// (renderer/spawn.h, spawn_segment), at any scale and at grazing arrival.
    Vec3f target_error{0.0f};
    Vec3f normal{0.0f};
    Vec3f wi;             ///< unit direction from the shading point toward the light
    float distance = 0;   ///< to the target; infinity for directional/environment
    float pdf = 0;        ///< solid-angle density; 1 for delta lights
    bool delta = false;   ///< point/spot/directional: cannot be hit by a ray
};

class LightSet {
public:
    enum class Kind : uint8_t { Rect, Mesh, Sphere, Point, Spot, Directional, Environment };

    /// Builds the lights of `scene`. CGL area lights that duplicate an emissive mesh (same
    /// plane, same area within 5 %, same radiance; the CS184 files' "one light, two
    /// descriptions") are dropped, so the panel is counted once, as the mesh. A scene with
    /// no emitter at all gets a constant white environment. `notes` receives one line per
    /// decision.
    LightSet(const scenes::Scene& scene, std::vector<std::string>& notes);

    size_t size() const { return lights_.size(); }
    Kind kind(size_t i) const { return lights_[i].kind; }
    bool is_delta(size_t i) const {
        Kind k = lights_[i].kind;
        return k == Kind::Point || k == Kind::Spot || k == Kind::Directional;
    }
    bool has_environment() const { return env_ >= 0; }
    /// Radiance arriving from direction `dir` from infinitely far away.
    Vec3f environment(const Vec3f& dir) const {
        if (!has_environment()) return Vec3f(0.0f);
        return env_map_.empty() ? lights_[size_t(env_)].radiance : env_map_.radiance(dir);
    }

    /// Samples light `i` as seen from point `p` with unit normal `n` (the environment is
    /// sampled by a cosine lobe around n). Returns false when the sample carries nothing.
    bool sample(size_t i, const Vec3f& p, const Vec3f& n, Rng& rng, LightSample& out) const;

    /// For multiple importance sampling (renderer/integrators/path.cpp): the light that
    /// mesh `mesh` / sphere `sphere` / the environment is, or -1 if it is not sampled.
    int light_of_mesh(uint32_t mesh) const { return mesh < mesh_light_.size() ? mesh_light_[mesh] : -1; }
    int light_of_sphere(uint32_t sphere) const {
        return sphere < sphere_light_.size() ? sphere_light_[sphere] : -1;
    }
    int environment_index() const { return env_; }
    /// Can a ray find light i (so a BSDF sample competes with its light samples)?
    bool hittable(size_t i) const {
        const Kind k = lights_[i].kind;
        return k == Kind::Mesh || k == Kind::Sphere || k == Kind::Environment;
    }
    /// Solid-angle density with which sample(i, p, n) returns direction wi toward the
    /// point of light i at distance `dist` whose geometric normal is `nq` (unused for the
    /// environment).
    float pdf(size_t i, const Vec3f& n, const Vec3f& wi, float dist, const Vec3f& nq) const;

    /// Summary line per kind, for stderr.
    std::string summary() const;

private:
    struct Light {
        Kind kind;
        Vec3f radiance;
        Vec3f position, normal, edge_u, edge_v;  // rect: centre, facing normal, full edges
        float area = 0;
        float radius = 0;
        float cos_inner = 1, cos_outer = 0;
        uint32_t first_tri = 0, num_tris = 0;    // mesh: range in tris_/cdf_
        uint32_t texture = scenes::kNoTexture;   // mesh: emission texture
    };
    struct Tri {
        Vec3f v0, e1, e2;
        Vec3f n;  ///< unit normal of the emitting side
        uint32_t mesh, index;  ///< for textured emission: where to find the uvs
    };
    std::vector<Light> lights_;
    std::vector<Tri> tris_;    // emissive triangles, grouped by mesh light
    std::vector<float> cdf_;   // per mesh light: running area, normalised to 1 at its end
    int env_ = -1;
    std::vector<int> mesh_light_, sphere_light_;  // scene mesh / sphere -> light, -1 if none
    EnvironmentMap env_map_;  // an image environment (-e), importance-sampled
    const scenes::Scene* scene_ = nullptr;  // for emission textures
};

}  // namespace renderer
