// scene_memory: what each scene costs in memory after loading, per triangle, so that
// "model only what a scene requires" is measured (normals, uvs and textures are stored
// only when the scene's materials use them).
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

#include "scenes/load.h"
#include "tools/cli.h"

int main(int argc, char** argv) {
    CLI::App app{"Scene memory per triangle after loading."};
    std::vector<std::string> paths;
    bool quick = false;
    app.add_option("scenes", paths, "Scene files (default: our scenes and the shared corpus)");
    app.add_flag("--quick", quick, "Smoke run: the project's own scenes only");
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
    std::printf("%-28s %10s %8s %8s %6s %5s %12s %12s %10s\n", "scene", "triangles", "normals", "uvs",
                "tex", "mats", "bytes", "bytes/tri", "load ms");
    for (const std::string& p : paths) {
        const auto t0 = std::chrono::steady_clock::now();
        const scenes::Scene s = tools::load_scene_or_exit(p, "scene_memory");
        const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        size_t with_n = 0, with_uv = 0;
        for (const auto& m : s.meshes) {
            with_n += !m.normals.empty();
            with_uv += !m.uvs.empty();
        }
        const uint64_t bytes = scenes::scene_bytes(s), tris = s.num_triangles();
        std::printf("%-28s %10llu %8zu %8zu %6zu %5zu %12llu %12.1f %10.1f\n",
                    fs::path(p).filename().string().c_str(), (unsigned long long)tris, with_n, with_uv,
                    s.textures.size(), s.materials.size(), (unsigned long long)bytes,
                    tris ? double(bytes) / double(tris) : 0.0, ms);
    }
    return 0;
}
