// accel_bench: build time, memory and Mrays/s of every backend on the same ray sets,
// each row with its ratio to Embree measured side by side in the same run.
//
// By default it prints what a reader needs: the table, then one thread-scaling line per
// cell. How each figure was measured (every round, the machine probe's readings, the
// CPUs' speeds alone) is printed with --verbose, and the probe's figures are in --csv.
// main reads as the run goes: options (Options), then per scene its backends
// (run_scene) and per ray kind its study (run_study: cells timed round by round).
#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "benchmarks/machine_probe.h"
#include "benchmarks/scaling.h"
#include "benchmarks/pin.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>
#include <sstream>
#include <thread>

#include <sys/resource.h>

#include "accel/bvh/bvh.h"
#include "renderer/backend_spec.h"
#include "renderer/camera.h"
#include "renderer/integrators/normals.h"
#include "renderer/ray_record.h"
#include "renderer/raysets.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "renderer/xcheck.h"
#include "scenes/load.h"
#include "tools/cli.h"
#include "tools/memory/memory.h"

namespace {

using Clock = std::chrono::steady_clock;
/// --wait-for-cores: the share of its best issue rate each CPU must show (machine_probe.h).
/// The slow state costs a full-width loop 23-29 % (accel/DECISIONS.md, "sibling thread's
/// cost"); readings of an idle core scatter by a few percent.
constexpr double kFullIssue = 0.9;
/// --wait-for-cores: how many times a round that ended below full issue is timed again.
constexpr int kRetimes = 2;

[[noreturn]] void fail(const std::string& m) { tools::fail("accel_bench", m); }

struct Row {
    std::string scene;
    uint64_t triangles;
    std::string backend, kernel, kind;
    int threads;
    double mrays, ratio = 0, tests_per_ray, nodes_per_ray, build_ms;
    uint64_t bytes;
    bool counts_prims, counts_nodes;
    double cpu_util = 0;  ///< process CPU seconds / wall seconds while tracing
    /// Rows of several threads: the machine's own scaling beside them (MachineProbe,
    /// median over rounds), the rounds in which it reached 0.9 x threads, and this
    /// backend's scaling over 1 thread in those rounds alone (0 if none).
    double machine = 0;
    int full_rounds = 0;
    double scaling_full = 0;
    /// Rows of several threads, traced pinned: per round, the rate over the sum of the
    /// rates one thread reached alone on each CPU used (bench::efficiency_over_cpus_alone).
    double efficiency = 0;
};

using bench::median;

/// User + system CPU seconds of the whole process so far.
double cpu_seconds() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

/// Returns once `threads` threads of the current arena have each run a task (or after
/// 50 ms, so a worker that never comes cannot hang the benchmark).
void join_all(int threads) {
    std::atomic<int> arrived{0};
    tbb::parallel_for(
        0, threads, 1,
        [&](int) {
            arrived.fetch_add(1);
            const auto limit = Clock::now() + std::chrono::milliseconds(50);
            while (arrived.load() < threads && Clock::now() < limit) {
            }
        },
        tbb::simple_partitioner());
}

/// Median Mrays/s over `repeats` traces of `set` with `threads` threads. `cpu_util` gets
/// the CPU time the process obtained per wall second over all repeats: on a shared
/// machine, 2 threads that only get ~1.2 CPUs cannot scale 1.8x, and this says so.
double measure(const accel::Accelerator& a, const renderer::RaySet& set, int threads, int repeats,
               accel::TraceStats& stats, double& cpu_util, bool pin, int first_cpu = 0) {
    std::vector<double> rates;
    double wall = 0, cpu = 0;
    tbb::task_arena arena(threads);
    bench::PinArena pinned(arena, pin, first_cpu);
    // The results land in an array allocated and cleared before the clock starts
    // (renderer::trace_set_into): both backends' work, not the harness's, is timed.
    std::vector<renderer::RayOutcome> out(set.rays.size());
    for (int r = 0; r < repeats; ++r) {
        accel::TraceStats st;
        st.counting = stats.counting;
        double s = 0;
        arena.execute([&] {
            // The arena's other threads join before the clock starts, so a worker's
            // wake-up is not timed (measured on the 2-vCPU CI machine: ~20 us when
            // quiet, past 50 ms when another process holds the worker's CPU; a 2-thread
            // trace of a course mesh lasts 4-10 ms).
            if (threads > 1) join_all(threads);
            const double c0 = cpu_seconds();
            const auto t0 = Clock::now();
            renderer::trace_set_into(a, set, st, out);
            s = std::chrono::duration<double>(Clock::now() - t0).count();
            cpu += cpu_seconds() - c0;
        });
        rates.push_back(double(set.rays.size()) / std::max(s, 1e-9) / 1e6);
        wall += s;
        if (r == 0) stats = st;
    }
    cpu_util = cpu / std::max(wall, 1e-9);
    return median(rates);
}

/// Build time alone at each thread count: rounds of (threads, backend) cells, so the
/// machine's drift spreads over all cells; the median per cell is printed with the CPUs
/// the builds obtained (process CPU seconds / wall seconds), and its ratio to
/// embree:high's at the same thread count.
/// With `verbose`, each build's time goes to stderr as it is taken.
void build_study(const std::string& name, const renderer::SceneGeometry& geometry,
                 const std::vector<renderer::BackendSpec>& specs, const std::vector<int>& threads, int rounds,
                 bool verbose) {
    struct Cell {
        int threads;
        size_t spec;
        std::vector<double> ms;
        double wall = 0, cpu = 0;
    };
    std::vector<Cell> cells;
    for (int t : threads)
        for (size_t i = 0; i < specs.size(); ++i) cells.push_back({t, i, {}, 0, 0});
    for (int r = 0; r < rounds; ++r)
        for (Cell& c : cells) {
            accel::AccelOptions o = specs[c.spec].options;
            o.build_threads = c.threads;
            const double cpu0 = cpu_seconds();
            const auto t0 = Clock::now();
            auto a = renderer::build_accelerator(specs[c.spec].backend, geometry, o, false);
            const double s = std::chrono::duration<double>(Clock::now() - t0).count();
            c.cpu += cpu_seconds() - cpu0;
            c.wall += s;
            c.ms.push_back(1e3 * s);
            if (verbose)
                std::fprintf(stderr, "[accel_bench] %s build %s, %d threads, round %d: %.1f ms\n", name.c_str(),
                             specs[c.spec].label.c_str(), c.threads, r + 1, 1e3 * s);
        }
    std::printf("build study: %s (median of %d builds per cell; threads 0 = all cores)\n", name.c_str(), rounds);
    std::printf("  %-24s %7s %10s %6s %18s\n", "backend", "threads", "build ms", "cpus", "vs embree:high");
    for (Cell& c : cells) {
        const double med = median(c.ms);
        double ref = 0;
        for (Cell& e : cells)
            if (e.threads == c.threads && specs[e.spec].label == "embree:high") ref = median(e.ms);
        std::printf("  %-24s %7d %10.1f %6.2f %18s\n", specs[c.spec].label.c_str(), c.threads, med,
                    c.cpu / std::max(c.wall, 1e-9), ref > 0 ? fmt::format("{:.2f}x", med / ref).c_str() : "-");
    }
    std::fflush(stdout);
}

/// The course write-ups' comparison: cow at 800x600, 1 spp, normal shading, without and
/// with a BVH, printed with the course's lines.
void course_comparison(const std::string& path, int w, int h) {
    scenes::Scene scene = scenes::load_scene(path);
    renderer::SceneGeometry geometry(scene);
    renderer::NormalsIntegrator integrator(scene, geometry);
    auto cam = renderer::make_camera(scene, renderer::CameraMode::Auto, w, h);
    for (const char* backend : {"naive", "custom"}) {
        std::printf("[PathTracer] %s (%s)\n", backend == std::string("naive") ? "Without BVH" : "With BVH",
                    backend);
        std::fflush(stdout);
        auto accel = renderer::build_accelerator(backend, geometry, {}, true);
        renderer::RenderSettings rs;
        rs.width = w;
        rs.height = h;
        rs.progress = false;
        auto r = renderer::render(cam.camera, integrator, *accel, rs);
        std::printf("[PathTracer] Rendering... 100%%! (%.4fs)\n", r.seconds);
        std::printf("[PathTracer] BVH traced %llu rays.\n", (unsigned long long)r.stats.total_rays());
        std::printf("[PathTracer] Averaged %.6f intersection tests per ray.\n", r.stats.tests_per_ray());
    }
}

/// Every option, as CLI11 fills it, and what finish_options derives from them.
struct Options {
    std::vector<std::string> scene_paths;
    std::string csv_path, backends_arg, kinds_arg = "camera,shadow,diffuse";
    size_t rays = 200000;
    int repeats = 3, build_repeats = 1;
    bool quick = false, no_course = false, no_pin = false, verbose = false;
    std::vector<int> thread_counts, build_threads;
    std::string isa_arg = "auto", nodes_arg = "auto";
    std::string instancing = "auto";
    std::string record_path;
    double wait_for_cores = 0;
    // Derived.
    bool pin = true;
    std::vector<renderer::RayKind> kinds;
    int max_threads = 1;
};

const std::string kShared = std::string(PT_SOURCE_DIR_BENCH) + "/../shared/scenes/cs184/";

void add_options(CLI::App& app, Options& o) {
    app.add_option("--scene", o.scene_paths, "Scene file (repeatable; default: the shared cow, CBbunny, "
                                             "maxplanck and the default scene)");
    app.add_option("--csv", o.csv_path, "Also write the rows as CSV (with the machine probe's columns)");
    app.add_option("--backends", o.backends_arg,
                   "Backends (default: naive up to 10k triangles, custom:midpoint, custom:sah, embree:high, "
                   "embree:high:count)");
    app.add_option("--kinds", o.kinds_arg, "Ray kinds (default camera,shadow,diffuse; also random, edge-vertex, "
                                           "grazing, and render-closest, render-shadow with --ray-record)");
    app.add_option("--ray-record", o.record_path,
                   "A render's own rays (pathtracer --record-rays FILE, same scene) for the kinds render-closest "
                   "(its closest-hit rays) and render-shadow (its any-hit rays), the first --rays of each");
    app.add_option("--rays", o.rays, "Rays per kind (default 200000)");
    app.add_option("--repeats", o.repeats, "Timed repeats; the median is reported (default 3)");
    app.add_option("--build-repeats", o.build_repeats, "Builds per backend; the median time is reported (default 1)");
    app.add_option("--threads", o.thread_counts, "Thread counts (default: 1 and all cores)");
    app.add_option("--build-threads", o.build_threads,
                   "Also time the builds alone at these thread counts (0 = all cores), every backend "
                   "interleaved in each of --build-repeats rounds, with the CPUs each build obtained");
    app.add_option("--isa", o.isa_arg, "Kernel of custom backends that name none: auto | sse2 | avx2 | avx512 "
                                       "(or name it per backend: custom:sah:sse2)")
        ->check(CLI::IsMember({"auto", "sse2", "avx2", "avx512"}));
    app.add_option("--nodes", o.nodes_arg, "Node layout of custom backends that name none: auto (quantized from 4M primitives) | float | quantized "
                                           "(or per backend: custom:sah:quantized)")
        ->check(CLI::IsMember({"auto", "float", "quantized"}));
    app.add_option("--instancing", o.instancing,
                   "auto: instances go to the backends as the file places them (two levels); flatten: world-space "
                   "copies, for the comparison")
        ->check(CLI::IsMember({"auto", "flatten"}));
    app.add_flag("--quick", o.quick, "Smoke run: 5000 rays, 1 repeat, default scene only unless --scene");
    app.add_flag("--no-pin", o.no_pin, "Leave the timed threads unpinned (default: thread i of a timed arena runs on "
                                       "the i-th CPU this process may use)");
    app.add_flag("--no-course", o.no_course, "Skip the course's with/without-BVH comparison on cow");
    app.add_option("--wait-for-cores", o.wait_for_cores,
                   "Before each trace of a study with N > 1 threads (its 1-thread traces too), wait up to "
                   "SECONDS for the machine probe to read >= 0.9 N (the host giving N cores) and each of "
                   "the N CPUs to issue instructions at >= 0.9 of the best rate it has shown (no other "
                   "thread on its core; default 0: time at once); a round after which some CPU issues "
                   "below that is timed again, at most twice. Rows report the median of the kept rounds; "
                   "with --verbose, stderr shows the rounds timed again")
        ->check(CLI::Range(0.0, 60.0));
    app.add_flag("--verbose", o.verbose,
                 "Also show how each figure was measured: every round of every cell on stderr (its rate, "
                 "the machine probe's reading, the CPUs' issue rates under --wait-for-cores), the build "
                 "rounds of --build-threads, and after each scaling line the CPUs' speeds alone, the "
                 "per-round efficiency and the machine probe's scaling (these last also in --csv)");
}

/// --quick's sizes, the default scenes and thread counts, and the ray kinds.
void finish_options(Options& o) {
    o.pin = !o.no_pin;
    if (o.quick) {
        o.rays = std::min<size_t>(o.rays, 5000);
        o.repeats = 1;
    }
    if (o.scene_paths.empty()) {
        o.scene_paths.push_back(std::string(PT_SOURCE_DIR_BENCH) + "/scenes/cornell.dae");
        if (!o.quick)
            for (const char* f : {"cow.dae", "CBbunny.dae", "maxplanck.dae"})
                if (std::filesystem::exists(kShared + f)) o.scene_paths.push_back(kShared + f);
    }
    if (o.thread_counts.empty()) {
        o.thread_counts = {1};
        const int all = int(std::max(1u, std::thread::hardware_concurrency()));
        if (all > 1) o.thread_counts.push_back(all);
    }
    std::stringstream ss(o.kinds_arg);
    for (std::string k; std::getline(ss, k, ',');) {
        renderer::RayKind kind;
        if (!renderer::parse_ray_kind(k, kind)) fail("--kinds: unknown ray kind '" + k + "'");
        o.kinds.push_back(kind);
    }
    o.max_threads = *std::max_element(o.thread_counts.begin(), o.thread_counts.end());
}

/// (scene, backend, kind) -> Mrays/s of one thread alone on the 2nd, 3rd, ... CPU.
using Alone = std::map<std::tuple<std::string, std::string, std::string>, std::vector<double>>;

/// What the whole run has measured so far.
struct Results {
    std::vector<Row> rows;
    Alone alone;
};

/// One timed cell of a study: a backend at a thread count (or one thread alone on
/// another CPU), its rate per round.
struct Cell {
    int threads;
    size_t backend;
    std::vector<double> rates;
    double wall = 0, cpu = 0;
    accel::TraceStats stats;
    int first_cpu = 0;            ///< > 0: one thread alone on that CPU (see Alone)
    std::vector<double> machine;  ///< per round, in a study of several threads: MachineProbe
};

/// A scene's backends, built, and the median time of their builds.
struct Built {
    std::vector<renderer::BackendSpec> specs;
    std::vector<std::unique_ptr<accel::Accelerator>> accels;
    std::vector<double> build_ms;
};

/// One study: a scene's ray set, traced by every cell, round after round.
struct Study {
    const Options& o;
    const bench::MachineProbe& probe;
    const std::string& name;  ///< the scene's file name
    uint64_t triangles;
    renderer::RayKind kind;
    const Built& built;
    const renderer::RaySet& set;
};

/// The backends of a scene: --backends, or the default list (naive on small scenes only).
std::vector<renderer::BackendSpec> backend_specs(const Options& o, uint64_t tris) {
    const auto available = accel::available_backends();
    const bool have_embree = std::find(available.begin(), available.end(), "embree") != available.end();
    std::string list = o.backends_arg;
    if (list.empty()) {
        list = "custom:midpoint,custom:sah";
        if (have_embree) list += ",embree:high,embree:high:count";
        if (tris <= 10000) list = "naive," + list;
    }
    std::vector<renderer::BackendSpec> specs;
    try {
        specs = renderer::parse_backend_specs(list, o.isa_arg, o.nodes_arg);
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    return specs;
}

/// Builds every backend --build-repeats times; the median time is kept, and the last
/// build for tracing (a single build on a shared machine can be off by tens of percent).
Built build_backends(std::vector<renderer::BackendSpec> specs, const renderer::SceneGeometry& geometry,
                     int build_repeats) {
    Built b;
    b.specs = std::move(specs);
    for (const auto& s : b.specs) {
        std::vector<double> times;
        std::unique_ptr<accel::Accelerator> a;
        for (int k = 0; k < std::max(1, build_repeats); ++k) {
            a.reset();  // free the previous build first, so peak memory stays one BVH
            const auto t0 = Clock::now();
            a = renderer::build_accelerator(s.backend, geometry, s.options, false);
            times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        }
        b.accels.push_back(std::move(a));
        b.build_ms.push_back(median(times));
    }
    return b;
}

/// Every (threads, backend) cell of a study. Naive only for the single-threaded camera
/// rays: enough to show its cost.
std::vector<Cell> make_cells(const Options& o, const Built& b, renderer::RayKind kind) {
    std::vector<Cell> cells;
    for (int threads : o.thread_counts)
        for (size_t i = 0; i < b.accels.size(); ++i)
            if (b.specs[i].backend != "naive" || (threads == 1 && kind == renderer::RayKind::Camera))
                cells.push_back({threads, i, {}, 0, 0, {}, 0, {}});
    // With several threads, one thread alone on each further CPU they use, too: on a
    // shared host one vCPU can run a kernel much slower than another (its core's other
    // hardware thread busy), so N threads are set against the sum of the N CPUs alone as
    // well as N times the first.
    if (o.pin)
        for (int cpu = 1; cpu < std::min(o.max_threads, bench::usable_cpus()); ++cpu)
            for (size_t i = 0; i < b.accels.size(); ++i)
                if (b.specs[i].backend != "naive") cells.push_back({1, i, {}, 0, 0, {}, cpu, {}});
    return cells;
}

/// What the machine probe read around one round (--wait-for-cores fills the issue rates).
struct RoundProbe {
    double before = 0;
    std::vector<double> issue, after;
    bool timed_out = false;            ///< timed anyway, on fewer or narrower cores
    std::vector<std::string> narrow;   ///< the readings of each attempt that failed the check
};

/// Reads the probe before a trace; with --wait-for-cores, waits (within its limit) for
/// `probed` cores of full width. On a shared host the machine gives N cores or fewer from
/// one second to the next, and a core's other hardware thread may be another tenant's
/// (machine_probe.h).
void wait_for_cores(const bench::MachineProbe& probe, int probed, double seconds, RoundProbe& p) {
    p.before = probed > 0 ? probe.scaling(probed) : 0.0;
    if (!(probed > 0 && seconds > 0)) return;
    const auto limit = Clock::now() + std::chrono::duration<double>(seconds);
    bool full = probe.full_issue(probed, kFullIssue, &p.issue);
    while ((p.before < 0.9 * probed || !full) && Clock::now() < limit) {
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        p.before = probe.scaling(probed);
        full = probe.full_issue(probed, kFullIssue, &p.issue);
    }
    p.timed_out = p.before < 0.9 * probed || !full;
}

/// --verbose: a round's line on stderr, after those of the attempts timed again.
void print_round(const Study& s, const Cell& c, int round, double mr, const std::vector<double>& discarded,
                 const RoundProbe& p, bool probed) {
    const std::string label = fmt::format(
        "[accel_bench] {} {} {}, {} thread{}{}, round {}", s.name, renderer::ray_kind_name(s.kind),
        s.built.specs[c.backend].label, c.threads, c.threads > 1 ? "s" : "",
        c.first_cpu > 0 ? fmt::format(" alone on CPU {}", c.first_cpu) : "", round + 1);
    for (size_t k = 0; k < discarded.size(); ++k)
        std::fprintf(stderr, "%s: %.3f Mrays/s, %s: timed again\n", label.c_str(), discarded[k], p.narrow[k].c_str());
    std::fprintf(stderr, "%s: %.3f Mrays/s%s%s%s%s%s\n", label.c_str(), mr,
                 probed ? fmt::format(", probe {:.2f}", c.machine.back()).c_str() : "",
                 p.issue.empty() ? "" : fmt::format(", issue {:.1f}", fmt::join(p.issue, "/")).c_str(),
                 p.after.empty() ? "" : fmt::format(", after {:.1f}", fmt::join(p.after, "/")).c_str(),
                 p.timed_out ? " (wait limit reached)" : "",
                 p.narrow.size() > discarded.size() ? " (below full issue after it: the last attempt, kept)" : "");
}

/// Times one round of one cell, bracketed by the machine probe.
void time_round(const Study& s, Cell& c, int round) {
    const accel::Accelerator& a = *s.built.accels[c.backend];
    if (s.built.specs[c.backend].backend == "naive" && round > 0) return;  // minutes per trace
    if (round == 0 && c.first_cpu == 0) {
        // Counts come from one untimed counting pass (it also warms the caches); the
        // timed traces run the backends' lean, uncounted path.
        tbb::task_arena arena(c.threads);
        bench::PinArena pinned(arena, s.o.pin);
        arena.execute([&] { renderer::trace_set(a, s.set, c.stats); });
    }
    accel::TraceStats st;
    st.counting = false;
    double util = 0;
    // The probe brackets the trace; the lower of the two is what the machine gave at
    // least, around it. One-thread traces are probed too when the study has several
    // threads: a lone thread whose core's other hardware thread is busy runs slower,
    // which inflates the scaling measured against it (2.2-2.5x "scalings" of course
    // meshes on the 2-vCPU CI machine; accel/DECISIONS.md, "sibling thread's cost").
    const int probed = c.threads > 1 ? c.threads : (s.o.max_threads > 1 ? s.o.max_threads : 0);
    const bool waiting = probed > 0 && s.o.wait_for_cores > 0;
    RoundProbe p;
    const auto wait = [&] { wait_for_cores(s.probe, probed, s.o.wait_for_cores, p); };
    const auto trace = [&] { return measure(a, s.set, c.threads, 1, st, util, s.o.pin, c.first_cpu); };
    // Waiting, each CPU's issue rate is read after the trace too, and a round that ended
    // on a narrower core is timed again (bench::timed_round).
    const auto full_after = [&] {
        if (!waiting) return true;
        const bool full = s.probe.full_issue(probed, kFullIssue, &p.after);
        if (!full)
            p.narrow.push_back(fmt::format("issue {:.1f}, after {:.1f}", fmt::join(p.issue, "/"), fmt::join(p.after, "/")));
        return full;
    };
    std::vector<double> discarded;
    const double mr = bench::timed_round(wait, trace, full_after, waiting ? kRetimes : 0, discarded);
    if (probed > 0) c.machine.push_back(std::min(p.before, s.probe.scaling(probed)));
    c.rates.push_back(mr);
    if (s.o.verbose) print_round(s, c, round, mr, discarded, p, probed > 0);
    const double wall = double(s.set.rays.size()) / (mr * 1e6);
    c.wall += wall;
    c.cpu += util * wall;
}

/// A row of several threads: its scaling over the rounds in which the machine gave the
/// cores, and its efficiency against the same backend's 1-thread cells on each CPU.
void add_scaling(Row& row, const Cell& c, const std::vector<Cell>& cells) {
    // The same backend's 1-thread cells: alone[k] on CPU k, round by round.
    std::vector<std::vector<double>> cpus(static_cast<size_t>(c.threads));
    const Cell* one = nullptr;
    for (const Cell& o : cells)
        if (o.threads == 1 && o.backend == c.backend && o.first_cpu < c.threads) {
            cpus[size_t(o.first_cpu)] = o.rates;
            if (o.first_cpu == 0) one = &o;
        }
    if (one && !c.machine.empty()) {
        const auto full = bench::scaling_over_full_rounds(c.rates, c.machine, one->rates, one->machine, c.threads);
        row.full_rounds = full.rounds;
        row.scaling_full = full.scaling;
    }
    const bool all = std::all_of(cpus.begin(), cpus.end(), [](const auto& v) { return !v.empty(); });
    if (all) row.efficiency = bench::efficiency_over_cpus_alone(c.rates, cpus);
}

/// The study's rows, each with its ratio to embree:high at the same thread count; the
/// cells of one thread alone on a further CPU go to `alone`.
void collect_rows(const Study& s, const std::vector<Cell>& cells, Results& res) {
    const std::string kind = renderer::ray_kind_name(s.kind);
    for (int threads : s.o.thread_counts) {
        std::map<std::string, double> rate;
        size_t first = res.rows.size();
        for (const Cell& c : cells) {
            if (c.threads != threads) continue;
            const double mr = median(c.rates);
            const renderer::BackendSpec& spec = s.built.specs[c.backend];
            if (c.first_cpu > 0) {
                res.alone[{s.name, spec.label, kind}].push_back(mr);
                continue;
            }
            const auto& info = s.built.accels[c.backend]->info();
            res.rows.push_back({s.name, s.triangles, spec.label, renderer::kernel_name(spec, info), kind, threads, mr,
                                0, c.stats.tests_per_ray(), c.stats.nodes_per_ray(), s.built.build_ms[c.backend],
                                info.bytes, info.counts_prims, info.counts_nodes, c.cpu / std::max(c.wall, 1e-9)});
            rate[spec.label] = mr;
            Row& row = res.rows.back();
            if (!c.machine.empty()) row.machine = median(c.machine);
            if (threads > 1) add_scaling(row, c, cells);
        }
        const double ref = rate.count("embree:high") ? rate["embree:high"] : 0.0;
        for (size_t r = first; r < res.rows.size(); ++r) res.rows[r].ratio = ref > 0 ? res.rows[r].mrays / ref : 0.0;
    }
}

/// One ray kind of one scene: the ray set, generated once with the first BVH-like backend
/// and traced by all, every cell timed once per round. Rounds are repeated rather than
/// each cell timed in a row: a shared machine's load drifts over minutes, and
/// interleaving spreads that drift over all cells instead of biasing whichever was
/// measured during a busy spell.
void run_study(const Options& o, const bench::MachineProbe& probe, const scenes::Scene& scene,
               const std::string& name, const Built& built, renderer::RayKind kind,
               const renderer::RayRecord* record, Results& res) {
    // What the rays meet: instanced triangles count once per placement.
    const uint64_t tris = scene.world_triangles() + scene.instanced_triangles();
    const accel::Accelerator& gen = *built.accels[std::min<size_t>(built.accels.size() - 1, tris <= 10000 ? 1 : 0)];
    renderer::RaySetOptions ro;
    ro.count = o.rays;
    ro.record = record;
    renderer::RaySet set;
    try {
        set = renderer::make_ray_set(kind, scene, gen, ro);
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    const Study s{o, probe, name, tris, kind, built, set};
    std::vector<Cell> cells = make_cells(o, built, kind);
    std::fprintf(stderr, "[accel_bench] %s %s rays: %zu cells x %d rounds\n", name.c_str(),
                 renderer::ray_kind_name(kind), cells.size(), o.repeats);
    for (int round = 0; round < std::max(1, o.repeats); ++round)
        for (Cell& c : cells) time_round(s, c, round);
    collect_rows(s, cells, res);
}

/// Every study of one scene (and the build study, with --build-threads).
void run_scene(const Options& o, const bench::MachineProbe& probe, const std::string& path, Results& res) {
    scenes::Scene scene = tools::load_scene_or_exit(path, "accel_bench");
    if (o.instancing == "flatten") {
        try {
            scenes::flatten_instances(scene);
        } catch (const scenes::SceneError& e) {
            fail(e.what());
        }
    }
    if (!scene.instances.empty())
        std::printf("%s: %llu unique triangles, %zu instances placing %llu\n", path.c_str(),
                    (unsigned long long)scene.num_triangles(), scene.instances.size(),
                    (unsigned long long)scene.instanced_triangles());
    std::vector<renderer::BackendSpec> specs =
        backend_specs(o, scene.world_triangles() + scene.instanced_triangles());
    renderer::SceneGeometry geometry(scene);
    const tools::memory::Stage stage("building the BVHs");
    const uint64_t failures = tools::memory::failures();
    const std::string name = std::filesystem::path(path).filename().string();
    if (!o.build_threads.empty())
        build_study(name, geometry, specs, o.build_threads, std::max(1, o.build_repeats), o.verbose);
    Built built;
    try {
        built = build_backends(std::move(specs), geometry, o.build_repeats);
    } catch (const accel::AccelError& e) {
        // A plugin reports its failed allocation as an error of its own.
        if (tools::memory::failures() != failures) tools::memory::out_of_memory();
        throw;
    }
    renderer::RayRecord record;
    if (!o.record_path.empty()) {
        tools::memory::set_stage("reading the ray record");
        try {
            record = renderer::read_ray_record_for(o.record_path, scene);
        } catch (const std::invalid_argument& e) {
            fail(e.what());
        }
    }
    tools::memory::set_stage("tracing the rays");
    for (renderer::RayKind kind : o.kinds)
        run_study(o, probe, scene, name, built, kind, o.record_path.empty() ? nullptr : &record, res);
}

/// The rows as CSV (plot/tables.py reads it by column name), replaced whole.
void write_csv(const std::string& csv_path, const std::vector<Row>& rows) {
    if (csv_path.empty()) return;
    const std::string tmp = csv_path + ".tmp";
    {
        std::ofstream out(tmp);
        out << "scene,triangles,backend,ray_kind,threads,mrays_per_s,ratio_to_embree,tests_per_ray,"
               "nodes_per_ray,build_ms,bytes,cpu_util,kernel,machine_scaling,full_rounds,"
               "scaling_full_rounds,efficiency_per_round\n";
        for (const Row& r : rows)
            out << fmt::format("{},{},{},{},{},{:.4f},{:.4f},{},{},{:.2f},{},{:.2f},{},{},{},{},{}\n", r.scene,
                               r.triangles, r.backend, r.kind, r.threads, r.mrays, r.ratio,
                               r.counts_prims ? fmt::format("{:.3f}", r.tests_per_ray) : "",
                               r.counts_nodes ? fmt::format("{:.3f}", r.nodes_per_ray) : "", r.build_ms,
                               r.bytes, r.cpu_util, r.kernel,
                               r.machine > 0 ? fmt::format("{:.3f}", r.machine) : "",
                               r.machine > 0 && r.threads > 1 ? std::to_string(r.full_rounds) : "",
                               r.full_rounds > 0 ? fmt::format("{:.4f}", r.scaling_full) : "",
                               r.efficiency > 0 ? fmt::format("{:.4f}", r.efficiency) : "");
        if (!out) fail(csv_path + ": write failed");
    }
    std::filesystem::rename(tmp, csv_path);
}

/// The table: one row per (scene, backend, ray kind, threads).
void print_table(const std::vector<Row>& rows) {
    // Backend, kernel and ray-kind columns, widened for long labels (plugins, a render's rays).
    int wb = 22, wk = 10, wr = 8;
    for (const Row& r : rows)
        wb = std::max(wb, int(r.backend.size())), wk = std::max(wk, int(r.kernel.size())),
        wr = std::max(wr, int(r.kind.size()));
    std::printf("%-18s %9s %-*s %-*s %-*s %3s %9s %9s %10s %10s %9s %10s %5s\n", "scene", "triangles", wb, "backend",
                wk, "kernel", wr, "rays", "thr", "Mrays/s", "vs embree", "tests/ray", "nodes/ray", "build ms", "MiB",
                "cpus");
    for (const Row& r : rows)
        std::printf("%-18s %9llu %-*s %-*s %-*s %3d %9.3f %9.3f %10s %10s %9.1f %10.2f %5.2f\n", r.scene.c_str(),
                    (unsigned long long)r.triangles, wb, r.backend.c_str(), wk, r.kernel.c_str(), wr, r.kind.c_str(),
                    r.threads,
                    r.mrays, r.ratio, r.counts_prims ? fmt::format("{:.2f}", r.tests_per_ray).c_str() : "-",
                    r.counts_nodes ? fmt::format("{:.2f}", r.nodes_per_ray).c_str() : "-", r.build_ms,
                    double(r.bytes) / (1024.0 * 1024.0), r.cpu_util);
}

/// --verbose: how a scaling figure stands against the machine: each CPU alone against the
/// first and what N threads reach of their sum, the per-round efficiency, and the machine
/// probe's own scaling with this backend's over the rounds the probe gave N cores.
std::string scaling_detail(const Row& a, const Row& b, const Alone& alone, int repeats) {
    std::string sum;
    const auto it = alone.find({a.scene, a.backend, a.kind});
    if (it != alone.end() && int(it->second.size()) + 1 >= b.threads) {
        double total = a.mrays;
        std::string each = "1.00";
        for (int k = 0; k + 1 < b.threads; ++k) {
            total += it->second[size_t(k)];
            each += fmt::format("/{:.2f}", a.mrays > 0 ? it->second[size_t(k)] / a.mrays : 0.0);
        }
        sum = fmt::format("; CPUs alone {} of the first, {} threads = {:.2f} of their sum", each, b.threads,
                          total > 0 ? b.mrays / total : 0.0);
    }
    if (b.efficiency > 0)
        sum += fmt::format("; per round {:.2f} of the CPUs alone ({:.2f}x on equal CPUs)", b.efficiency,
                           b.efficiency * b.threads);
    if (b.machine > 0)
        sum += fmt::format("; machine probe {:.2f}x, {}", b.machine,
                           b.full_rounds > 0 ? fmt::format("{:.2f}x in the {} of {} rounds it reached {:.2f}",
                                                           b.scaling_full, b.full_rounds, std::max(1, repeats),
                                                           0.9 * b.threads)
                                             : fmt::format("no round reached {:.2f}", 0.9 * b.threads));
    return sum;
}

/// One line per (scene, backend, ray kind) measured at 1 thread and more: throughput with
/// the most threads over one thread, and the build time over Embree high's.
void print_scaling(const Results& res, const Options& o) {
    std::printf("\nthread scaling (Mrays/s with the most threads / with 1 thread) and build time / embree:high\n");
    for (const Row& a : res.rows) {
        if (a.threads != 1) continue;
        const Row* b = nullptr;
        for (const Row& r : res.rows)
            if (r.scene == a.scene && r.backend == a.backend && r.kind == a.kind && r.threads > 1 &&
                (!b || r.threads > b->threads))
                b = &r;
        double embree_build = 0;
        for (const Row& r : res.rows)
            if (r.scene == a.scene && r.backend == "embree:high") embree_build = r.build_ms;
        if (!b) continue;
        const std::string detail = o.verbose ? scaling_detail(a, *b, res.alone, o.repeats) : "";
        std::printf("  %-18s %-22s %-8s %d threads: %.2fx (%.2f CPUs obtained%s)   build %.2fx embree:high\n",
                    a.scene.c_str(), a.backend.c_str(), a.kind.c_str(), b->threads,
                    a.mrays > 0 ? b->mrays / a.mrays : 0.0, b->cpu_util, detail.c_str(),
                    embree_build > 0 ? a.build_ms / embree_build : 0.0);
    }
}

}  // namespace

int main(int argc, char** argv) try {
    tools::memory::install("accel_bench");
    CLI::App app{"Accelerator benchmark: every backend on the very same camera, shadow and diffuse rays."};
    Options o;
    add_options(app, o);
    tools::parse_or_exit(app, argc, argv, "accel_bench");
    finish_options(o);
    const bench::MachineProbe probe(o.pin);
    Results res;
    for (const std::string& path : o.scene_paths) {
        run_scene(o, probe, path, res);
        write_csv(o.csv_path, res.rows);  // after every scene: a long run that is stopped keeps what it measured
    }
    print_table(res.rows);
    print_scaling(res, o);
    if (!o.csv_path.empty()) std::printf("wrote %s\n", o.csv_path.c_str());
    if (!o.no_course && !o.quick && std::filesystem::exists(kShared + "cow.dae"))
        course_comparison(kShared + "cow.dae", 800, 600);
    return 0;
} catch (const std::bad_alloc& e) {
    tools::memory::out_of_memory(e);
}
