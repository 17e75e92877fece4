#include "scenes/load.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>

#include "scenes/collada/collada.h"
#include "scenes/gltf/gltf.h"

namespace scenes {

namespace {
std::string lower_extension(const std::string& path) {
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

template <typename T>
uint64_t bytes_of(const std::vector<T>& v) {
    return uint64_t(v.capacity()) * sizeof(T);
}
}  // namespace

Scene load_scene(const std::string& path) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
        throw SceneError(fmt::format("{}: no such file", path));
    if (std::filesystem::is_directory(path, ec))
        throw SceneError(fmt::format("{}: is a directory, not a scene file", path));
    if (!std::ifstream(path, std::ios::binary))
        throw SceneError(fmt::format("{}: cannot be opened for reading", path));
    const std::string ext = lower_extension(path);
    if (ext == ".dae") return load_collada(path);
    if (ext == ".gltf" || ext == ".glb") return load_gltf(path);
    throw SceneError(fmt::format("{}: unknown scene format '{}' (expected .dae, .gltf or .glb)",
                                 path, ext));
}

uint64_t scene_bytes(const Scene& s) {
    uint64_t b = sizeof(Scene);
    for (const Mesh& m : s.meshes)
        b += sizeof(Mesh) + bytes_of(m.positions) + bytes_of(m.indices) + bytes_of(m.normals) +
             bytes_of(m.uvs) + bytes_of(m.colors) + bytes_of(m.alphas);
    b += bytes_of(s.spheres) + bytes_of(s.materials) + bytes_of(s.lights) + bytes_of(s.instances) +
         bytes_of(s.prototypes);
    for (const Texture& t : s.textures) b += sizeof(Texture) + bytes_of(t.data) + bytes_of(t.levels);
    return b;
}

std::string scene_summary(const Scene& s) {
    size_t by_kind[5] = {0, 0, 0, 0, 0};
    for (const Light& l : s.lights) ++by_kind[size_t(l.type)];
    size_t emissive_meshes = 0, with_normals = 0, with_uvs = 0, with_colors = 0;
    for (const Mesh& m : s.meshes) {
        if (m.material < s.materials.size() && s.materials[m.material].is_emissive())
            ++emissive_meshes;
        with_normals += !m.normals.empty();
        with_uvs += !m.uvs.empty();
        with_colors += !m.colors.empty() || !m.alphas.empty();
    }
    size_t emissive_spheres = 0;
    for (const Sphere& sp : s.spheres)
        if (sp.material < s.materials.size() && s.materials[sp.material].is_emissive())
            ++emissive_spheres;
    std::string out = fmt::format(
        "[PathTracer] Scene: {} meshes, {} triangles, {} spheres\n"
        "[PathTracer]   lights: {} area, {} point, {} directional, {} spot, {} environment; "
        "{} emissive meshes, {} emissive spheres\n"
        "[PathTracer]   {} materials, {} textures; {} meshes with normals, {} with uvs{}\n"
        "[PathTracer]   memory: {:.2f} MiB\n",
        s.meshes.size(), s.num_triangles(), s.spheres.size(), by_kind[0], by_kind[1],
        by_kind[2], by_kind[3], by_kind[4], emissive_meshes, emissive_spheres,
        s.materials.size(), s.textures.size(), with_normals, with_uvs,
        with_colors ? fmt::format(", {} with vertex colours", with_colors) : std::string(),
        double(scene_bytes(s)) / (1024.0 * 1024.0));
    for (const Material& m : s.materials)
        if (!m.replaced.empty())
            out += fmt::format("[PathTracer]   material '{}': {} rendered as diffuse\n", m.name,
                               m.replaced);
    return out;
}

}  // namespace scenes
