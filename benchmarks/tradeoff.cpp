// tradeoff: the speed-accuracy study. For each Cornell-box scene, error against a
// high-sample reference versus wall time, for every knob a user can turn: hemisphere vs
// light sampling, samples per pixel, samples per light, adaptive tolerance, Russian
// roulette, the sampler under each roulette, bounce splitting, maximum depth, the
// accelerator, and the triangle test.
//
// Error metric (luminance Y = 0.2126 R + 0.7152 G + 0.0722 B, per pixel):
//   rel_rmse(region) = sqrt( sum_p (Y_p - Yref_p)^2 / sum_p Yref_p^2 ),  p in region
// i.e. the RMS error relative to the RMS brightness of the region. Unlike the per-pixel
// relative error it does not blow up on nearly black pixels. Regions:
//   image  - every pixel whose centre does not see an emitter directly (an emitter's
//            pixels are exact and 10-100x brighter; they would dominate the denominator
//            and make every estimator look good);
//   shadow - the cast shadows: pixels whose surface faces the light but sees less than
//            95 % of it unoccluded (umbra and penumbra), measured once per scene with 64
//            shadow rays per sub-pixel sample. Indirect light dominates there, which is
//            where the estimators differ most.
// The reference has noise of its own; `*_debiased` columns subtract its estimated
// variance (the reference's per-pixel variance of the mean, summed over the region)
// from the squared error, so that high-spp points are not flattened by the reference's
// floor. Under mpirun the points are spread over the ranks (point i on rank i mod N) and
// the reference is rendered by all of them; rank 0 prints and writes everything, and
// every error is identical to a single-process run (same seeds, per-sample streams). Wall
// time is render() alone (all threads unless --threads), scene loading and BVH build
// excluded; the accelerator comparison also reports build time.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <memory>
#include <string>
#include <vector>

#include "renderer/backend_spec.h"
#include "renderer/camera.h"
#include "renderer/integrators/path.h"
#include "renderer/interaction.h"
#include "renderer/lights.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "renderer/spawn.h"
#include "scenes/load.h"
#include "tools/cli.h"
#include "tools/distributed/distributed.h"

namespace {

using Clock = std::chrono::steady_clock;
using renderer::IntegratorSettings;

[[noreturn]] void fail(const std::string& m) { tools::fail("tradeoff", m); }

float luminance(const float* p) { return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2]; }

/// One configuration to render.
struct Config {
    std::string study, label;  ///< study name and the curve within it
    double param = 0;          ///< the swept value (for the x axis of non-time plots)
    IntegratorSettings is;
    int spp = 1;
    std::string backend = "custom:sah";
    int adaptive_batch = 0;
    float adaptive_tol = 0;
    uint64_t seed = 1;
    /// The course's independent samples (baseline()); sampler_rr and split set their own.
    renderer::SamplerKind sampler = renderer::SamplerKind::Independent;
};

/// Per-pixel luminance, the variance of its mean, and the region masks.
struct Reference {
    int w = 0, h = 0, spp = 0;
    std::vector<float> y, var;
    std::vector<uint8_t> image_mask, shadow_mask;
    double seconds = 0;
};

/// Everything one scene needs, kept alive together; accelerators built on first use.
struct World {
    scenes::Scene scene;
    std::unique_ptr<renderer::SceneGeometry> geometry;
    std::unique_ptr<renderer::LightSet> lights;
    std::vector<std::string> notes;
    renderer::LightModel model{};
    renderer::Camera camera;
    std::map<std::string, std::unique_ptr<accel::Accelerator>> accels;
    std::map<std::string, double> build_ms;

    const accel::Accelerator& accel(const std::string& spec_str) {
        auto it = accels.find(spec_str);
        if (it != accels.end()) return *it->second;
        const renderer::BackendSpec spec = renderer::parse_backend_spec(spec_str);
        const auto t0 = Clock::now();
        auto a = renderer::build_accelerator(spec.backend, *geometry, spec.options, false);
        build_ms[spec_str] = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
        return *(accels[spec_str] = std::move(a));
    }
};

renderer::RenderResult render(World& w, const Config& c, int width, int height, int threads,
                              renderer::TileSource* tiles = nullptr) {
    const accel::Accelerator& a = w.accel(c.backend);
    renderer::PathIntegrator integrator(w.scene, *w.geometry, *w.lights, c.is);
    renderer::RenderSettings rs;
    rs.width = width;
    rs.height = height;
    rs.spp = c.spp;
    rs.threads = threads;
    rs.seed = c.seed;
    rs.progress = false;
    rs.adaptive_batch = c.adaptive_batch;
    rs.adaptive_tol = c.adaptive_tol;
    rs.sampler = c.sampler;
    rs.tiles = tiles;
    return renderer::render(w.camera, integrator, a, rs);
}

/// Pixels that see an emitter (excluded from every region) and the cast-shadow mask, from
/// 2x2 sub-pixel camera rays and `k` light samples per light each.
void make_masks(World& w, Reference& ref, int k) {
    const accel::Accelerator& a = w.accel("custom:sah");
    const accel::Bounds3f b = w.scene.bounds();
    const float scale = b.empty() ? 1.0f : accel::max_component(b.diagonal());
    ref.image_mask.assign(size_t(ref.w) * ref.h, 1);
    ref.shadow_mask.assign(size_t(ref.w) * ref.h, 0);
    renderer::Rng rng(99, 0);
    accel::TraceStats st;
    for (int y = 0; y < ref.h; ++y)
        for (int x = 0; x < ref.w; ++x) {
            int facing = 0, visible = 0;
            bool sees_emitter = false;
            for (int s = 0; s < 4; ++s) {
                const float fx = (float(x) + 0.25f + 0.5f * float(s & 1)) / float(ref.w);
                const float fy = (float(y) + 0.25f + 0.5f * float(s >> 1)) / float(ref.h);
                const accel::Ray ray = w.camera.generate_ray(fx, fy);
                accel::Hit hit;
                if (!a.intersect(ray, hit, st)) continue;
                renderer::Interaction it = renderer::make_interaction(w.scene, *w.geometry, ray, hit);
                if (it.material < w.scene.materials.size() && w.scene.materials[it.material].is_emissive()) {
                    sees_emitter = true;
                    continue;
                }
                const accel::Vec3f wo = -accel::normalize(ray.dir);
                if (accel::dot(it.ng, wo) < 0) it.ng = -it.ng;
                if (accel::dot(it.ns, it.ng) < 0) it.ns = -it.ns;
                for (size_t li = 0; li < w.lights->size(); ++li) {
                    if (w.lights->is_delta(li)) continue;
                    for (int j = 0; j < k; ++j) {
                        renderer::LightSample ls;
                        if (!w.lights->sample(li, it.p, it.ns, rng, ls) || !(ls.pdf > 0)) continue;
                        if (!(accel::dot(it.ns, ls.wi) > 0) || accel::dot(it.ng, ls.wi) <= 0) continue;
                        if (!std::isfinite(ls.distance)) continue;  // environment: not a cast shadow
                        ++facing;
                        const accel::Ray sr = renderer::spawn_segment(it.p, it.p_error, it.ng, ls.target,
                                                                      ls.target_error, scale,
                                                                      renderer::OffsetMode::ErrorBound, ls.normal);
                        if (!a.occluded(sr, st)) ++visible;
                    }
                }
            }
            const size_t i = size_t(y) * ref.w + x;
            if (sees_emitter) ref.image_mask[i] = 0;
            // A surface facing away from the light is dark by orientation, not shadowed.
            ref.shadow_mask[i] = !sees_emitter && facing > 0 && double(visible) < 0.95 * double(facing);
        }
}

/// Cached reference: a tiny header line then raw float32 luminance and variance.
std::string ref_header(const std::string& scene, int w, int h, int spp, const IntegratorSettings& is,
                       renderer::LightModel model) {
    // v3: the light model is the scene's default (course for COLLADA); v2 references were
    // --lights=mesh with two-sided panels, v1 one-sided panels.
    return fmt::format("tradeoff-ref v3 {} {}x{} spp={} l={} m={} rr={:.3f} lights={}\n", scene, w, h, spp,
                       is.light_samples, is.max_depth, is.rr_continue, renderer::light_model_name(model));
}

bool load_ref(const std::string& path, const std::string& header, Reference& ref) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    std::string line;
    std::getline(f, line);
    if (line + "\n" != header) return false;
    const size_t n = size_t(ref.w) * ref.h;
    ref.y.resize(n);
    ref.var.resize(n);
    f.read(reinterpret_cast<char*>(ref.y.data()), std::streamsize(n * 4));
    f.read(reinterpret_cast<char*>(ref.var.data()), std::streamsize(n * 4));
    f.read(reinterpret_cast<char*>(&ref.seconds), sizeof ref.seconds);
    return bool(f);
}

void save_ref(const std::string& path, const std::string& header, const Reference& ref) {
    const std::string tmp = path + ".tmp";
    {
        std::ofstream f(tmp, std::ios::binary);
        f << header;
        f.write(reinterpret_cast<const char*>(ref.y.data()), std::streamsize(ref.y.size() * 4));
        f.write(reinterpret_cast<const char*>(ref.var.data()), std::streamsize(ref.var.size() * 4));
        f.write(reinterpret_cast<const char*>(&ref.seconds), sizeof ref.seconds);
        if (!f) fail(path + ": write failed");
    }
    std::filesystem::rename(tmp, path);
}

struct Errors {
    double image = 0, shadow = 0, image_db = 0, shadow_db = 0;
};

Errors errors(const renderer::Image& img, const Reference& ref) {
    double se[2] = {0, 0}, sr[2] = {0, 0}, sv[2] = {0, 0};
    for (int y = 0; y < ref.h; ++y)
        for (int x = 0; x < ref.w; ++x) {
            const size_t i = size_t(y) * ref.w + x;
            if (!ref.image_mask[i]) continue;
            const double d = double(luminance(img.at(x, y))) - ref.y[i];
            for (int r = 0; r < 2; ++r) {
                if (r == 1 && !ref.shadow_mask[i]) continue;
                se[r] += d * d;
                sr[r] += double(ref.y[i]) * ref.y[i];
                sv[r] += ref.var[i];
            }
        }
    auto rel = [](double e, double r) { return r > 0 ? std::sqrt(std::max(0.0, e) / r) : 0.0; };
    return {rel(se[0], sr[0]), rel(se[1], sr[1]), rel(se[0] - sv[0], sr[0]), rel(se[1] - sv[1], sr[1])};
}

/// Every option, as CLI11 fills it.
struct Options {
    std::vector<std::string> scene_paths;
    std::string csv_path, ref_dir = std::string(PT_SOURCE_DIR_BENCH) + "/benchmarks/results/reference";
    std::string lights;  ///< --lights; empty: the scene format's default
    std::string studies_arg =
        "spp,sampling,light_samples,adaptive,rr,sampler_rr,split,max_depth,backend,"
        "triangle_test";
    int width = 160, height = 120, ref_spp = 4096, threads = 0, repeats = 1;
    bool quick = false;
    std::vector<std::string> studies;  ///< --studies, split
    bool wants(const char* s) const { return std::find(studies.begin(), studies.end(), s) != studies.end(); }
};

void add_options(CLI::App& app, Options& o) {
    app.add_option("--scene", o.scene_paths, "Scene (repeatable; default: the shared CBspheres_lambertian and CBbunny)");
    app.add_option("--csv", o.csv_path, "Write the rows as CSV");
    app.add_option("--ref-dir", o.ref_dir, "Where references are cached (default benchmarks/results/reference)");
    app.add_option("--lights", o.lights,
                   "Light semantics, course | mesh (default: the scene's own, course for COLLADA); a "
                   "reference is cached per light model, so give each its own --ref-dir");
    app.add_option("--studies", o.studies_arg, "Comma-separated studies to run (default all)");
    app.add_option("--width", o.width, "Image width (default 160; the course's 480x360 field of view is kept)");
    app.add_option("--height", o.height, "Image height (default 120)");
    app.add_option("--ref-spp", o.ref_spp, "Reference samples per pixel (default 4096)");
    app.add_option("--threads", o.threads, "Render threads (default 0 = all cores)");
    app.add_option("--repeats", o.repeats, "Renders per configuration; the median time is kept (default 1)");
    app.add_flag("--quick", o.quick, "Smoke run: the default scene at 32x24, reference 64 spp (not cached), few points");
}

/// --quick's sizes, the default scenes, and the studies' list.
void finish_options(Options& o) {
    const std::string shared = std::string(PT_SOURCE_DIR_BENCH) + "/../shared/scenes/cs184/";
    if (o.quick) {
        o.width = 32;
        o.height = 24;
        o.ref_spp = 64;
        if (o.scene_paths.empty()) o.scene_paths.push_back(std::string(PT_SOURCE_DIR_BENCH) + "/scenes/cornell.dae");
    }
    if (o.scene_paths.empty())
        for (const char* f : {"CBspheres_lambertian.dae", "CBbunny.dae"}) o.scene_paths.push_back(shared + f);
    if (o.width < 4 || o.height < 3 || o.ref_spp < 4) fail("image or reference too small");
    std::stringstream ss(o.studies_arg);
    for (std::string s; std::getline(ss, s, ',');) o.studies.push_back(s);
}

/// The study's baseline, which is also how the reference is rendered: light sampling,
/// one sample per light, depth 100 (Russian roulette ends paths long before), rr 0.65,
/// one path per camera sample (no bounce splitting), independent samples
/// (Config::sampler), as the course renders. Depth 100 makes the reference the converged
/// global illumination, so the max-depth study can show the bias of truncating paths.
IntegratorSettings baseline() {
    IntegratorSettings base;
    base.name = "path";
    base.max_depth = 100;
    base.light_samples = 1;
    base.rr_continue = 0.65f;
    base.split = 1;
    return base;
}

/// Loads the scene into `w`, with its default light model and the course's framing.
void setup_world(World& w, const std::string& path, const Options& o) {
    try {
        w.scene = scenes::load_scene(path);
    } catch (const scenes::SceneError& e) {
        fail(e.what());
    }
    w.geometry = std::make_unique<renderer::SceneGeometry>(w.scene);
    // The light model a user gets by default (course for the CS184 files). Under mesh
    // semantics the panel's upper side, 1 cm below the ceiling, is sampled by area and
    // its 1/r^2 spikes on the ceiling dominate every error measured here (relative RMSE
    // 0.6 at 1024 spp, measured): that would be a study of that one estimator's tail.
    // The price: under course semantics -H converges to a slightly different image (the
    // panel's upper side lights the ceiling under -H only), so the hemisphere rows carry
    // that bias against the light-sampled reference.
    try {
        w.model = renderer::parse_light_model(o.lights, w.scene.format);
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    w.lights = std::make_unique<renderer::LightSet>(w.scene, w.model, w.notes);
    // The course's 480x360 framing, rendered at width x height (as the transport tests do).
    renderer::CameraOverrides ov;
    ov.hfov_deg = renderer::make_camera(w.scene, renderer::CameraMode::Auto, 480, 360).camera.hfov_deg();
    w.camera = renderer::make_camera(w.scene, renderer::CameraMode::Auto, o.width, o.height, ov).camera;
}

/// Renders the reference with every rank's help; rank 0 caches it (unless --quick).
void render_reference(World& w, Reference& ref, const std::string& name, const Options& o,
                      const IntegratorSettings& base, const dist::World& mpi, const std::string& ref_path,
                      const std::string& header) {
    std::fprintf(stderr, "[tradeoff] %s: rendering the %d spp reference...\n", name.c_str(), o.ref_spp);
    Config c;
    c.is = base;
    c.spp = o.ref_spp;
    c.seed = 0x5eed0f7e5ULL;  // independent of every study render (they use small seeds)
    const auto tiles = dist::make_tile_source(mpi);
    const auto r = render(w, c, o.width, o.height, o.threads, tiles.get());
    ref.seconds = r.seconds;
    ref.y.resize(size_t(o.width) * o.height);
    ref.var.resize(ref.y.size());
    for (int y = 0; y < o.height; ++y)
        for (int x = 0; x < o.width; ++x) {
            ref.y[size_t(y) * o.width + x] = luminance(r.image.at(x, y));
            ref.var[size_t(y) * o.width + x] = r.image.at(x, y)[renderer::kVariance];
        }
    if (!o.quick && mpi.root()) {
        std::filesystem::create_directories(o.ref_dir);
        save_ref(ref_path, header, ref);
        try {
            renderer::write_image(fmt::format("{}/{}_reference.png", o.ref_dir, name), r.image);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "[tradeoff] %s\n", e.what());
        }
    }
    std::fprintf(stderr, "[tradeoff] %s: reference took %.1f s\n", name.c_str(), r.seconds);
}

/// The reference of one scene, on every rank: cached, or rendered now; then its masks.
Reference make_reference(World& w, const std::string& name, const Options& o, const IntegratorSettings& base,
                         const dist::World& mpi) {
    Reference ref;
    ref.w = o.width;
    ref.h = o.height;
    ref.spp = o.ref_spp;
    // The camera is part of the reference: a cached one made with another framing must
    // be rendered again, not reused.
    std::string header = ref_header(name, o.width, o.height, o.ref_spp, base, w.model);
    header.insert(header.size() - 1, fmt::format(" hfov={:.3f}", w.camera.hfov_deg()));
    const std::string ref_path = fmt::format("{}/{}_{}x{}_{}spp.ref", o.ref_dir, name, o.width, o.height, o.ref_spp);
    // Rank 0 decides whether the cached reference is usable; if not, every rank renders
    // tiles of it and rank 0 gathers; then every rank gets rank 0's copy.
    std::string cached(1, (!o.quick && mpi.root() && load_ref(ref_path, header, ref)) ? '1' : '0');
    dist::broadcast(mpi, cached);
    if (cached[0] == '0') render_reference(w, ref, name, o, base, mpi, ref_path, header);
    for (std::vector<float>* v : {&ref.y, &ref.var}) {
        std::string bytes(reinterpret_cast<const char*>(v->data()), v->size() * sizeof(float));
        dist::broadcast(mpi, bytes);
        v->resize(bytes.size() / sizeof(float));
        std::memcpy(v->data(), bytes.data(), bytes.size());
    }
    make_masks(w, ref, o.quick ? 8 : 64);
    if (!o.quick && mpi.root()) {
        std::vector<float> m(ref.shadow_mask.size());
        for (size_t i = 0; i < m.size(); ++i) m[i] = ref.image_mask[i] ? (ref.shadow_mask[i] ? 1.0f : 0.3f) : 0.0f;
        try {
            renderer::write_image(fmt::format("{}/{}_shadow_mask.png", o.ref_dir, name),
                                  renderer::heat_map(m, o.width, o.height, 0.0f, 1.0f),
                                  {renderer::Encoding::Display, "", "", "", {}});
        } catch (const std::exception& e) {
            std::fprintf(stderr, "[tradeoff] %s\n", e.what());
        }
    }
    return ref;
}

/// The reference's own noise, as the rel_rmse it would score against itself (image, shadow).
struct NoiseFloor {
    double image = 0, shadow = 0;
};

NoiseFloor noise_floor(const Reference& ref, const std::string& name, const dist::World& mpi) {
    double rv[2] = {0, 0}, ry[2] = {0, 0};
    size_t nshadow = 0;
    for (size_t i = 0; i < ref.y.size(); ++i) {
        if (!ref.image_mask[i]) continue;
        rv[0] += ref.var[i];
        ry[0] += double(ref.y[i]) * ref.y[i];
        if (ref.shadow_mask[i]) {
            rv[1] += ref.var[i];
            ry[1] += double(ref.y[i]) * ref.y[i];
            ++nshadow;
        }
    }
    const NoiseFloor f{ry[0] > 0 ? std::sqrt(rv[0] / ry[0]) : 0, ry[1] > 0 ? std::sqrt(rv[1] / ry[1]) : 0};
    if (mpi.root())
        std::fprintf(stderr, "[tradeoff] %s: %zu shadow pixels of %zu; reference noise floor %.4f (shadow %.4f)\n",
                     name.c_str(), nshadow, ref.y.size(), f.image, f.shadow);
    return f;
}

/// The sampling studies' points (spp, sampling, light samples, adaptive, rr, sampler and
/// roulette, split, max depth).
/// Quick mode keeps one or two points per study.
void add_sampling_configs(std::vector<Config>& configs, const Options& o, const IntegratorSettings& base) {
    const bool quick = o.quick;
    auto add = [&](Config c) { configs.push_back(std::move(c)); };
    const std::vector<int> spps = quick ? std::vector<int>{1, 4} : std::vector<int>{1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024};
    if (o.wants("spp"))
        for (int s : spps) add({"spp", "light sampling", double(s), base, s});
    if (o.wants("sampling"))
        for (int s : quick ? std::vector<int>{1, 4} : std::vector<int>{1, 4, 16, 64, 256, 1024}) {
            Config c{"sampling", "hemisphere", double(s), base, s};
            c.is.hemisphere = true;
            add(c);
        }
    if (o.wants("light_samples"))
        for (int l : quick ? std::vector<int>{1, 4} : std::vector<int>{1, 2, 4, 8, 16, 32, 64}) {
            Config c{"light_samples", "spp 4 l=N", double(l), base, 4};
            c.is.light_samples = l;
            add(c);
        }
    if (o.wants("adaptive")) {
        const int cap = quick ? 16 : 256;
        for (float tol : quick ? std::vector<float>{0.2f} : std::vector<float>{0.5f, 0.2f, 0.1f, 0.05f, 0.025f}) {
            const int batch = quick ? 4 : 16;
            Config c{"adaptive", fmt::format("cap {} batch {}", cap, batch), double(tol), base, cap};
            c.adaptive_batch = batch;
            c.adaptive_tol = tol;
            add(c);
        }
        // The non-adaptive render at the cap: what the tolerance trades against.
        add({"adaptive", "fixed", 0.0, base, cap});
    }
    if (o.wants("rr"))
        for (float rr : quick ? std::vector<float>{0.65f} : std::vector<float>{1.0f, 0.9f, 0.8f, 0.65f, 0.5f, 0.3f, 0.15f}) {
            Config c{"rr", quick ? "spp 2" : "spp 16", double(rr), base, quick ? 2 : 16};
            c.is.rr_continue = rr;
            add(c);
        }
    // Every sampler under both roulettes (renderer/sampler.h; --rr): error against time at
    // 4, 16 and 64 spp, so the efficiency 1 / (error^2 t) of each pair can be read off.
    if (o.wants("sampler_rr"))
        for (const char* name : {"independent", "stratified", "sobol", "zsobol", "pmj02"})
            for (const float rr : {IntegratorSettings::kThroughputRoulette, 0.65f})
                for (int spp : quick ? std::vector<int>{4} : std::vector<int>{4, 16, 64}) {
                    Config c{"sampler_rr", fmt::format("{} rr={}", name, rr < 0 ? "throughput" : "0.65"), double(spp),
                             base, spp};
                    c.sampler = renderer::parse_sampler(name);
                    c.is.rr_continue = rr;
                    add(c);
                }
    // Bounce splitting (IntegratorSettings::split) on top of the sampler and roulette
    // that are the renderer's defaults: K = 1 is sampler_rr's "sobol rr=throughput"
    // curve, and the renderer's default, K = 4 sized per pixel by its noise from 8 spp
    // (renderer/README.md, "split by noise"), is one of these; "uniform" is K = 4 at
    // every pixel (--split-by uniform), the same rays spread evenly.
    if (o.wants("split"))
        for (const int k : quick ? std::vector<int>{4} : std::vector<int>{2, 4, 8})
            for (const bool by_noise : k == 4 && !quick ? std::vector<bool>{true, false} : std::vector<bool>{true})
                for (int spp : quick ? std::vector<int>{4} : std::vector<int>{4, 16, 64}) {
                    Config c{"split", fmt::format("sobol rr=throughput split={}{}", k, by_noise ? "" : " uniform"),
                             double(spp), base, spp};
                    c.sampler = renderer::SamplerKind::Sobol;
                    c.is.rr_continue = IntegratorSettings::kThroughputRoulette;
                    c.is.split = k;
                    c.is.split_by_noise = by_noise;
                    add(c);
                }
    if (o.wants("max_depth"))
        for (int m : quick ? std::vector<int>{1, 5} : std::vector<int>{1, 2, 3, 4, 5, 8, 16, 100}) {
            Config c{"max_depth", quick ? "spp 2" : "spp 64", double(m), base, quick ? 2 : 64};
            c.is.max_depth = m;
            add(c);
        }
}

/// Every study's points: the sampling knobs, then the accelerators and triangle tests at
/// equal samples.
std::vector<Config> make_configs(const Options& o, const IntegratorSettings& base, bool have_embree) {
    std::vector<Config> configs;
    add_sampling_configs(configs, o, base);
    const std::vector<int> eq_spps = o.quick ? std::vector<int>{2} : std::vector<int>{4, 16, 64};
    if (o.wants("backend")) {
        std::vector<std::string> bs = {"custom:midpoint", "custom:sah"};
        if (have_embree) bs.push_back("embree:high");
        for (const auto& b : bs)
            for (int s : eq_spps) {
                Config c{"backend", b, double(s), base, s};
                c.backend = b;
                configs.push_back(c);
            }
    }
    if (o.wants("triangle_test"))
        for (const char* b : {"custom:sah:fast", "custom:sah:watertight"})
            for (int s : eq_spps) {
                Config c{"triangle_test", b, double(s), base, s};
                c.backend = b;
                configs.push_back(c);
            }
    return configs;
}

/// Renders this rank's points (point i on rank i mod N), each as "text line\ncsv line";
/// a single process prints each text line as it goes.
std::vector<std::string> run_configs(World& w, std::vector<Config>& configs, const Reference& ref,
                                     const NoiseFloor& floor, const std::string& name, const Options& o,
                                     const dist::World& mpi) {
    std::vector<std::string> rows;
    for (Config& c : configs) {
        // Every configuration gets its own seed, independent of the reference's.
        c.seed = 1 + uint64_t(&c - configs.data());
        if ((&c - configs.data()) % mpi.size != mpi.rank) continue;
        std::vector<double> times;
        renderer::RenderResult r;
        for (int k = 0; k < std::max(1, o.repeats); ++k) {
            r = render(w, c, o.width, o.height, o.threads);
            times.push_back(r.seconds);
        }
        std::sort(times.begin(), times.end());
        const double secs = times[times.size() / 2];
        const Errors e = errors(r.image, ref);
        std::string row = fmt::format("{:<22} {:<13} {:<22} {:>7} {:>6} {:>9.3f} {:>10} {:>9.5f} {:>9.5f} {:>9.5f}\n",
                                      name, c.study, c.label, fmt::format("{:g}", c.param), c.spp, secs,
                                      r.samples, e.image, e.shadow, e.image_db);
        if (mpi.size == 1) {
            std::fputs(row.c_str(), stdout);
            std::fflush(stdout);
        }
        row += fmt::format("{},{},{},{},{},{},{},{:.3f},{},{},{},{:.5f},{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.2f}\n",
                           name, c.study, c.label, c.param, c.spp, c.is.light_samples, c.is.max_depth,
                           c.is.rr_continue, c.is.hemisphere ? 1 : 0, c.backend, c.adaptive_tol, secs,
                           r.samples, e.image, e.shadow, e.image_db, e.shadow_db, floor.image, floor.shadow,
                           w.build_ms[c.backend]);
        rows.push_back(std::move(row));
    }
    return rows;
}

/// One scene: its reference, every study's points, and their rows (gathered on rank 0,
/// which prints them under mpirun and appends them to the CSV).
void run_scene(const std::string& path, const Options& o, const IntegratorSettings& base, bool have_embree,
               const dist::World& mpi, std::ofstream& csv) {
    World w;
    setup_world(w, path, o);
    const std::string name = std::filesystem::path(path).stem().string();
    const Reference ref = make_reference(w, name, o, base, mpi);
    const NoiseFloor floor = noise_floor(ref, name, mpi);
    std::vector<Config> configs = make_configs(o, base, have_embree);
    const std::vector<std::string> rows = run_configs(w, configs, ref, floor, name, o, mpi);
    for (const std::string& row : dist::gather(mpi, rows, configs.size())) {
        const size_t nl = row.find('\n');
        if (mpi.size > 1) std::fputs(row.substr(0, nl + 1).c_str(), stdout);
        if (csv.is_open()) csv << row.substr(nl + 1);
    }
    std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Speed-accuracy study: error against a high-sample reference versus wall time, per knob."};
    Options o;
    add_options(app, o);
    tools::parse_or_exit(app, argc, argv, "tradeoff");
    const dist::World mpi = dist::init(argc, argv, "tradeoff");
    finish_options(o);
    const auto available = accel::available_backends();
    const bool have_embree = std::find(available.begin(), available.end(), "embree") != available.end();
    const IntegratorSettings base = baseline();

    std::ofstream csv;
    if (!o.csv_path.empty() && mpi.root()) {
        csv.open(o.csv_path + ".tmp");
        csv << "scene,study,label,param,spp,light_samples,max_depth,rr,hemisphere,backend,adaptive_tol,seconds,"
               "samples,rel_rmse,rel_rmse_shadow,rel_rmse_debiased,rel_rmse_shadow_debiased,ref_floor,"
               "ref_floor_shadow,build_ms\n";
    }
    if (mpi.root())
        std::printf("%-22s %-13s %-22s %7s %6s %9s %10s %9s %9s %9s\n", "scene", "study", "label", "param", "spp",
                    "seconds", "samples", "rel_rmse", "shadow", "debiased");
    for (const std::string& path : o.scene_paths) run_scene(path, o, base, have_embree, mpi, csv);
    if (csv.is_open()) {
        csv.close();
        if (!csv) fail(o.csv_path + ": write failed");
        std::filesystem::rename(o.csv_path + ".tmp", o.csv_path);
        std::printf("wrote %s\n", o.csv_path.c_str());
    }
    dist::finalize();
    return 0;
}
