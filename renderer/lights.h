// Everything that emits, in one list the integrators sample: rectangular area lights,
// emissive meshes (sampled by solid angle where near, by area elsewhere), emissive spheres, point, spot and directional
// lights, and a constant environment. Built once per scene; only the kinds present cost
// anything.
#pragma once

#include <string>
#include <vector>

#include "accel/math.h"
#include "accel/ray.h"
#include "renderer/envmap.h"
#include "renderer/rng.h"
#include "renderer/spherical_triangle.h"
#include "renderer/texture.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec2f;
using accel::Vec3f;
struct Interaction;
struct Placement;

/// Which surfaces are lights (renderer/README.md, "Light semantics").
///  - Course: the CS184 course exactly. Light sampling (-l) draws only from the file's
///    explicit lights (library_lights: CGL area lights front side only, point, spot,
///    directional). Emissive meshes and spheres are seen, from both sides, by camera
///    rays and by the direct rays of hemisphere sampling (-H), and by nothing else: a
///    bounce adds only the light sampled at its next vertex. -H and -l converge to
///    slightly different images, as in the course.
///  - Mesh: every emissive surface is the light, sampled (by solid angle where near,
///    else by area) and seen by every ray; a mesh emits on both sides when its material
///    is double-sided (CS184 files always; glTF's doubleSided), else on the side its
///    shading normals face. An area light that describes an emissive panel is counted
///    once, as the mesh. -H and -l converge to the same image where every light is a
///    surface: no hemisphere ray finds a point, spot or directional light, which -l
///    samples under either model (the CLI says so when -H meets one).
enum class LightModel : uint8_t { Course, Mesh };

/// "course" | "mesh"; "" = the default for the scene's format (course for COLLADA,
/// mesh for glTF). Throws std::invalid_argument otherwise.
LightModel parse_light_model(const std::string& name, scenes::SceneFormat format);
const char* light_model_name(LightModel m);

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
    /// Under LightModel::Course nothing is deduplicated and emissive surfaces are not
    /// sampled (see LightModel). glTF scenes always use Mesh (a note says so when Course
    /// was asked for).
    LightSet(const scenes::Scene& scene, LightModel model, std::vector<std::string>& notes);

    LightModel model() const { return model_; }

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
    /// sampled by a cosine lobe around n), from `choice` (which placement of an instanced
    /// emissive mesh) and `u` (the point; an emissive mesh picks its triangle with u.x and
    /// reuses what is left of it, as Cycles does, so that a stratified u stays stratified
    /// over the whole light). Returns false when the sample carries nothing.
    bool sample(size_t i, const Vec3f& p, const Vec3f& n, float choice, Vec2f u, LightSample& out) const;
    /// The same from a stream: a choice number only where uses_choice(i), then the point.
    bool sample(size_t i, const Vec3f& p, const Vec3f& n, Rng& rng, LightSample& out) const {
        if (!uses_point(i)) return sample(i, p, n, 0.0f, Vec2f{}, out);
        const float c = uses_choice(i) ? rng.next_float() : 0.0f;
        const float u0 = rng.next_float();
        return sample(i, p, n, c, Vec2f{u0, rng.next_float()}, out);
    }
    /// Does sampling light i read its choice number (an instanced emissive mesh picks a
    /// placement)?
    bool uses_choice(size_t i) const { return lights_[i].kind == Kind::Mesh && lights_[i].num_inst > 0; }
    /// Does sampling light i read its point numbers (delta lights read none)?
    bool uses_point(size_t i) const { return !is_delta(i); }

    /// The emitter-visibility policy, consulted wherever an integrator adds emission
    /// found by a ray (camera rays, -H direct rays): the radiance the surface at `it`
    /// emits toward `wo`, zero when it does not emit that way. Consistent with sample():
    /// a side that is sampled is a side that is seen. Bounce rays add it with an MIS
    /// weight in Mesh (at diffuse vertices too, under --strategy=mis), and in Course only
    /// through delta lobes (mirror, glass), which light sampling cannot serve; a diffuse
    /// bounce in Course is black to it (the course's bounce).
    Vec3f emitted(const Interaction& it, const Vec3f& wo) const;

    /// For multiple importance sampling (renderer/integrators/path.cpp): the light that
    /// mesh `mesh` / sphere `sphere` / the environment is, or -1 if it is not sampled.
    /// A hit inside instance `inst` (accel::Hit::inst_id) on prototype mesh `mesh` finds
    /// the light of all that mesh's placements; pdf() then takes the instance too.
    int light_of_mesh(uint32_t mesh, uint32_t inst = accel::kInvalidId) const {
        if (inst != accel::kInvalidId) return mesh < proto_light_.size() ? proto_light_[mesh] : -1;
        return mesh < mesh_light_.size() ? mesh_light_[mesh] : -1;
    }
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
    /// point of light i at distance `dist` whose geometric normal is `nq` and, for an
    /// emissive mesh, which is on its triangle `prim` (unused for the environment) and,
    /// for an instanced one, in instance `inst`.
    float pdf(size_t i, const Vec3f& p, const Vec3f& n, const Vec3f& wi, float dist, const Vec3f& nq,
              uint32_t prim = 0, uint32_t inst = accel::kInvalidId) const;

    /// Could a ray from ray.org along ray.dir find an emitter (or the environment)? False
    /// only where every emitter is one of a few world-space triangles and the ray passes
    /// clear of all of them ("emitter guard" in renderer/README.md): a path the roulette
    /// ends then skips the trace that would only look for emission. Conservative: true
    /// whenever in doubt.
    bool may_emit_toward(const accel::Ray& ray) const;

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
        uint32_t first_tri = 0, num_tris = 0;    // mesh: range in tris_/pick_
        /// mesh: tri_of_prim_[first_prim + mesh triangle] (for the mesh's num_prims
        /// triangles) is that triangle's index in tris_ (kNoTri where degenerate), so
        /// pdf() finds a hit's triangle in O(1).
        uint32_t first_prim = 0, num_prims = 0;
        uint32_t texture = scenes::kNoTexture;   // mesh: emission texture
        /// Instanced mesh: its placements are inst_ids_/inst_cdf_[first_inst, +num_inst),
        /// its triangles (in tris_, `area` = their total) in object space. 0: world space.
        uint32_t first_inst = 0, num_inst = 0;
    };
    struct Tri {
        Vec3f v0, e1, e2;
        Vec3f n;  ///< unit normal of the emitting side
        float area;
        Vec3f centroid;
        float near2;  ///< squared distance from the centroid within which it is "near"
        bool two_sided;
        uint32_t mesh, index;  ///< for textured emission: where to find the uvs
    };
    /// The spherical triangle of `t` seen from p when p is near it, else an invalid one.
    static SphericalTriangle near_triangle(const Tri& t, const Vec3f& p);
    /// The object-space triangle `t` placed by `place` (renderer/interaction.h): world
    /// vertices, unit emitting normal, area, centroid and reach, as a world-space
    /// emitter's Tri would hold them, made at the sample (or pdf) that needs it.
    static Tri placed(const Tri& t, const Placement& place);
    /// Decides whether may_emit_toward can answer no for this scene (guarded_).
    void build_guard(const scenes::Scene& scene);
    static constexpr size_t kGuardTris = 16;
    static constexpr float kGuardSlack = 1e-3f;
    bool guarded_ = false;
    /// Per triangle of tris_, where guarded_: the determinant below which a ray counts as
    /// in its plane (times the ray's length), and the t slack from its edges.
    struct GuardTri {
        float det_floor, t_slack;
    };
    std::vector<GuardTri> guard_;
    /// sample() of an instanced mesh light (Light::num_inst > 0).
    bool sample_instanced(const Light& l, const Vec3f& p, float choice, Vec2f u2, LightSample& out) const;
    /// Probability with which instanced light `l` picks its placement number k (the gap
    /// of its cdf: sample() and pdf() read the same numbers).
    float instance_pmf(const Light& l, uint32_t k) const {
        const float* c = inst_cdf_.data() + l.first_inst;
        return c[k] - (k ? c[k - 1] : 0.0f);
    }

    /// One entry of an alias table (Walker 1977, built by Vose's method, 1991; pbrt-v4's
    /// AliasTable): bin k keeps k with probability q, else gives `alias`. A triangle is
    /// picked by area with one memory access instead of a binary search over a running
    /// sum, which cost 4 % of a DamagedHelmet render (15k emissive triangles; the
    /// "light selection" row of renderer/README.md).
    struct AliasBin {
        float q;
        uint32_t alias;
    };
    static constexpr uint32_t kNoTri = ~0u;
    /// Index in [0, n) drawn from bins[0, n) by u in [0, 1). `rest`, where given: u's
    /// unused part, uniform in [0, 1) given the index (pbrt-v4's uRemapped), for the point.
    static uint32_t pick(const AliasBin* bins, uint32_t n, float u, float* rest = nullptr);
    /// Appends the n bins that pick tris[k] with probability area / total area.
    static void build_alias_table(const Tri* tris, uint32_t n, std::vector<AliasBin>& out);

    std::vector<Light> lights_;
    std::vector<Tri> tris_;        // emissive triangles, grouped by mesh light
    std::vector<AliasBin> pick_;   // per mesh light: its triangles by area
    std::vector<uint32_t> tri_of_prim_;
    int env_ = -1;
    LightModel model_ = LightModel::Mesh;
    std::vector<int> mesh_light_, sphere_light_;  // scene mesh / sphere -> light, -1 if none
    /// Emissive prototype meshes: a prototype mesh -> the light of all its placements.
    /// A placement is 8 bytes (its instance id, ascending, and its cdf entry by world
    /// area, i.e. power, as every placement shares the mesh's emission), and only
    /// placements of emissive prototype meshes have one: N placements of an emitter are
    /// N sampled emitters without N copies of its triangles.
    std::vector<int> proto_light_;
    std::vector<uint32_t> inst_ids_;
    std::vector<float> inst_cdf_;
    /// Per texture (empty where unused): the zero tiles of emission textures, so that
    /// emitted() reads a glow map only where it may glow.
    std::vector<ZeroTiles> emission_zero_;
    EnvironmentMap env_map_;  // an image environment (-e), importance-sampled
    const scenes::Scene* scene_ = nullptr;  // for emission textures
};

}  // namespace renderer
