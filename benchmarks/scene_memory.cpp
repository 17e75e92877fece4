// scene_memory: what each scene costs in memory after loading, per triangle, so that
// "model only what a scene requires" is measured (normals, uvs and textures are stored
// only when the scene's materials use them), and how much of it is texture.
//
// A twelve-texture helmet is made at run time from the shared DamagedHelmet: its mesh
// split into three parts, each with its own material and its own copy of the four
// images (the copies are new image entries over the same bytes in the file, which the
// loader decodes separately), written as a .glb in a temporary folder. It stands in for
// production models whose parts each carry a texture set.
#include <CLI/CLI.hpp>
#include <tiny_gltf.h>
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include <unistd.h>

#include "scenes/load.h"
#include "tools/cli.h"

namespace {

/// Writes `out` (.glb): the model in `helmet` with its first mesh's first primitive cut
/// into `parts` primitives, each with its own copy of every material, texture and image.
/// Returns false with `why` on failure.
bool write_split_helmet(const std::string& helmet, const std::string& out, int parts, std::string& why) {
    tinygltf::Model m;
    tinygltf::TinyGLTF io;
    // The images are copied as references to their bytes, never decoded here.
    io.SetImageLoader([](tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*,
                         int, void*) { return true; },
                      nullptr);
    std::string warn;
    if (!io.LoadBinaryFromFile(&m, &why, &warn, helmet)) return false;
    if (m.meshes.empty() || m.meshes[0].primitives.empty() || m.materials.empty()) {
        why = "no mesh or material to split";
        return false;
    }
    const size_t images = m.images.size(), textures = m.textures.size(), materials = m.materials.size();
    for (int k = 1; k < parts; ++k) {
        for (size_t i = 0; i < images; ++i) m.images.push_back(m.images[i]);
        for (size_t i = 0; i < textures; ++i) {
            tinygltf::Texture t = m.textures[i];
            if (t.source >= 0) t.source += int(k * images);
            m.textures.push_back(t);
        }
        for (size_t i = 0; i < materials; ++i) {
            tinygltf::Material mat = m.materials[i];
            const int off = int(k * textures);
            for (int* idx : {&mat.pbrMetallicRoughness.baseColorTexture.index,
                             &mat.pbrMetallicRoughness.metallicRoughnessTexture.index, &mat.normalTexture.index,
                             &mat.occlusionTexture.index, &mat.emissiveTexture.index})
                if (*idx >= 0) *idx += off;
            m.materials.push_back(mat);
        }
    }
    tinygltf::Primitive& prim = m.meshes[0].primitives[0];
    if (prim.indices < 0) {
        why = "the primitive has no indices";
        return false;
    }
    const tinygltf::Accessor whole = m.accessors[size_t(prim.indices)];
    const size_t tris = whole.count / 3, elem = size_t(tinygltf::GetComponentSizeInBytes(whole.componentType));
    std::vector<tinygltf::Primitive> split;
    for (int k = 0; k < parts; ++k) {
        const size_t first = tris * size_t(k) / size_t(parts), last = tris * size_t(k + 1) / size_t(parts);
        tinygltf::Accessor a = whole;
        a.byteOffset = whole.byteOffset + first * 3 * elem;
        a.count = (last - first) * 3;
        a.minValues.clear();
        a.maxValues.clear();
        m.accessors.push_back(a);
        tinygltf::Primitive p = prim;
        p.indices = int(m.accessors.size() - 1);
        p.material = prim.material + int(size_t(k) * materials);
        split.push_back(p);
    }
    m.meshes[0].primitives = split;
    if (!io.WriteGltfSceneToFile(&m, out, false, true, false, true)) {
        why = "cannot write " + out;
        return false;
    }
    return true;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Scene memory per triangle after loading."};
    std::vector<std::string> paths;
    bool quick = false;
    app.add_option("scenes", paths, "Scene files (default: our scenes and the shared corpus)");
    app.add_flag("--quick", quick, "Smoke run: the project's own scenes only");
    std::string keep_helmet;
    app.add_option("--write-helmet12", keep_helmet,
                   "Write the twelve-texture helmet (.glb) here and keep it, to load it with other builds");
    tools::parse_or_exit(app, argc, argv, "scene_memory");
    namespace fs = std::filesystem;
    if (paths.empty()) {
        const fs::path src(PT_SOURCE_DIR_BENCH);
        paths.push_back((src / "scenes/cornell.dae").string());
        paths.push_back((src / "scenes/cornell_emissive.gltf").string());
        const fs::path shared = src / "../shared/scenes";
        if (!quick && fs::exists(shared))
            for (const auto& e : fs::recursive_directory_iterator(shared)) {
                const std::string ext = e.path().extension().string();
                if (ext == ".dae" || ext == ".gltf" || ext == ".glb") paths.push_back(e.path().string());
            }
    }
    const fs::path helmet = fs::path(PT_SOURCE_DIR_BENCH) / "../shared/scenes/gltf/DamagedHelmet.glb";
    fs::path tmp_dir;
    if ((!quick || !keep_helmet.empty()) && fs::exists(helmet)) {
        std::string out = keep_helmet;
        if (out.empty()) {
            tmp_dir = fs::temp_directory_path() / ("scene_memory_" + std::to_string(::getpid()));
            fs::create_directories(tmp_dir);
            out = (tmp_dir / "Helmet12.glb").string();
        }
        std::string why;
        if (write_split_helmet(helmet.string(), out, 3, why))
            paths.push_back(out);
        else
            std::fprintf(stderr, "scene_memory: twelve-texture helmet not made: %s\n", why.c_str());
    }
    std::printf("%-28s %10s %8s %8s %6s %5s %12s %12s %12s %10s\n", "scene", "triangles", "normals", "uvs",
                "tex", "mats", "bytes", "texture MiB", "bytes/tri", "load ms");
    for (const std::string& p : paths) {
        const auto t0 = std::chrono::steady_clock::now();
        const scenes::Scene s = tools::load_scene_or_exit(p, "scene_memory");
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        size_t with_n = 0, with_uv = 0;
        for (const auto& m : s.meshes) {
            with_n += !m.normals.empty();
            with_uv += !m.uvs.empty();
        }
        uint64_t tex_bytes = 0;
        for (const scenes::Texture& t : s.textures) tex_bytes += t.data.size();
        const uint64_t bytes = scenes::scene_bytes(s), tris = s.num_triangles();
        std::printf("%-28s %10llu %8zu %8zu %6zu %5zu %12llu %12.1f %12.1f %10.1f\n",
                    fs::path(p).filename().string().c_str(), (unsigned long long)tris, with_n, with_uv,
                    s.textures.size(), s.materials.size(), (unsigned long long)bytes,
                    double(tex_bytes) / (1024.0 * 1024.0), tris ? double(bytes) / double(tris) : 0.0, ms);
    }
    if (!tmp_dir.empty()) {
        std::error_code ec;
        fs::remove_all(tmp_dir, ec);
    }
    return 0;
}
