// Plain scene description: what loaders produce and the renderer consumes. Everything is
// in world space except the meshes of prototypes, which instances place. Header-only on purpose: the loader libraries (scenes/collada,
// scenes/gltf) depend on this header and nothing else of scenes/.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "accel/instance.h"
#include "accel/math.h"

namespace scenes {

using accel::Affine3f;
using accel::Bounds3f;
using accel::Mat4f;
using accel::Vec2f;
using accel::Vec3f;

inline constexpr uint32_t kNoTexture = 0xFFFFFFFFu;

/// IEEE binary16 bits to float (exact).
inline float half_to_float(uint16_t h) {
    const uint32_t sign = uint32_t(h & 0x8000u) << 16, e = (h >> 10) & 0x1Fu, m = h & 0x3FFu;
    uint32_t bits;
    if (e == 0) {
        const float v = float(m) * 5.9604644775390625e-8f;  // subnormal: m * 2^-24
        return sign ? -v : v;
    }
    if (e == 31) bits = sign | 0x7F800000u | (m << 13);
    else bits = sign | ((e + 112u) << 23) | (m << 13);
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
}

/// Float to IEEE binary16 bits, rounding to nearest even; overflow gives infinity.
inline uint16_t float_to_half(float f) {
    uint32_t x;
    std::memcpy(&x, &f, 4);
    const uint16_t sign = uint16_t((x >> 16) & 0x8000u);
    x &= 0x7FFFFFFFu;
    if (x >= 0x7F800000u) return uint16_t(sign | 0x7C00u | (x > 0x7F800000u ? 0x200u : 0u));
    if (x >= 0x477FF000u) return uint16_t(sign | 0x7C00u);
    if (x < 0x38800000u) {  // below 2^-14: a subnormal half, in units of 2^-24
        float v;
        std::memcpy(&v, &x, 4);
        return uint16_t(sign | uint16_t(v * 16777216.0f + 0.5f));
    }
    const uint32_t r = x + 0xFFFu + ((x >> 13) & 1u);
    return uint16_t(sign | uint16_t((r - 0x38000000u) >> 13));
}

/// sRGB-encoded value in [0, 1] to linear, the IEC 61966-2-1 curve: how the codes of a
/// Texture with `srgb` set decode.
inline float srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

/// The 256 8-bit sRGB codes, decoded: the loaders and the renderer's lookups share it.
inline const std::array<float, 256>& srgb8_to_linear() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (int i = 0; i < 256; ++i) t[size_t(i)] = srgb_to_linear(float(i) / 255.0f);
        return t;
    }();
    return table;
}

/// How a texture's texels are stored: at the source's precision, never wider. 8- and
/// 16-bit images stay integers (unorm), EXR halves stay half (raw IEEE binary16 bits),
/// float sources stay float.
enum class TexelFormat : uint8_t { U8, U16, F16, F32 };

inline constexpr size_t texel_format_bytes(TexelFormat f) {
    return f == TexelFormat::U8 ? 1 : f == TexelFormat::F32 ? 4 : 2;
}

/// How a texture continues outside [0, 1] along one axis (glTF sampler wrapS / wrapT):
/// tiled, its edge texels stretched, or tiled with every other copy mirrored. The same
/// rule gives a bilinear lookup's neighbour across an edge: the opposite edge's texel when
/// repeating, the edge texel itself otherwise.
enum class TextureWrap : uint8_t { Repeat, ClampToEdge, MirroredRepeat };

/// An image at its source's precision, holding only the channels a material reads, with
/// its MIP pyramid (renderer/texture.h filters it). Row 0 is at the top of each level.
struct Texture {
    std::string name;
    uint32_t width = 0, height = 0;  ///< level 0
    TexelFormat format = TexelFormat::F32;
    uint8_t channels = 0;  ///< stored per texel, interleaved
    /// slot[c]: which stored channel holds source channel c (R, G, B, A); -1 = not stored
    /// (read as 0, alpha as 1). Stored channels keep the source's order.
    int8_t slot[4] = {-1, -1, -1, -1};
    /// The stored R, G, B channels are sRGB-encoded 8-bit values, decoded on lookup (base
    /// colour and emissive); alpha and data textures are linear.
    bool srgb = false;
    /// The sampler's wrap along u (s) and v (t); glTF's default repeats.
    TextureWrap wrap_s = TextureWrap::Repeat, wrap_t = TextureWrap::Repeat;
    /// glTF magFilter NEAREST: where a texel is larger than the lookup's footprint, the
    /// nearest texel of level 0 rather than a blend of four (pixel art, labels).
    bool magnify_nearest = false;
    struct Level {
        uint32_t width = 0, height = 0;
        uint64_t offset = 0;  ///< bytes into `data`
    };
    /// levels[0] is width x height; the rest halve it down to 1x1 (empty: no texels).
    std::vector<Level> levels;
    std::vector<uint8_t> data;  ///< every level, one after another

    size_t texel_bytes() const { return size_t(channels) * texel_format_bytes(format); }
    bool empty() const { return levels.empty() || channels == 0; }
    const uint8_t* texel(uint32_t level, uint32_t x, uint32_t y) const {
        const Level& l = levels[level];
        return data.data() + l.offset + (size_t(y) * l.width + x) * texel_bytes();
    }

    /// One level of `channels` channels (named by `source`, e.g. "RGB", "GB"), no
    /// pyramid: allocates the texels, zeroed. `source` lists source channels in order.
    static Texture make(std::string name, uint32_t w, uint32_t h, TexelFormat format,
                        const char* source = "RGB") {
        Texture t;
        t.name = std::move(name);
        t.width = w;
        t.height = h;
        t.format = format;
        for (const char* c = source; *c; ++c) {
            const int i = *c == 'R' ? 0 : *c == 'G' ? 1 : *c == 'B' ? 2 : *c == 'A' ? 3 : -1;
            if (i < 0 || t.channels >= 4) throw std::invalid_argument("Texture::make: bad channel list");
            t.slot[i] = int8_t(t.channels++);
        }
        t.levels.push_back(Level{w, h, 0});
        t.data.assign(size_t(w) * h * t.texel_bytes(), 0);
        return t;
    }
    /// A float RGB image of w*h*3 linear values (environment maps, tests).
    static Texture from_rgb(std::string name, uint32_t w, uint32_t h, const std::vector<float>& rgb) {
        Texture t = make(std::move(name), w, h, TexelFormat::F32, "RGB");
        if (rgb.size() != size_t(w) * h * 3) throw std::invalid_argument("Texture::from_rgb: size mismatch");
        if (!rgb.empty()) std::memcpy(t.data.data(), rgb.data(), rgb.size() * sizeof(float));
        return t;
    }
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

/// How a material's alpha (Material::base_alpha times the alpha of albedo_texture) covers
/// its surface: glTF 2.0 material.alphaMode (spec section 3.9.4, "Alpha Coverage").
/// Opaque ignores alpha. Mask: fully opaque where alpha >= alpha_cutoff, absent
/// elsewhere. Blend: a ray sees the surface with probability alpha and passes through
/// it otherwise, which in expectation is the spec's "over" compositing (stochastic
/// transparency; the renderer's hit filter, renderer/scene_geometry.h).
enum class AlphaMode : uint8_t { Opaque, Mask, Blend };

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
    AlphaMode alpha_mode = AlphaMode::Opaque;
    float alpha_cutoff = 0.5f;  ///< Mask only: the glTF alphaCutoff (default 0.5)
    float base_alpha = 1.0f;    ///< the alpha of glTF baseColorFactor, in [0, 1]

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
    /// Optional per-vertex colours (glTF COLOR_0, linear RGB), which multiply the
    /// material's base colour; stored only when some vertex is not white.
    std::vector<Vec3f> colors;
    /// Optional per-vertex alpha (COLOR_0's fourth component), which multiplies the base
    /// alpha; stored only for a MASK or BLEND material with some vertex not opaque.
    std::vector<float> alphas;
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
    /// Orthographic (glTF "orthographic", COLLADA <orthographic>): parallel rays along -Z
    /// over half-extents xmag by ymag in camera space (0: derived from the other and the
    /// image's aspect); the fovs are unused.
    bool orthographic = false;
    float xmag = 0.0f, ymag = 0.0f;
};

/// A group of meshes in object space, placed by instances: the meshes
/// [first_mesh, first_mesh + num_meshes) of Scene::meshes. Loaders make one for each mesh
/// (or group) the file places more than once; a mesh placed once is flattened into
/// world space, so a scene without reuse has none.
struct Prototype {
    std::string name;
    uint32_t first_mesh = 0;
    uint32_t num_meshes = 0;
};

/// One placement of a prototype: Instance::prototype indexes Scene::prototypes, and
/// Instance::object_to_world is the composed transform of every node above it. The
/// accelerator's own type (accel/instance.h), so a scene's instances reach a backend
/// without a copy.
using Instance = accel::InstanceView;

/// The loaders' bound on what a file may make them build, against hostile files: unique
/// geometry elements (vertices, indices, texels are bounded by the file's own bytes) and
/// instances, counted apart, so that a forest of 10^7 placements of a few hundred
/// meshes is accepted and a file that asks for more of either is refused.
inline constexpr uint64_t kMaxInstances = uint64_t(1) << 27;

enum class SceneFormat : uint8_t { Collada, Gltf };

struct Scene {
    std::string source;  ///< path the scene was loaded from
    SceneFormat format = SceneFormat::Collada;
    Vec3f up{0.0f, 1.0f, 0.0f};  ///< the file's up axis, in world space
    std::vector<Mesh> meshes;
    std::vector<Prototype> prototypes;
    std::vector<Instance> instances;
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

    /// Unique triangles: every mesh once, prototypes included.
    uint64_t num_triangles() const {
        uint64_t n = 0;
        for (const Mesh& m : meshes) n += m.num_triangles();
        return n;
    }
    uint64_t prototype_triangles(uint32_t p) const {
        uint64_t n = 0;
        for (uint32_t i = 0; i < prototypes[p].num_meshes; ++i) n += meshes[prototypes[p].first_mesh + i].num_triangles();
        return n;
    }
    /// Triangles the instances place (what flattening them would copy).
    uint64_t instanced_triangles() const {
        std::vector<uint64_t> per(prototypes.size());
        for (uint32_t p = 0; p < prototypes.size(); ++p) per[p] = prototype_triangles(p);
        uint64_t n = 0;
        for (const Instance& i : instances) n += per[i.prototype];
        return n;
    }
    /// Triangles placed in world space directly (meshes outside every prototype).
    uint64_t world_triangles() const {
        uint64_t n = num_triangles();
        for (uint32_t p = 0; p < prototypes.size(); ++p) n -= prototype_triangles(p);
        return n;
    }
    /// For each mesh, the prototype holding it, or -1 for a world-space mesh.
    std::vector<int32_t> mesh_prototypes() const {
        std::vector<int32_t> r(meshes.size(), -1);
        for (uint32_t p = 0; p < prototypes.size(); ++p)
            for (uint32_t i = 0; i < prototypes[p].num_meshes; ++i) r[prototypes[p].first_mesh + i] = int32_t(p);
        return r;
    }
    Bounds3f bounds() const {
        Bounds3f b;
        const std::vector<int32_t> owner = mesh_prototypes();
        std::vector<Bounds3f> proto(prototypes.size());
        for (size_t mi = 0; mi < meshes.size(); ++mi) {
            const Mesh& m = meshes[mi];
            Bounds3f& into = owner[mi] < 0 ? b : proto[size_t(owner[mi])];
            for (uint32_t i = 0; i < m.num_vertices(); ++i) into.extend(m.positions[i]);
        }
        for (const Instance& i : instances) b.extend(i.object_to_world.bounds(proto[i.prototype]));
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

/// Replaces every instance by world-space copies of its prototype's meshes and drops the
/// prototypes: the scene a loader without instancing would have made
/// (`pathtracer --instancing=flatten`, and the reference instanced renders are checked
/// against). Positions go through the transform, shading normals through the inverse
/// transpose (renormalised). A transform that mirrors (det L < 0) reverses the copy's
/// winding, so its front face stays the prototype's (glTF 2.0, 3.7.4: the determinant
/// of the global transform sets the winding; pbrt-v4 flips a triangle's normal when its
/// transform swaps handedness); the renderer flips an instanced hit's normal likewise.
/// Throws SceneError when the copies would hold more than `max_elements` vertex and
/// index elements (the loaders' bound on a flat scene), before allocating them.
inline void flatten_instances(Scene& scene, uint64_t max_elements = uint64_t(1) << 28) {
    if (scene.prototypes.empty() && scene.instances.empty()) return;
    {
        uint64_t elements = 0;
        std::vector<uint64_t> per(scene.prototypes.size(), 0);
        for (size_t p = 0; p < scene.prototypes.size(); ++p)
            for (uint32_t k = 0; k < scene.prototypes[p].num_meshes; ++k) {
                const Mesh& m = scene.meshes[scene.prototypes[p].first_mesh + k];
                per[p] += m.positions.size() + m.indices.size() + m.normals.size() + m.uvs.size() +
                          m.colors.size() + m.alphas.size();
            }
        for (const Mesh& m : scene.meshes) elements += m.positions.size() + m.indices.size();
        for (const Instance& i : scene.instances) elements += per[i.prototype];
        if (elements > max_elements)
            throw SceneError(scene.source + ": flattening " + std::to_string(scene.instances.size()) +
                             " instances makes " + std::to_string(elements) + " vertex/index elements, more than " +
                             std::to_string(max_elements) + " (trace them as instances)");
    }
    const std::vector<int32_t> owner = scene.mesh_prototypes();
    std::vector<Mesh> out;
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi)
        if (owner[mi] < 0) out.push_back(std::move(scene.meshes[mi]));
    for (const Instance& inst : scene.instances) {
        const Prototype& p = scene.prototypes[inst.prototype];
        const Affine3f& m = inst.object_to_world;
        const Affine3f n = m.inverse();  // normals: transpose_vector of the inverse
        for (uint32_t k = 0; k < p.num_meshes; ++k) {
            const Mesh& src = scene.meshes[p.first_mesh + k];
            Mesh c;
            c.name = src.name;
            c.material = src.material;
            c.indices = src.indices;
            if (m.det() < 0.0)
                for (size_t t = 0; t + 2 < c.indices.size(); t += 3) std::swap(c.indices[t + 1], c.indices[t + 2]);
            c.uvs = src.uvs;
            c.colors = src.colors;
            c.alphas = src.alphas;
            c.positions.reserve(src.positions.size());
            for (uint32_t v = 0; v < src.num_vertices(); ++v) c.positions.push_back(m.point(src.positions[v]));
            c.pad_positions();
            c.normals.reserve(src.normals.size());
            for (const Vec3f& nv : src.normals) {
                const Vec3f w = n.transpose_vector(nv);
                const float len = accel::length(w);
                c.normals.push_back(len > 0.0f ? w / len : nv);
            }
            out.push_back(std::move(c));
        }
    }
    scene.meshes = std::move(out);
    scene.prototypes.clear();
    scene.instances.clear();
    scene.instances.shrink_to_fit();
}


}  // namespace scenes
