// pathtracer [options] SCENE: the course's command line, on any of our backends.
//
// main reads as the program runs: the options CLI11 fills (Options), their checks and
// conversions (finish_options), the scene, camera and accelerator (set-up), the render,
// and the files it writes. Each flag's meaning is in the add_*_options functions, in the
// order --help lists them.
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <malloc.h>
#include <sys/resource.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <thread>

#include "accel/accelerator.h"
#include "accel/bvh/bvh.h"
#include "renderer/camera.h"
#include "renderer/checkpoint.h"
#include "renderer/envmap.h"
#include "renderer/image.h"
#include "renderer/image_module.h"
#include "renderer/integrator.h"
#include "renderer/lights.h"
#include "renderer/ray_record.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "renderer/split_map.h"
#include "scenes/load.h"
#include "tools/cli.h"
#include "tools/distributed/distributed.h"
#include "tools/memory/memory.h"
#include "tools/output_check.h"

namespace {

std::atomic<bool> g_cancel{false};
extern "C" void on_sigint(int) { g_cancel.store(true); }

[[noreturn]] void fail(const std::string& message) { tools::fail("pathtracer", message); }

namespace mem = tools::memory;

/// Every option, as CLI11 fills it; finish_options turns the words into settings.
struct Options {
    std::string scene_path;
    renderer::RenderSettings rs;
    renderer::IntegratorSettings is;
    accel::AccelOptions ao;
    std::string backend = "custom", bvh = "sah", tri = "fast", quality = "high", camera_mode = "auto", isa = "auto";
    std::string nodes = "auto", lights_mode, offset = "error-bound", strategy = "mis", texture_filter = "trilinear";
    std::string output;
    std::string rr = "throughput";  ///< --rr: "throughput" or a probability in (0, 1]
    std::string sampler = renderer::sampler_name(renderer::RenderSettings{}.sampler);
    std::vector<int> resolution, cell;
    std::vector<float> adaptive;
    int accumulate = 1;
    std::vector<float> cam_pos, cam_target, cam_up;
    float fov = 0;
    bool quiet = false, cost = false, strict = false;
    std::string ocio_config;
    std::string env_map, camera_file;
    float lens_radius = -1, focal_distance = -1;
    std::string checkpoint, resume;
    double max_memory_gib = 0;  ///< --max-memory; 0 = this machine's memory
    std::string instancing = "auto";  ///< --instancing: auto | flatten
    std::string record_rays;          ///< --record-rays FILE
    uint64_t record_rays_max = 1000000;
};

/// --accel: the backends built in, and any plugin:PATH[:OPTIONS] (accel::is_backend_name
/// decides, so every tool accepts the same names).
CLI::Validator backend_name() {
    return CLI::Validator(
        [](std::string& name) -> std::string {
            if (accel::is_backend_name(name)) return {};
            return "unknown backend '" + name + "' (naive, custom, embree or plugin:PATH[:OPTIONS])";
        },
        "");
}

/// The scene and the course's flags (CS184 3-1 and 3-2), lens and output.
void add_course_options(CLI::App& app, Options& o) {
    app.add_option("scene", o.scene_path,
                   "Scene file: .dae (CS184 COLLADA, CGL or CMU462 profile), .gltf or .glb (glTF 2.0 with "
                   "KHR_draco_mesh_compression, KHR_mesh_quantization, KHR_texture_transform, "
                   "KHR_lights_punctual, KHR_materials_emissive_strength, KHR_materials_transmission, "
                   "KHR_materials_ior, KHR_materials_unlit)")
        ->required();
    app.add_option("-s", o.rs.spp, "Samples per pixel (the cap under -a)")->check(CLI::Range(1, 1 << 20));
    app.add_option("-l", o.is.light_samples, "Samples per area light")->check(CLI::Range(1, 1 << 16));
    app.add_option("-t", o.rs.threads, "Render threads (default: all cores)")->check(CLI::Range(1, 1024));
    app.add_option("-m", o.is.max_depth, "Maximum ray depth (0 = emission only, 1 = direct only)")
        ->check(CLI::Range(0, 100000));
    app.add_option("-o", o.accumulate, "1: accumulate all bounces (default); 0: only light of exactly -m bounces")
        ->check(CLI::IsMember({0, 1}));
    app.add_option("-a", o.adaptive, "Adaptive sampling: BATCH TOL (stop a pixel when 1.96*sigma/sqrt(n) <= TOL*mean)")
        ->expected(2);
    app.add_flag("-H", o.is.hemisphere, "Direct lighting by uniform hemisphere sampling instead of light sampling "
                                        "(under --lights=course it converges to a slightly different image than "
                                        "light sampling, as in the course; under either, point, spot and "
                                        "directional lights, which no hemisphere ray finds, light nothing)");
    app.add_option("-e", o.env_map, "Environment map: latitude-longitude EXR/HDR, importance-sampled");
    app.add_option("-b", o.lens_radius, "Thin lens radius (0 = pinhole)")->check(CLI::Range(0.0f, 1e30f));
    app.add_option("-d", o.focal_distance, "Focal distance of the thin lens (default: to the scene centre)")
        ->check(CLI::PositiveNumber);
    app.add_option("--strategy", o.strategy, "Direct light: mis (light and BSDF samples by the power heuristic; at diffuse surfaces only under --lights=mesh) | light | bsdf (at non-diffuse surfaces; diffuse ones sample lights; bsdf is mis under --lights=course, where bounces do not see emitters)")
        ->check(CLI::IsMember({"mis", "light", "bsdf"}));
    app.add_option("--texture-filter", o.texture_filter, "Texture lookups: trilinear (the two MIP levels around each hit's pixel footprint, from ray differentials, blended; default) | stochastic (one of the two, at random with the blend's weight: faster, a little noisier) | bilinear (full-resolution image) | nearest (nearest texel of the full-resolution image)")
        ->check(CLI::IsMember({"nearest", "bilinear", "trilinear", "stochastic"}));
    app.add_option("-c", o.camera_file, "Camera settings file of the course application (overrides the scene's camera)");
    app.add_option("-f", o.output, "Output image (.png, .jpg, .exr; default: SCENE-NAME.png)");
    app.add_option("-r", o.resolution, "Image size W H (default 800 600)")->expected(2);
    app.add_option("-p", o.cell, "Render only the cell X Y DX DY (pixels, from the top left)")->expected(4);
}

/// The integrator and the acceleration structure.
void add_accel_options(CLI::App& app, Options& o) {
    app.add_option("--integrator", o.is.name, "normals | direct | path")
        ->check(CLI::IsMember({"normals", "direct", "path"}));
    app.add_option("--accel", o.backend, "naive | custom | embree | plugin:PATH[:OPTIONS]")->check(backend_name());
    app.add_option("--bvh", o.bvh, "Custom BVH split: midpoint | sah | sbvh (SAH + spatial splits)")
        ->check(CLI::IsMember({"midpoint", "sah", "sbvh"}));
    app.add_option("--leaf-size", o.ao.leaf_size, "Custom BVH: maximum primitives per leaf (default 8; 16 with --bvh=sbvh, 4 with midpoint)")
        ->check(CLI::Range(1, 255));
    app.add_option("--triangle", o.tri, "Triangle test: fast (Moller-Trumbore) | watertight (Woop 2013)")
        ->check(CLI::IsMember({"fast", "watertight"}));
    app.add_option("--embree-quality", o.quality, "Embree build quality: low | medium | high")
        ->check(CLI::IsMember({"low", "medium", "high"}));
    app.add_option("--isa", o.isa, "Custom BVH kernel: auto (by CPUID) | sse2 | avx2 | avx512")
        ->check(CLI::IsMember({"auto", "sse2", "avx2", "avx512"}));
    app.add_option("--nodes", o.nodes, "Custom BVH node layout: auto (quantized from 4M primitives) | float | quantized (Ylitie 2017)")
        ->check(CLI::IsMember({"auto", "float", "quantized"}));
    app.add_flag("--embree-robust", o.ao.embree_robust, "Embree robust traversal mode");
    app.add_flag("--embree-count", o.ao.embree_count,
                 "Embree counting mode: triangles through our intersector, so tests per ray are counted");
    app.add_option("--record-rays", o.record_rays,
                   "Write the rays the render traces to FILE (closest-hit and any-hit, in the order traced; "
                   "the same file every run with -t 1), for accel_bench and xcheck --ray-record");
    app.add_option("--record-rays-max", o.record_rays_max,
                   "Rays of each kind --record-rays keeps, the first traced (default 1000000; 32 bytes each)")
        ->check(CLI::Range(uint64_t(1), uint64_t(1) << 32));
}

/// Camera, light semantics, sampling details and what is written besides the image.
void add_scene_options(CLI::App& app, Options& o) {
    app.add_option("--camera", o.camera_mode, "auto | course | file (auto: course for .dae, file for glTF)")
        ->check(CLI::IsMember({"auto", "course", "file"}));
    app.add_option("--lights", o.lights_mode,
                   "Which surfaces are lights. course (default for .dae): the course exactly: -l samples "
                   "only the file's library_lights (CGL area lights: front side only); emissive meshes "
                   "are seen, from both sides, by camera rays and -H rays only (black to bounce rays), "
                   "so -H and -l converge to slightly different images, as in the course. mesh (always "
                   "for glTF): every emissive surface is the light, sampled (by solid angle where near, "
                   "else by area) and seen by every "
                   "ray, two-sided for .dae (glTF: the material's doubleSided); an area light describing "
                   "the same panel is counted once; -H and -l converge to the same image where every light is "
                   "a surface (-H finds no point, spot or directional light)")
        ->check(CLI::IsMember({"course", "mesh"}));
    app.add_option("--instancing", o.instancing,
                   "Scenes that place a mesh more than once: auto (default; each placement is an "
                   "instance the backend traces through its transform, so the triangles are stored "
                   "once; a plugin backend, which traces no instances, flattens, with a note) | "
                   "flatten (every placement becomes a world-space copy after loading, as before "
                   "instancing: more memory, the same image up to rounding)")
        ->check(CLI::IsMember({"auto", "flatten"}));
    app.add_option("--cam-pos", o.cam_pos, "Camera position X Y Z")->expected(3);
    app.add_option("--cam-target", o.cam_target, "Camera target X Y Z")->expected(3);
    app.add_option("--cam-up", o.cam_up, "Camera up X Y Z")->expected(3);
    app.add_option("--fov", o.fov, "Horizontal field of view, degrees")->check(CLI::Range(0.01f, 179.0f));
    app.add_option("--seed", o.rs.seed, "Random seed (images are identical for any -t)");
    app.add_option("--rr", o.rr,
                   "Russian roulette from the second bounce: throughput (default; a path survives "
                   "with probability equal to its throughput, pbrt-v4's rule) | sqrt (with the "
                   "square root of its throughput, Cycles' rule: longer dim paths) | P, a fixed "
                   "continuation probability with 0 < P <= 1 (the CS184 course's roulette, which "
                   "uses 0.65; 1 = no roulette)")
        ->type_name("throughput|sqrt|P");
    app.add_option("--split", o.is.split,
                   "Bounce rays per camera hit (default 4): its direct light is sampled once "
                   "and its bounce K times, each branch a path of its own; 1 = one path per "
                   "camera sample, as in the course")
        ->check(CLI::Range(1, 64));
    app.add_option_function<std::string>(
           "--split-by",
           [&o](const std::string& v) { o.is.split_by_noise = v == "noise"; },
           "How --split is shared out: noise (default; from 8 spp on, each pixel's first "
           "spp/8 samples (4 to 8) split --split ways, and the rest a power of two of ways "
           "in proportion to the relative noise those showed around the pixel, --split on "
           "average) | uniform (--split ways everywhere)")
        ->type_name("noise|uniform")
        ->check(CLI::IsMember({"noise", "uniform"}));
    app.add_option("--sampler", o.sampler,
                   "Where each sample's random numbers come from: independent (the per-sample PCG32 "
                   "streams of earlier versions) | stratified (jittered strata per dimension) | "
                   "sobol (default; Owen-scrambled Sobol, Burley 2020) | zsobol (the same along a Morton curve "
                   "over pixels, blue-noise error, Ahmed and Wonka 2020) | pmj02 (progressive "
                   "multi-jittered (0,2), Christensen et al. 2018). Images stay identical for any -t")
        ->check(CLI::IsMember({"independent", "stratified", "sobol", "zsobol", "pmj02"}));
    app.add_option("--offset", o.offset,
                   "How secondary rays leave surfaces: error-bound (default; offset by the hit "
                   "point's floating-point error bound, pbrt-v4 6.8, robust at any scene scale) | "
                   "epsilon (plain scale-relative epsilon, for comparison)")
        ->check(CLI::IsMember({"error-bound", "epsilon"}));
    app.add_option("--only", o.is.only, "direct | indirect: keep one part of the light")
        ->check(CLI::IsMember({"direct", "indirect"}));
    app.add_option("--ocio-config", o.ocio_config, "OpenColorIO config for PNG/JPEG output (default: ours)")
        ->check(CLI::ExistingFile);
    app.add_flag("--cost", o.cost,
                 "Also write heat maps of BVH nodes visited and primitive tests per pixel "
                 "(NAME_nodes.png, NAME_tests.png), from the backend that did the work");
    app.add_flag("-q,--quiet", o.quiet, "No progress lines");
    app.add_flag("--strict", o.strict, "Refuse a scene the loader warns about (e.g. a missing texture file)");
}

/// Long renders: checkpoints, resuming, a time budget, and how the work is cut up.
void add_progress_options(CLI::App& app, Options& o) {
    app.add_option("--checkpoint", o.checkpoint, "Write the accumulated samples to FILE (atomically) "
                   "between passes, at the end and on Ctrl-C");
    app.add_option("--checkpoint-every", o.rs.checkpoint_every, "Seconds between checkpoints (default 60)")
        ->check(CLI::Range(0.0, 1e9));
    app.add_option("--resume", o.resume, "Continue from a checkpoint FILE to -s samples per pixel "
                   "(bit-identical to an uninterrupted render)")->check(CLI::ExistingFile);
    app.add_option("--time-limit", o.rs.time_limit, "Render passes until SECONDS are spent")
        ->check(CLI::Range(0.0, 1e9));
    app.add_option("--tile", o.rs.tile, "Tile size in pixels (default 32), the unit handed to threads and ranks")
        ->check(CLI::Range(1, 4096));
    app.add_option("--pass", o.rs.pass_spp, "Samples per pixel per pass (default: the -a batch, else 8)")
        ->check(CLI::Range(1, 1 << 20));
    app.add_option("--max-memory", o.max_memory_gib,
                   "Refuse (exit status 3), before building the BVH, a render whose estimated peak "
                   "memory exceeds GIB gibibytes (default: this machine's memory and swap)")
        ->type_name("GIB")
        ->check(CLI::PositiveNumber);
}

/// The checks CLI11 cannot make (values that depend on each other), and the words turned
/// into the settings' enums.
void finish_options(Options& o, const dist::World& world) {
    renderer::RenderSettings& rs = o.rs;
    if (world.size > 1 && (!o.checkpoint.empty() || !o.resume.empty() || rs.time_limit > 0))
        fail("--checkpoint, --resume and --time-limit work in a single process, not under mpirun");
    if (world.size > 1 && !o.record_rays.empty()) fail("--record-rays works in a single process, not under mpirun");
    if (!o.resolution.empty()) {
        const std::vector<int>& r = o.resolution;
        if (r[0] < 1 || r[1] < 1 || r[0] > 65536 || r[1] > 65536)
            fail(fmt::format("-r {} {}: width and height must be between 1 and 65536", r[0], r[1]));
        rs.width = r[0];
        rs.height = r[1];
    }
    if (!o.cell.empty()) {
        const std::vector<int>& c = o.cell;
        if (c[0] < 0 || c[1] < 0 || c[2] < 1 || c[3] < 1 || c[0] >= rs.width || c[1] >= rs.height)
            fail(fmt::format("-p {} {} {} {}: the cell must start inside the {}x{} image and be at "
                             "least 1x1", c[0], c[1], c[2], c[3], rs.width, rs.height));
        rs.cell = renderer::Cell{c[0], c[1], c[2], c[3]};
    }
    if (!o.adaptive.empty()) {
        const std::vector<float>& a = o.adaptive;
        if (a[0] < 1 || a[0] != std::floor(a[0]) || !(a[1] > 0))
            fail(fmt::format("-a {} {}: BATCH must be a whole number >= 1 and TOL > 0", a[0], a[1]));
        rs.adaptive_batch = int(a[0]);
        rs.adaptive_tol = a[1];
    }
    if (o.rr == "throughput") {
        o.is.rr_continue = renderer::IntegratorSettings::kThroughputRoulette;
    } else if (o.rr == "sqrt") {
        o.is.rr_continue = renderer::IntegratorSettings::kSqrtThroughputRoulette;
    } else {
        char* end = nullptr;
        const float p = std::strtof(o.rr.c_str(), &end);
        if (o.rr.empty() || *end != '\0' || !(p > 0.0f && p <= 1.0f))
            fail(fmt::format("--rr {}: expected throughput, sqrt or a probability P with 0 < P <= 1", o.rr));
        o.is.rr_continue = p;
    }
    rs.sampler = renderer::parse_sampler(o.sampler);
    o.is.accumulate = o.accumulate == 1;
    o.is.strategy = o.strategy == "light"  ? renderer::IntegratorSettings::Strategy::Light
                    : o.strategy == "bsdf" ? renderer::IntegratorSettings::Strategy::Bsdf
                                           : renderer::IntegratorSettings::Strategy::Mis;
    o.is.offset = o.offset == "epsilon" ? renderer::OffsetMode::Epsilon : renderer::OffsetMode::ErrorBound;
    o.is.texture_filter = renderer::parse_texture_filter(o.texture_filter);
    o.ao.split = o.bvh == "midpoint" ? accel::BvhSplit::Midpoint
                 : o.bvh == "sbvh"   ? accel::BvhSplit::Sbvh
                                     : accel::BvhSplit::Sah;
    o.ao.triangle = o.tri == "watertight" ? accel::TriangleTest::Watertight : accel::TriangleTest::Fast;
    accel::parse_isa(o.isa, o.ao.isa);
    accel::parse_layout(o.nodes, o.ao.nodes);
    o.ao.embree_quality = o.quality == "low"      ? accel::EmbreeQuality::Low
                          : o.quality == "medium" ? accel::EmbreeQuality::Medium
                                                  : accel::EmbreeQuality::High;
    // The course names the image after the scene.
    if (o.output.empty()) o.output = std::filesystem::path(o.scene_path).stem().string() + ".png";
    rs.progress = !o.quiet && world.root();
    rs.cancel = &g_cancel;
}

/// "foo.png" -> "foo_rate.png" (the course's name for the sample-rate image).
std::string sibling(const std::string& path, const std::string& suffix, const std::string& ext) {
    std::filesystem::path p(path);
    return (p.parent_path() / (p.stem().string() + suffix + ext)).string();
}

/// What a checkpoint must match to be resumed: every option's value (new options join
/// automatically) except those that do not change the samples, and the scene file's bytes.
std::string fingerprint(const CLI::App& app, const std::string& scene_path, int spp) {
    static const char* kFree[] = {"s", "t", "f", "q", "quiet", "checkpoint", "checkpoint-every",
                                  "resume", "time-limit", "cost", "scene", "ocio-config", "tile", "pass",
                                  "max-memory", "record-rays", "record-rays-max"};
    std::string out, line;
    std::istringstream lines(app.config_to_str(true, false));
    while (std::getline(lines, line)) {
        const std::string key = line.substr(0, line.find('='));
        if (std::find(std::begin(kFree), std::end(kFree), key) == std::end(kFree)) out += line + ";";
    }
    std::ifstream in(scene_path, std::ios::binary);
    uint64_t h = 1469598103934665603ull;  // FNV-1a of the scene file, read a block at a time
    std::vector<char> block(1 << 20);
    while (in.read(block.data(), std::streamsize(block.size())) || in.gcount() > 0)
        for (std::streamsize i = 0; i < in.gcount(); ++i) h = (h ^ uint8_t(block[size_t(i)])) * 1099511628211ull;
    // Stratified, zsobol and pmj02 lay their samples out for the sample count, so a
    // checkpoint of theirs continues only to the same -s.
    const std::string sampler = app.get_option("--sampler")->as<std::string>();
    if (sampler == "stratified" || sampler == "zsobol" || sampler == "pmj02")
        out += fmt::format("sampler-spp={};", spp);
    // Split by noise sizes its map from the first samples, whose count follows -s.
    if (app.get_option("--split-by")->as<std::string>() != "uniform")
        out += fmt::format("split-first={};", renderer::SplitMap::first_samples(spp));
    return out + fmt::format("scene-fnv1a={:016x};jitter={}", h, spp > 1);
}

/// -e: the environment map joins the scene as one more (importance-sampled) light.
void add_environment(scenes::Scene& scene, const std::string& env_map) {
    try {
        scene.textures.push_back(renderer::load_environment_image(env_map));
    } catch (const scenes::SceneError& e) {
        fail(e.what());
    }
    scenes::Light env;
    env.type = scenes::LightType::Environment;
    env.name = env_map;
    env.texture = uint32_t(scene.textures.size() - 1);
    scene.lights.push_back(env);
    std::fprintf(stderr, "[PathTracer] Environment map %s (%ux%u), importance-sampled\n", env_map.c_str(),
                 scene.textures.back().width, scene.textures.back().height);
}

/// Loads the scene with the course's progress lines; refuses one with nothing to render.
scenes::Scene load_scene(const Options& o) {
    std::fprintf(stderr, "[PathTracer] Collecting primitives... ");
    std::fflush(stderr);
    auto t0 = std::chrono::steady_clock::now();
    scenes::Scene scene;
    {
        const mem::Stage stage("loading the scene", true);
        const uint64_t failures = mem::failures();
        try {
            scene = scenes::load_scene(o.scene_path);
        } catch (const std::bad_alloc& e) {
            mem::out_of_memory(e);
        } catch (const scenes::SceneError& e) {
            // A loader that catches std::bad_alloc reports it as a bad file; it was not.
            if (mem::failures() != failures) mem::out_of_memory();
            std::fprintf(stderr, "\n");
            fail(e.what());
        }
    }
    mem::set_stage("loading the scene");
    std::fprintf(stderr, "Done! (%.4f sec)\n",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    std::fputs(scenes::scene_summary(scene).c_str(), stderr);
    if (!scene.instances.empty() || !scene.prototypes.empty())
        // What the file asked for: the summary's triangles are the unique ones (each
        // mesh once); the instances place more, which a flat scene would copy.
        std::fprintf(stderr,
                     "[PathTracer]   instances: %zu placements of %zu prototypes; %llu unique triangles "
                     "(%llu in world space), %llu instanced triangles\n",
                     scene.instances.size(), scene.prototypes.size(), (unsigned long long)scene.num_triangles(),
                     (unsigned long long)scene.world_triangles(), (unsigned long long)scene.instanced_triangles());
    tools::print_once("[PathTracer] Note: ", scene.notes);
    tools::print_once("[PathTracer] Warning: ", scene.warnings);
    if (o.strict && !scene.warnings.empty()) fail(scene.warnings.front() + " (--strict)");
    if (!scene.instances.empty() || !scene.prototypes.empty()) {
        // --instancing=flatten, or a backend that traces no instances (a plugin): world-space
        // copies of every placement (scenes::flatten_instances), the scene a loader without
        // instancing would have made.
        const bool asked = o.instancing == "flatten";
        if (asked || !accel::backend_traces_instances(o.backend)) {
            const uint64_t placed = scene.instanced_triangles();
            const size_t count = scene.instances.size();
            try {
                scenes::flatten_instances(scene);
            } catch (const std::bad_alloc& e) {
                mem::out_of_memory(e);
            } catch (const scenes::SceneError& e) {
                fail(e.what());
            }
            std::fprintf(stderr, "[PathTracer] Note: %s: %zu instances flattened into world-space copies (%llu triangles)\n",
                         asked ? "--instancing=flatten" : fmt::format("backend {} traces no instances", o.backend).c_str(),
                         count, (unsigned long long)placed);
        }
    }
    if (scene.num_triangles() == 0 && scene.spheres.empty())
        fail(fmt::format("{}: the scene has no geometry to render", o.scene_path));
    if (!o.env_map.empty()) add_environment(scene, o.env_map);
    return scene;
}

/// -c (the course's camera settings file) replaces the camera; -b/-d (or the file's 3-2
/// lens fields) make it a thin lens. -d defaults to the distance to the scene's centre.
void apply_course_camera(renderer::CameraSetup& cam, const std::string& file, float lens_radius,
                         float focal_distance, const scenes::Scene& scene, int width, int height) {
    if (!file.empty()) {
        renderer::CameraSettings c;
        try {
            c = renderer::read_camera_settings(file);
        } catch (const std::invalid_argument& e) {
            fail(e.what());
        }
        const float aspect = float(width) / float(height);
        const float vfov = 2.0f * std::atan(std::tan(0.5f * c.hfov_deg * accel::kPi / 180.0f) / aspect) * 180.0f /
                           accel::kPi;
        cam.camera = renderer::Camera(c.position, c.target, c.up, c.hfov_deg, vfov);
        cam.description = fmt::format("[PathTracer] Camera from settings file {}: hfov {:g}", file, c.hfov_deg);
        if (c.has_lens) {
            if (lens_radius < 0) lens_radius = c.lens_radius;
            if (focal_distance < 0) focal_distance = c.focal_distance;
        }
    }
    if (lens_radius > 0) {
        if (focal_distance < 0) {
            const accel::Bounds3f b = scene.bounds();
            const accel::Vec3f centre = b.empty() ? accel::Vec3f(0.0f) : b.center();
            focal_distance = std::max(1e-4f, accel::dot(centre - cam.camera.position(), cam.camera.forward()));
        }
        cam.camera.set_lens(lens_radius, focal_distance);
        cam.description += fmt::format(", thin lens radius {:g}, focal distance {:g}", lens_radius, focal_distance);
    }
}

/// The scene's camera (--camera), with --cam-*/--fov overrides, then -c and the lens.
renderer::CameraSetup setup_camera(const Options& o, const scenes::Scene& scene) {
    renderer::CameraOverrides ov;
    if (!o.cam_pos.empty()) ov.position = accel::Vec3f(o.cam_pos[0], o.cam_pos[1], o.cam_pos[2]);
    if (!o.cam_target.empty()) ov.target = accel::Vec3f(o.cam_target[0], o.cam_target[1], o.cam_target[2]);
    if (!o.cam_up.empty()) ov.up = accel::Vec3f(o.cam_up[0], o.cam_up[1], o.cam_up[2]);
    if (o.fov > 0) ov.hfov_deg = o.fov;
    const renderer::CameraMode mode = o.camera_mode == "course" ? renderer::CameraMode::Course
                                      : o.camera_mode == "file" ? renderer::CameraMode::File
                                                                : renderer::CameraMode::Auto;
    renderer::CameraSetup cam = renderer::make_camera(scene, mode, o.rs.width, o.rs.height, ov);
    apply_course_camera(cam, o.camera_file, o.lens_radius, o.focal_distance, scene, o.rs.width, o.rs.height);
    std::fprintf(stderr, "%s\n", cam.description.c_str());
    return cam;
}

/// The lights, under --lights' semantics; none for the normals integrator, which has no use
/// for them.
std::unique_ptr<renderer::LightSet> make_lights(const Options& o, const scenes::Scene& scene) {
    if (o.is.name == "normals") return nullptr;
    std::vector<std::string> notes;
    auto lights = std::make_unique<renderer::LightSet>(
        scene, renderer::parse_light_model(o.lights_mode, scene.format), notes);
    std::fprintf(stderr, "[PathTracer] Light semantics: --lights=%s\n", renderer::light_model_name(lights->model()));
    std::fprintf(stderr, "%s\n", lights->summary().c_str());
    // Hemisphere rays see emission only: a delta light's contribution would vanish without
    // a word, as in the course, and the image differ from -l's by all of it.
    if (o.is.hemisphere) {
        size_t delta = 0;
        for (size_t i = 0; i < lights->size(); ++i) delta += lights->is_delta(i);
        if (delta)
            notes.push_back(fmt::format("-H: no hemisphere ray finds a point, spot or directional light; "
                                        "{} of this scene's lights light nothing (light sampling, without -H, "
                                        "samples them)",
                                        delta));
    }
    tools::print_once("[PathTracer] Note: ", notes);
    return lights;
}

/// --resume reads the accumulated samples (`resumed` must outlive the render); --checkpoint
/// writes them between passes. Both are tied to `fp`, the options and scene that made them.
void setup_checkpoints(Options& o, const std::string& fp, renderer::Accumulation& resumed) {
    if (!o.resume.empty()) {
        try {
            resumed = renderer::read_checkpoint(o.resume, fp);
        } catch (const renderer::CheckpointError& e) {
            fail(e.what());
        }
        o.rs.resume = &resumed;
    }
    if (!o.checkpoint.empty())
        o.rs.on_checkpoint = [path = o.checkpoint, fp](const renderer::Accumulation& acc, bool) {
            try {
                renderer::write_checkpoint(path, acc, fp);
            } catch (const renderer::CheckpointError& e) {
                fail(e.what());
            }
        };
}

/// The course's statistics lines, on stdout as results.
void print_statistics(const renderer::RenderResult& result, const accel::BuildInfo& info) {
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
    if (!result.split_shares.empty()) {
        std::string shares;
        for (const auto& [k, share] : result.split_shares)
            shares += fmt::format("{}{} way{} {:.1f} %", shares.empty() ? "" : ", ", k, k == 1 ? "" : "s",
                                  100.0 * share);
        std::printf("[PathTracer] Split by noise: later samples split %s of the pixels\n", shares.c_str());
    }
}

/// The image, written whole or not at all; an interrupted render is marked partial.
void write_main_image(const Options& o, const renderer::RenderResult& result, bool display_referred) {
    renderer::WriteOptions wo;
    wo.encoding = display_referred ? renderer::Encoding::Display : renderer::Encoding::SceneLinear;
    wo.ocio_config = o.ocio_config;
    if (result.partial) wo.attributes.push_back({"pathtracer:partial", "1"});
    std::fprintf(stderr, "[PathTracer] Saving to file: %s... ", o.output.c_str());
    const mem::Stage stage("writing the image", true);
    try {
        renderer::write_image(o.output, result.image, wo);
    } catch (const std::bad_alloc& e) {
        mem::out_of_memory(e);
    } catch (const renderer::ImageModuleMemoryError& e) {
        std::fprintf(stderr, "\n");
        mem::refuse(fmt::format("{}, to write {}", e.what(), o.output));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "\n");
        fail(e.what());
    }
    std::fprintf(stderr, "Done!\n");
    std::printf("Wrote %s%s\n", o.output.c_str(), result.partial ? " (partial: interrupted)" : "");
    if (result.time_limited)
        std::printf("[PathTracer] Time limit: %.2f samples per pixel of %d\n",
                    double(result.samples) / double(size_t(o.rs.width) * o.rs.height), o.rs.spp);
}

/// Side images: the sample-rate heat map (course name NAME_rate.png) and the cost maps.
void write_side_images(const Options& o, const renderer::RenderResult& result) {
    const renderer::RenderSettings& rs = o.rs;
    const mem::Stage stage("writing the side images");
    auto channel = [&](int c) {
        std::vector<float> v(size_t(rs.width) * rs.height);
        for (size_t i = 0; i < v.size(); ++i) v[i] = result.image.pixels[i * result.image.nchannels() + c];
        return v;
    };
    auto write_heat = [&](int c, const std::string& suffix) {
        std::vector<float> v = channel(c);
        const float hi = *std::max_element(v.begin(), v.end());
        const std::string path = sibling(o.output, suffix, ".png");
        renderer::WriteOptions ho;
        ho.encoding = renderer::Encoding::Display;
        try {
            renderer::write_image(path, renderer::heat_map(v, rs.width, rs.height, 0.0f, hi), ho);
        } catch (const std::bad_alloc& e) {
            mem::out_of_memory(e);
        } catch (const renderer::ImageModuleMemoryError& e) {
            mem::refuse(fmt::format("{}, to write {}", e.what(), path));
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
    if (o.cost) {
        write_heat(renderer::kCostNodes, "_nodes");
        write_heat(renderer::kCostTests, "_tests");
    }
}

/// The images and the checkpoint this run will write: each folder must take a new file
/// and each image's extension must have a writer, before the scene loads. Rank 0 alone
/// writes, so it alone checks.
void check_outputs(const Options& o, const dist::World& world) {
    if (!world.root()) return;
    std::vector<std::pair<std::string, std::string>> images{{"-f", o.output}};
    if (o.rs.adaptive_batch > 0) images.push_back({"-a (its sample-rate image)", sibling(o.output, "_rate", ".png")});
    if (o.cost) {
        images.push_back({"--cost", sibling(o.output, "_nodes", ".png")});
        images.push_back({"--cost", sibling(o.output, "_tests", ".png")});
    }
    for (const auto& [flag, path] : images)
        if (const std::string why = tools::check_image_output(flag, path); !why.empty()) fail(why);
    if (const std::string why = renderer::image_module_missing(); !why.empty()) fail(why);
    if (!o.checkpoint.empty())
        if (const std::string why = tools::check_writable("--checkpoint", o.checkpoint); !why.empty())
            fail(why);
    if (!o.record_rays.empty())
        if (const std::string why = tools::check_writable("--record-rays", o.record_rays); !why.empty())
            fail(why);
}

/// Under an address-space limit (ulimit -v) the image libraries' mappings are what the save
/// can run out of, hours later: they are mapped before the render, so such a run fails
/// before any work instead of losing it. Without one they load at the save, after the
/// scene is freed (renderer/image_module.h).
void map_image_libraries_if_limited(const dist::World& world) {
    rlimit as{};
    if (!world.root() || getrlimit(RLIMIT_AS, &as) != 0 || as.rlim_cur == RLIM_INFINITY) return;
    const mem::Stage stage("loading the image libraries");
    try {
        renderer::load_image_module();
    } catch (const renderer::ImageModuleMemoryError& e) {
        mem::refuse(fmt::format("{} (ulimit -v {} KiB); refused before the render", e.what(), as.rlim_cur / 1024));
    } catch (const std::exception& e) {
        fail(e.what());
    }
}

uint64_t gib_bytes(double gib) { return uint64_t(gib * 1024.0 * 1024.0 * 1024.0); }

/// The film alone, before the scene loads: an image that cannot fit in this machine (its
/// memory and swap, ulimit -v, the cgroup), or in --max-memory, is refused at once rather
/// than after the scene has loaded and the BVH is built.
void check_film(const Options& o) {
    const uint64_t film = renderer::film_bytes(o.rs.width, o.rs.height, !o.resume.empty());
    std::string what;
    uint64_t limit = mem::memory_limit(true, &what);
    if (o.max_memory_gib > 0 && gib_bytes(o.max_memory_gib) < limit) {
        limit = gib_bytes(o.max_memory_gib);
        what = fmt::format("--max-memory {:g}", o.max_memory_gib);
    }
    if (film > limit)
        mem::refuse(fmt::format("the film of -r {} {} needs {} ({} bytes, {} per pixel), more than {} ({})",
                                o.rs.width, o.rs.height, mem::size_text(film), film,
                                film / (uint64_t(o.rs.width) * uint64_t(o.rs.height)), mem::size_text(limit), what));
}

/// The estimate of peak memory, made before the build from what is measured so far (the
/// resident set once the scene, lights and integrator are in memory, and the loader's
/// high-water mark) and what is still to come, per primitive and per pixel.
struct MemoryEstimate {
    uint64_t loaded = 0, loading_peak = 0, build = 0, kept = 0, film = 0, writing = 0, peak = 0;
    uint64_t record = 0;  ///< --record-rays: its buffers at their fullest and the file's copy
    const char* when = "";  ///< the stage the peak falls in
};

/// Resident bytes once the image libraries (renderer/image_module.h) are loaded, above a
/// process that has not loaded them: Debian 12's OpenImageIO 2.4 and the ~270 libraries it
/// brings (measured, the 8x8 Cornell box: 140 MB peak against 9 MB before the save).
constexpr uint64_t kImageLibrariesBytes = 125ull << 20;

/// Resident bytes when main starts, before anything is loaded: the base of the estimate's
/// last stage, when the scene and the BVH are freed and the image is encoded.
uint64_t g_start_resident = 0;

MemoryEstimate estimate_memory(const Options& o, const renderer::SceneGeometry& geometry) {
    uint64_t prims = 0;
    for (const accel::GeometryView& v : geometry.views()) prims += v.num_prims;
    // Bytes per primitive above the resident set before the build: at the build's peak
    // (what is kept included), and kept for the render. Measured with /usr/bin/time on
    // generated meshes of 2M, 5M and 20M triangles (benchmarks/memory_estimate.sh); the
    // figures for Embree's low and medium qualities, SBVH and plugins are not measured and
    // lean high.
    double build = 0, kept = 0;
    if (o.backend == "embree") {
        const bool high = o.ao.embree_quality == accel::EmbreeQuality::High;
        build = high ? 112 : 120;
        kept = high ? 70 : 80;
    } else if (o.backend == "naive") {
        build = kept = 8;
    } else if (o.backend.rfind("plugin:", 0) == 0) {
        build = 150;
        kept = 80;
    } else {
        const bool quantized = o.ao.nodes == accel::NodeLayout::Quantized ||
                               (o.ao.nodes == accel::NodeLayout::Auto && prims >= 4000000);
        build = quantized ? 88 : 118;
        kept = quantized ? 45 : 50;
        if (o.ao.split == accel::BvhSplit::Sbvh) {
            build *= 2.0;
            kept *= 1.5;
        }
    }
    // Bytes per instance (placements of prototypes), above their primitives', measured on
    // the forest of 10^7 placements (benchmarks/instancing.sh), rounded up: ours ~240 at
    // the build's peak (the top level's binary tree and build records beside the
    // placements), 97 kept with the float top nodes of Auto and 75 with compressed ones
    // (--nodes quantized). Embree keeps an instance object each: ~390 bytes, ~400 at the
    // peak.
    const uint64_t instances = geometry.instances().instances.size();
    double build_i = 0, kept_i = 0;
    if (o.backend == "embree") {
        build_i = 400, kept_i = 390;
    } else if (o.backend == "naive") {
        build_i = kept_i = 56;
    } else if (o.backend.rfind("plugin:", 0) != 0) {
        build_i = 260;
        kept_i = o.ao.nodes == accel::NodeLayout::Quantized ? 80 : 100;
    }
    MemoryEstimate e;
    e.loaded = mem::resident_bytes();
    e.loading_peak = mem::peak_resident_bytes();
    e.build = uint64_t(build * double(prims) + build_i * double(instances));
    e.kept = uint64_t(kept * double(prims) + kept_i * double(instances));
    e.film = renderer::film_bytes(o.rs.width, o.rs.height, !o.resume.empty());
    // The save holds the resolved image and the encoder's copy of it: all of it as float for
    // EXR, 3 floats and 3 bytes per pixel for the 8-bit formats.
    const uint64_t pixels = uint64_t(o.rs.width) * uint64_t(o.rs.height);
    const uint64_t image = pixels * sizeof(float) * renderer::kNumChannels;
    e.writing = g_start_resident + kImageLibrariesBytes + image +
                (renderer::is_float_format(o.output) ? image : pixels * 15);
    // A full ray record: each kind's buffers grown by doubling (up to twice the rays), then
    // copied whole for the file.
    if (!o.record_rays.empty()) e.record = 3 * 2 * o.record_rays_max * sizeof(accel::Ray);
    const uint64_t during_build = e.loaded + e.build, during_render = e.loaded + e.kept + e.film + e.record;
    e.peak = std::max({e.loading_peak, during_build, during_render, e.writing});
    e.when = e.peak == e.loading_peak ? "loading"
             : e.peak == during_build ? "the build"
             : e.peak == during_render ? "the render"
                                       : "the save";
    return e;
}

/// Prints the estimate, and refuses (exit status 3) a render whose estimate exceeds
/// --max-memory, or by default this machine's memory and swap: a render that would be
/// killed hours later for want of memory is refused before any work.
void check_memory(const Options& o, const MemoryEstimate& e) {
    std::fprintf(stderr,
                 "[PathTracer] Memory estimate: peak %s during %s (scene and set-up %s measured, "
                 "loading peak %s, BVH %s while building, %s kept, film %s%s, save %s)\n",
                 mem::size_text(e.peak).c_str(), e.when, mem::size_text(e.loaded).c_str(),
                 mem::size_text(e.loading_peak).c_str(), mem::size_text(e.build).c_str(),
                 mem::size_text(e.kept).c_str(), mem::size_text(e.film).c_str(),
                 e.record ? (", ray record " + mem::size_text(e.record)).c_str() : "",
                 mem::size_text(e.writing).c_str());
    std::string what;
    uint64_t limit = mem::memory_limit(false, &what);
    if (o.max_memory_gib > 0) {
        limit = gib_bytes(o.max_memory_gib);
        what = fmt::format("--max-memory {:g}", o.max_memory_gib);
    }
    if (e.peak > limit)
        mem::refuse(fmt::format("the estimated peak of {} is more than {} ({}); refused before the build",
                                mem::size_text(e.peak), mem::size_text(limit), what));
}

}  // namespace

int main(int argc, char** argv) {
    mem::install("pathtracer");
    g_start_resident = mem::resident_bytes();
    CLI::App app{"Physically based path tracer: diffuse, mirror, glass, microfacet, glTF PBR and unlit materials (CS184 dialect "
                 "COLLADA, glTF 2.0), on our own BVH or on Embree."};
    app.set_help_flag("-h,--help", "Print this help and exit");
    Options o;
    add_course_options(app, o);
    add_accel_options(app, o);
    add_scene_options(app, o);
    add_progress_options(app, o);
    tools::parse_or_exit(app, argc, argv, "pathtracer");
    const dist::World world = dist::init(argc, argv, "pathtracer");
    // Out of memory on any rank stops every rank, with status 3.
    mem::on_exit([](int status) { dist::abort_job(status); });
    finish_options(o, world);
    // Before any work: what cannot be saved, or cannot fit, is refused now.
    check_outputs(o, world);
    check_film(o);

    const int threads = o.rs.threads > 0 ? o.rs.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    std::fprintf(stderr, "[PathTracer] Input scene file: %s\n", o.scene_path.c_str());
    std::fprintf(stderr, "[PathTracer] Rendering using %d threads%s\n", threads,
                 world.size > 1 ? fmt::format(" on each of {} MPI ranks", world.size).c_str() : "");

    // Set-up: scene, camera, lights, integrator, accelerator, checkpoints.
    scenes::Scene scene = load_scene(o);
    std::unique_ptr<accel::Accelerator> accel;
    std::unique_ptr<renderer::Integrator> integrator;
    std::unique_ptr<renderer::LightSet> lights;
    std::optional<renderer::SceneGeometry> geometry;
    std::optional<renderer::CameraSetup> cam;
    try {
        mem::set_stage("setting up the camera, lights and integrator");
        cam = setup_camera(o, scene);
        geometry.emplace(scene);
        lights = make_lights(o, scene);
        o.is.pixel_spread = cam->camera.pixel_spread(o.rs.width, o.rs.height, o.rs.spp);
        integrator = renderer::make_integrator(o.is, scene, *geometry, lights.get());
    } catch (const std::bad_alloc& e) {
        mem::out_of_memory(e);
    } catch (const accel::AccelError& e) {
        fail(e.what());
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    check_memory(o, estimate_memory(o, *geometry));
    {
        // The build's progress line is left open ("Building BVH... "), so an error
        // starts a line of its own.
        const mem::Stage stage("building the BVH", true);
        const uint64_t failures = mem::failures();
        try {
            accel = renderer::build_accelerator(o.backend, *geometry, o.ao);
        } catch (const std::bad_alloc& e) {
            mem::out_of_memory(e);
        } catch (const accel::AccelError& e) {
            // A plugin reports its failed allocation as an error of its own.
            if (mem::failures() != failures) mem::out_of_memory();
            fail(e.what());
        } catch (const std::invalid_argument& e) {
            fail(e.what());
        }
    }
    renderer::Accumulation resumed;
    try {
        mem::set_stage("reading the checkpoint");
        // The fingerprint reads the whole scene file: only for a checkpoint to write or read.
        if (!o.resume.empty() || !o.checkpoint.empty())
            setup_checkpoints(o, fingerprint(app, o.scene_path, o.rs.spp), resumed);
    } catch (const std::bad_alloc& e) {
        mem::out_of_memory(e);
    }

    map_image_libraries_if_limited(world);

    // Run.
    std::signal(SIGINT, on_sigint);
    renderer::RenderResult result;
    const std::unique_ptr<renderer::TileSource> tiles = dist::make_tile_source(world);
    o.rs.tiles = tiles.get();
    o.rs.on_stage = [](const char* stage) { mem::set_stage(stage); };
    std::optional<renderer::RayRecorder> recorder;
    if (!o.record_rays.empty()) recorder.emplace(*accel, o.record_rays_max);
    try {
        result = renderer::render(cam->camera, *integrator, recorder ? *recorder : *accel, o.rs);
    } catch (const std::bad_alloc& e) {
        mem::out_of_memory(e);
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    if (recorder) {
        try {
            mem::set_stage("writing the ray record");
            const renderer::RayRecord record = recorder->record(renderer::scene_primitives(scene));
            renderer::write_ray_record(o.record_rays, record);
            if (!o.quiet)
                std::printf("[PathTracer] Recorded %zu closest-hit and %zu any-hit rays to %s\n", record.closest.size(),
                            record.any_hit.size(), o.record_rays.c_str());
        } catch (const std::bad_alloc& e) {
            mem::out_of_memory(e);
        } catch (const std::runtime_error& e) {
            fail(e.what());
        }
        recorder.reset();
    }
    if (!world.root()) {  // rank 0 has gathered this rank's tiles and writes the files
        dist::finalize();
        return 0;
    }
    std::signal(SIGINT, SIG_DFL);
    // The sums are in the checkpoint already and the image is resolved: freeing them
    // before the files are encoded lowers the peak by 144 bytes per pixel.
    std::vector<renderer::PixelSums>().swap(result.sums.pixels);
    std::vector<renderer::PixelSums>().swap(resumed.pixels);

    // Output. The image libraries load at the first file (renderer/image_module.h); the
    // encoder needs none of the scene, so it is freed first and the peak is the render's
    // or the encoder's, not their sum.
    print_statistics(result, accel->info());
    const bool display_referred = integrator->display_referred();
    integrator.reset();
    lights.reset();
    accel.reset();
    geometry.reset();
    scene = scenes::Scene();
    malloc_trim(0);  // glibc keeps freed heap pages resident until asked
    write_main_image(o, result, display_referred);
    write_side_images(o, result);
    dist::finalize();
    return result.partial ? 130 : 0;
}
