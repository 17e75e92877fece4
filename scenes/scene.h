// Plain scene description: what loaders produce and the renderer consumes. Everything is
// in world space. Header-only on purpose: the loader libraries (scenes/collada,
// scenes/gltf) depend on this header and nothing else of scenes/.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "accel/math.h"

namespace scenes {

using accel::Bounds3f;
using accel::Mat4f;
using accel::Vec2f;
using accel::Vec3f;

inline constexpr uint32_t kNoTexture = 0xFFFFFFFFu;

/// 8-bit or float RGB(A) texture, decoded to linear float RGB at load time
/// (base colour and emissive textures are sRGB-decoded by the loader).
struct Texture {
    std::string name;
    uint32_t width = 0, height = 0;
    std::vector<float> rgb;  ///< width*height*3 linear values, row 0 at the top
};

/// Which BSDF a material uses (renderer/bsdf/). Plain data: the parameters below that
/// the kind does not use are ignored.
enum class BsdfKind : uint8_t {
    Diffuse,     ///< Lambert with `albedo` (the default, and every pre-3-2 CS184 file)
    Mirror,      ///< CGL mirror: perfect specular reflection tinted by `reflectance`
    Glass,       ///< CGL glass/refraction: smooth dielectric, `reflectance`/`transmittance`, `ior`
    Microfacet,  ///< CGL microfacet: Beckmann `alpha`, conductor Fresnel from per-channel eta, k
    MetallicRoughness,  ///< glTF 2.0 core PBR (+ KHR_materials_transmission / _ior)
};

/// A surface's material. Emissive materials emit and do not reflect (the BSDF is ignored
/// when emission is non-zero), unless `emitter_reflects` is set (a surface that does
/// both, e.g. a white-furnace enclosure).
struct Material {
    std::string name;
    BsdfKind bsdf = BsdfKind::Diffuse;
    Vec3f albedo{0.8f, 0.8f, 0.8f};  ///< diffuse albedo; glTF base colour
    Vec3f emission{0.0f, 0.0f, 0.0f};
    uint32_t albedo_texture = kNoTexture;    ///< multiplies albedo
    uint32_t emission_texture = kNoTexture;  ///< multiplies emission
    // Mirror / Glass (CS184 3-2 element names).
    Vec3f reflectance{1.0f, 1.0f, 1.0f};
    Vec3f transmittance{1.0f, 1.0f, 1.0f};
    float ior = 1.5f;  ///< glass; glTF KHR_materials_ior
    // Microfacet (course): per-channel complex index of refraction and Beckmann roughness.
    Vec3f eta{0.2f, 0.9f, 1.1f};  ///< the course's default-ish gold-like values if absent
    Vec3f k{3.9f, 2.4f, 2.2f};
    float alpha = 0.5f;
    // glTF metallic-roughness.
    float metallic = 1.0f, roughness = 1.0f;
    uint32_t metallic_roughness_texture = kNoTexture;  ///< linear; G = roughness, B = metallic
    float transmission = 0.0f;                          ///< KHR_materials_transmission factor
    uint32_t transmission_texture = kNoTexture;         ///< linear; R = transmission
    uint32_t normal_texture = kNoTexture;               ///< tangent-space, linear [0,1] encoded
    float normal_scale = 1.0f;
    /// Non-empty when the file asked for a BSDF we do not model and render as diffuse
    /// with `albedo`: names what was replaced.
    std::string replaced;
    bool emitter_reflects = false;
    /// Emits on both sides (CS184 files: the course's emission has no side test; glTF:
    /// the material's doubleSided). One-sided emitters emit toward their shading normals.
    bool double_sided = true;
    /// glTF KHR_materials_unlit: camera rays see the base colour (`albedo` times
    /// `albedo_texture`) as radiance, with no lighting; every other ray finds it black
    /// (it neither reflects nor lights anything). One-sided unless `double_sided`.
    bool unlit = false;

    bool is_emissive() const {
        return emission.x > 0.0f || emission.y > 0.0f || emission.z > 0.0f;
    }
};

/// Indexed triangle mesh with one material.
struct Mesh {
    std::string name;
    /// Vertex positions. Always keep one extra, unused element after the last vertex
    /// (Embree reads vertex buffers with 16-byte loads); use num_vertices(), not size().
    std::vector<Vec3f> positions;
    std::vector<uint32_t> indices;  ///< 3 per triangle
    /// Optional per-vertex shading normals (same indexing as positions, no padding),
    /// stored only when the file provides them. Empty = use the geometric normal.
    std::vector<Vec3f> normals;
    /// Optional per-vertex texture coordinates, stored only when a material uses a texture.
    std::vector<Vec2f> uvs;
    uint32_t material = 0;

    uint32_t num_vertices() const {
        return positions.empty() ? 0u : uint32_t(positions.size() - 1);
    }
    uint32_t num_triangles() const { return uint32_t(indices.size() / 3); }

    /// Call once after filling positions without padding: appends the padding element.
    void pad_positions() { positions.push_back(Vec3f{0.0f, 0.0f, 0.0f}); }
};

struct Sphere {
    Vec3f center;
    float radius = 1.0f;
    uint32_t material = 0;
};

enum class LightType : uint8_t { Area, Point, Directional, Spot, Environment };

/// Explicit lights (library_lights / KHR_lights_punctual). Emissive meshes and spheres
/// are lights through their material, not listed here.
struct Light {
    LightType type = LightType::Point;
    std::string name;
    /// Area: emitted radiance. Point/spot: intensity (W/sr). Directional: irradiance.
    /// Environment: constant radiance.
    Vec3f radiance{1.0f, 1.0f, 1.0f};
    Vec3f position;    ///< area: rectangle centre; point/spot: position
    Vec3f direction;   ///< directional/spot: direction light travels; area: facing normal
    Vec3f edge_u;      ///< area: full edge vector (centre +/- edge_u/2)
    Vec3f edge_v;      ///< area: full edge vector
    float spot_cos_inner = 1.0f, spot_cos_outer = 0.0f;
    /// Environment: latitude-longitude radiance image in Scene::textures (times
    /// `radiance`); kNoTexture = constant.
    uint32_t texture = kNoTexture;
};

struct Camera {
    std::string name;
    /// Camera-to-world transform of the camera node (camera looks down local -Z, +Y up).
    Mat4f camera_to_world;
    float xfov_deg = 49.13f;  ///< horizontal field of view, degrees
    float yfov_deg = 0.0f;    ///< vertical field of view, degrees (0 = derive from aspect)
    float aspect = 0.0f;      ///< width / height if the file gave it, else 0
    float znear = 0.01f, zfar = 1e30f;
};

enum class SceneFormat : uint8_t { Collada, Gltf };

struct Scene {
    std::string source;  ///< path the scene was loaded from
    SceneFormat format = SceneFormat::Collada;
    Vec3f up{0.0f, 1.0f, 0.0f};  ///< the file's up axis, in world space
    std::vector<Mesh> meshes;
    std::vector<Sphere> spheres;
    std::vector<Material> materials;
    std::vector<Texture> textures;
    std::vector<Light> lights;
    std::optional<Camera> camera;
    /// Things the loader decided or skipped that a user should know (replaced
    /// materials, skipped primitives, missing but unneeded textures). Printed on stderr.
    std::vector<std::string> notes;
    /// Parts of the file's intent that could not be honoured (a missing texture file,
    /// rendered with its factor alone). Printed on stderr; `pathtracer --strict` refuses.
    std::vector<std::string> warnings;

    uint64_t num_triangles() const {
        uint64_t n = 0;
        for (const Mesh& m : meshes) n += m.num_triangles();
        return n;
    }
    Bounds3f bounds() const {
        Bounds3f b;
        for (const Mesh& m : meshes)
            for (uint32_t i = 0; i < m.num_vertices(); ++i) b.extend(m.positions[i]);
        for (const Sphere& s : spheres) {
            b.extend(s.center - Vec3f(s.radius));
            b.extend(s.center + Vec3f(s.radius));
        }
        return b;
    }
};

/// Bad input. The message names the file and the element, accessor or line; tools print
/// it and exit with status 2.
class SceneError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

}  // namespace scenes
