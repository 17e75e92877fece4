// pathtracer [options] SCENE: the course's command line, on any of our backends.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "accel/accelerator.h"
#include "accel/bvh/bvh.h"
#include "renderer/camera.h"
#include "renderer/image.h"
#include "renderer/integrator.h"
#include "renderer/lights.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "scenes/load.h"
#include "tools/cli.h"

namespace {

std::atomic<bool> g_cancel{false};
extern "C" void on_sigint(int) { g_cancel.store(true); }

[[noreturn]] void fail(const std::string& message) { tools::fail("pathtracer", message); }

std::string default_output(const std::string& scene) {
    return std::filesystem::path(scene).stem().string() + ".png";
}

/// "foo.png" -> "foo_rate.png" (the course's name for the sample-rate image).
std::string sibling(const std::string& path, const std::string& suffix, const std::string& ext) {
    std::filesystem::path p(path);
    return (p.parent_path() / (p.stem().string() + suffix + ext)).string();
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Physically based path tracer for diffuse and emissive scenes (CS184 dialect "
                 "COLLADA, glTF 2.0), on our own BVH or on Embree."};
    app.set_help_flag("-h,--help", "Print this help and exit");

    std::string scene_path;
    renderer::RenderSettings rs;
    renderer::IntegratorSettings is;
    accel::AccelOptions ao;
    std::string backend = "custom", bvh = "sah", tri = "fast", quality = "high", camera_mode = "auto", isa = "auto";
    std::string output;
    std::vector<int> resolution, cell;
    std::vector<float> adaptive;
    int accumulate = 1;
    std::vector<float> cam_pos, cam_target, cam_up;
    float fov = 0;
    bool quiet = false, cost = false;
    std::string ocio_config;

    app.add_option("scene", scene_path, "Scene file (.dae, .gltf, .glb)")->required();
    app.add_option("-s", rs.spp, "Samples per pixel (the cap under -a)")->check(CLI::Range(1, 1 << 20));
    app.add_option("-l", is.light_samples, "Samples per area light")->check(CLI::Range(1, 1 << 16));
    app.add_option("-t", rs.threads, "Render threads (default: all cores)")->check(CLI::Range(1, 1024));
    app.add_option("-m", is.max_depth, "Maximum ray depth (0 = emission only, 1 = direct only)")
        ->check(CLI::Range(0, 100000));
    app.add_option("-o", accumulate, "1: accumulate all bounces (default); 0: only light of exactly -m bounces")
        ->check(CLI::IsMember({0, 1}));
    app.add_option("-a", adaptive, "Adaptive sampling: BATCH TOL (stop a pixel when 1.96*sigma/sqrt(n) <= TOL*mean)")
        ->expected(2);
    app.add_flag("-H", is.hemisphere, "Direct lighting by uniform hemisphere sampling instead of light sampling");
    app.add_option("-f", output, "Output image (.png, .jpg, .exr; default: SCENE-NAME.png)");
    app.add_option("-r", resolution, "Image size W H (default 800 600)")->expected(2);
    app.add_option("-p", cell, "Render only the cell X Y DX DY (pixels, from the top left)")->expected(4);
    app.add_option("--integrator", is.name, "normals | direct | path")
        ->check(CLI::IsMember({"normals", "direct", "path"}));
    app.add_option("--accel", backend, "naive | custom | embree")
        ->check(CLI::IsMember({"naive", "custom", "embree"}));
    app.add_option("--bvh", bvh, "Custom BVH split: midpoint | sah")->check(CLI::IsMember({"midpoint", "sah"}));
    app.add_option("--leaf-size", ao.leaf_size, "Custom BVH: maximum primitives per leaf")->check(CLI::Range(1, 255));
    app.add_option("--triangle", tri, "Triangle test: fast (Moller-Trumbore) | watertight (Woop 2013)")
        ->check(CLI::IsMember({"fast", "watertight"}));
    app.add_option("--embree-quality", quality, "Embree build quality: low | medium | high")
        ->check(CLI::IsMember({"low", "medium", "high"}));
    app.add_option("--isa", isa, "Custom BVH kernel: auto (by CPUID) | sse2 | avx2 | avx512")
        ->check(CLI::IsMember({"auto", "sse2", "avx2", "avx512"}));
    app.add_flag("--embree-robust", ao.embree_robust, "Embree robust traversal mode");
    app.add_flag("--embree-count", ao.embree_count,
                 "Embree counting mode: triangles through our intersector, so tests per ray are counted");
    app.add_option("--camera", camera_mode, "auto | course | file (auto: course for .dae, file for glTF)")
        ->check(CLI::IsMember({"auto", "course", "file"}));
    app.add_option("--cam-pos", cam_pos, "Camera position X Y Z")->expected(3);
    app.add_option("--cam-target", cam_target, "Camera target X Y Z")->expected(3);
    app.add_option("--cam-up", cam_up, "Camera up X Y Z")->expected(3);
    app.add_option("--fov", fov, "Horizontal field of view, degrees")->check(CLI::Range(0.01f, 179.0f));
    app.add_option("--seed", rs.seed, "Random seed (images are identical for any -t)");
    app.add_option("--rr", is.rr_continue, "Russian roulette continuation probability")
        ->check(CLI::Range(0.01f, 1.0f));
    std::string offset = "error-bound";
    app.add_option("--offset", offset,
                   "How secondary rays leave surfaces: error-bound (default; offset by the hit "
                   "point's floating-point error bound, pbrt-v4 6.8, robust at any scene scale) | "
                   "epsilon (plain scale-relative epsilon, for comparison)")
        ->check(CLI::IsMember({"error-bound", "epsilon"}));
    app.add_option("--only", is.only, "direct | indirect: keep one part of the light")
        ->check(CLI::IsMember({"direct", "indirect"}));
    app.add_option("--ocio-config", ocio_config, "OpenColorIO config for PNG/JPEG output (default: ours)")
        ->check(CLI::ExistingFile);
    app.add_flag("--cost", cost,
                 "Also write heat maps of BVH nodes visited and primitive tests per pixel "
                 "(NAME_nodes.png, NAME_tests.png), from the backend that did the work");
    app.add_flag("-q,--quiet", quiet, "No progress lines");

    tools::parse_or_exit(app, argc, argv, "pathtracer");

    if (!resolution.empty()) {
        if (resolution[0] < 1 || resolution[1] < 1 || resolution[0] > 65536 || resolution[1] > 65536)
            fail(fmt::format("-r {} {}: width and height must be between 1 and 65536", resolution[0],
                             resolution[1]));
        rs.width = resolution[0];
        rs.height = resolution[1];
    }
    if (!cell.empty()) {
        if (cell[0] < 0 || cell[1] < 0 || cell[2] < 1 || cell[3] < 1 || cell[0] >= rs.width ||
            cell[1] >= rs.height)
            fail(fmt::format("-p {} {} {} {}: the cell must start inside the {}x{} image and be at "
                             "least 1x1", cell[0], cell[1], cell[2], cell[3], rs.width, rs.height));
        rs.cell = renderer::Cell{cell[0], cell[1], cell[2], cell[3]};
    }
    if (!adaptive.empty()) {
        if (adaptive[0] < 1 || adaptive[0] != std::floor(adaptive[0]) || !(adaptive[1] > 0))
            fail(fmt::format("-a {} {}: BATCH must be a whole number >= 1 and TOL > 0", adaptive[0],
                             adaptive[1]));
        rs.adaptive_batch = int(adaptive[0]);
        rs.adaptive_tol = adaptive[1];
    }
    is.accumulate = accumulate == 1;
    is.offset = offset == "epsilon" ? renderer::OffsetMode::Epsilon : renderer::OffsetMode::ErrorBound;
    ao.split = bvh == "midpoint" ? accel::BvhSplit::Midpoint : accel::BvhSplit::Sah;
    ao.triangle = tri == "watertight" ? accel::TriangleTest::Watertight : accel::TriangleTest::Fast;
    accel::parse_isa(isa, ao.isa);
    ao.embree_quality = quality == "low"      ? accel::EmbreeQuality::Low
                        : quality == "medium" ? accel::EmbreeQuality::Medium
                                              : accel::EmbreeQuality::High;
    if (output.empty()) output = default_output(scene_path);
    rs.progress = !quiet;
    rs.cancel = &g_cancel;

    const int threads = rs.threads > 0 ? rs.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    std::fprintf(stderr, "[PathTracer] Input scene file: %s\n", scene_path.c_str());
    std::fprintf(stderr, "[PathTracer] Rendering using %d threads\n", threads);

    // Load.
    std::fprintf(stderr, "[PathTracer] Collecting primitives... ");
    std::fflush(stderr);
    auto t0 = std::chrono::steady_clock::now();
    scenes::Scene scene;
    try {
        scene = scenes::load_scene(scene_path);
    } catch (const scenes::SceneError& e) {
        std::fprintf(stderr, "\n");
        fail(e.what());
    }
    std::fprintf(stderr, "Done! (%.4f sec)\n",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::fputs(scenes::scene_summary(scene).c_str(), stderr);
    for (const std::string& note : scene.notes) std::fprintf(stderr, "[PathTracer] Note: %s\n", note.c_str());
    if (scene.num_triangles() == 0 && scene.spheres.empty())
        fail(fmt::format("{}: the scene has no geometry to render", scene_path));

    // Camera.
    renderer::CameraOverrides ov;
    if (!cam_pos.empty()) ov.position = accel::Vec3f(cam_pos[0], cam_pos[1], cam_pos[2]);
    if (!cam_target.empty()) ov.target = accel::Vec3f(cam_target[0], cam_target[1], cam_target[2]);
    if (!cam_up.empty()) ov.up = accel::Vec3f(cam_up[0], cam_up[1], cam_up[2]);
    if (fov > 0) ov.hfov_deg = fov;
    const renderer::CameraMode mode = camera_mode == "course" ? renderer::CameraMode::Course
                                      : camera_mode == "file" ? renderer::CameraMode::File
                                                              : renderer::CameraMode::Auto;
    const renderer::CameraSetup cam = renderer::make_camera(scene, mode, rs.width, rs.height, ov);
    std::fprintf(stderr, "%s\n", cam.description.c_str());

    // Accelerator and integrator.
    renderer::SceneGeometry geometry(scene);
    std::unique_ptr<renderer::LightSet> lights;
    if (is.name != "normals") {
        std::vector<std::string> notes;
        lights = std::make_unique<renderer::LightSet>(scene, notes);
        std::fprintf(stderr, "%s\n", lights->summary().c_str());
        for (const std::string& note : notes) std::fprintf(stderr, "[PathTracer] Note: %s\n", note.c_str());
    }
    std::unique_ptr<accel::Accelerator> accel;
    std::unique_ptr<renderer::Integrator> integrator;
    try {
        integrator = renderer::make_integrator(is, scene, geometry, lights.get());
        accel = renderer::build_accelerator(backend, geometry, ao);
    } catch (const accel::AccelError& e) {
        fail(e.what());
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }

    std::signal(SIGINT, on_sigint);
    renderer::RenderResult result = renderer::render(cam.camera, *integrator, *accel, rs);
    std::signal(SIGINT, SIG_DFL);

    // Statistics go to stdout, as results.
    const accel::BuildInfo& info = accel->info();
    std::printf("[PathTracer] BVH traced %llu rays.\n", (unsigned long long)result.stats.total_rays());
    if (info.counts_prims)
        std::printf("[PathTracer] Averaged %.6f intersection tests per ray.\n", result.stats.tests_per_ray());
    else
        std::printf("[PathTracer] Averaged intersection tests per ray: not counted by %s "
                    "(use --embree-count)\n", info.backend.c_str());
    if (info.counts_nodes)
        std::printf("[PathTracer] Averaged %.6f BVH nodes visited per ray.\n", result.stats.nodes_per_ray());
    std::printf("[PathTracer] Render time %.4f s, %.3f Mrays/s, %llu camera samples\n", result.seconds,
                double(result.stats.total_rays()) / std::max(result.seconds, 1e-9) / 1e6,
                (unsigned long long)result.samples);
    if (result.nan_samples)
        std::printf("[PathTracer] Dropped %llu NaN/Inf samples (counted in the EXR 'nan' channel)\n",
                    (unsigned long long)result.nan_samples);

    renderer::WriteOptions wo;
    wo.encoding = integrator->display_referred() ? renderer::Encoding::Display : renderer::Encoding::SceneLinear;
    wo.ocio_config = ocio_config;
    if (result.partial) wo.attributes.push_back({"pathtracer:partial", "1"});
    std::fprintf(stderr, "[PathTracer] Saving to file: %s... ", output.c_str());
    try {
        renderer::write_image(output, result.image, wo);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "\n");
        fail(e.what());
    }
    std::fprintf(stderr, "Done!\n");
    std::printf("Wrote %s%s\n", output.c_str(), result.partial ? " (partial: interrupted)" : "");

    // Side images: the sample-rate heat map (course name NAME_rate.png) and the cost maps.
    auto channel = [&](int c) {
        std::vector<float> v(size_t(rs.width) * rs.height);
        for (size_t i = 0; i < v.size(); ++i) v[i] = result.image.pixels[i * result.image.nchannels() + c];
        return v;
    };
    auto write_heat = [&](int c, const std::string& suffix) {
        std::vector<float> v = channel(c);
        const float hi = *std::max_element(v.begin(), v.end());
        const std::string path = sibling(output, suffix, ".png");
        renderer::WriteOptions ho;
        ho.encoding = renderer::Encoding::Display;
        try {
            renderer::write_image(path, renderer::heat_map(v, rs.width, rs.height, 0.0f, hi), ho);
        } catch (const std::exception& e) {
            fail(e.what());
        }
        std::printf("Wrote %s (blue 0 .. red %g)\n", path.c_str(), double(hi));
    };
    if (rs.adaptive_batch > 0) {
        write_heat(renderer::kSamples, "_rate");
        std::vector<float> v = channel(renderer::kSamples);
        double total = 0;
        for (float x : v) total += x;
        std::printf("[PathTracer] Adaptive sampling: %.2f samples per pixel on average (cap %d)\n",
                    total / double(v.size()), rs.spp);
    }
    if (cost) {
        write_heat(renderer::kCostNodes, "_nodes");
        write_heat(renderer::kCostTests, "_tests");
    }
    return result.partial ? 130 : 0;
}
