// accel_bench: build time, memory and Mrays/s of every backend on the same ray sets,
// each row with its ratio to Embree measured side by side in the same run.
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
#include "renderer/raysets.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "renderer/xcheck.h"
#include "scenes/load.h"
#include "tools/cli.h"

namespace {

using Clock = std::chrono::steady_clock;
/// --wait-for-cores: the share of its best issue rate each CPU must show (machine_probe.h).
/// The slow state costs a full-width loop 23-29 % (session 13); readings of an idle core
/// scatter by a few percent.
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
            // wake-up is not timed (measured in session 11: ~20 us on a quiet machine,
            // past 50 ms when another process holds the worker's CPU; a 2-thread trace
            // of a course mesh lasts 4-10 ms).
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
void build_study(const std::string& name, const renderer::SceneGeometry& geometry,
                 const std::vector<renderer::BackendSpec>& specs, const std::vector<int>& threads, int rounds) {
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

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Accelerator benchmark: every backend on the very same camera, shadow and diffuse rays."};
    std::vector<std::string> scene_paths;
    std::string csv_path, backends_arg, kinds_arg = "camera,shadow,diffuse";
    size_t rays = 200000;
    int repeats = 3, build_repeats = 1;
    bool quick = false, no_course = false;
    std::vector<int> thread_counts;
    const std::string shared = std::string(PT_SOURCE_DIR_BENCH) + "/../shared/scenes/cs184/";
    app.add_option("--scene", scene_paths, "Scene file (repeatable; default: the shared cow, CBbunny, "
                                           "maxplanck and the default scene)");
    app.add_option("--csv", csv_path, "Also write the rows as CSV");
    app.add_option("--backends", backends_arg,
                   "Backends (default: naive up to 10k triangles, custom:midpoint, custom:sah, embree:high, "
                   "embree:high:count)");
    app.add_option("--kinds", kinds_arg, "Ray kinds (default camera,shadow,diffuse)");
    app.add_option("--rays", rays, "Rays per kind (default 200000)");
    app.add_option("--repeats", repeats, "Timed repeats; the median is reported (default 3)");
    app.add_option("--build-repeats", build_repeats, "Builds per backend; the median time is reported (default 1)");
    app.add_option("--threads", thread_counts, "Thread counts (default: 1 and all cores)");
    std::vector<int> build_threads;
    app.add_option("--build-threads", build_threads,
                   "Also time the builds alone at these thread counts (0 = all cores), every backend "
                   "interleaved in each of --build-repeats rounds, with the CPUs each build obtained");
    std::string isa_arg = "auto";
    app.add_option("--isa", isa_arg, "Kernel of custom backends that name none: auto | sse2 | avx2 | avx512 "
                                     "(or name it per backend: custom:sah:sse2)")
        ->check(CLI::IsMember({"auto", "sse2", "avx2", "avx512"}));
    std::string nodes_arg = "auto";
    app.add_option("--nodes", nodes_arg, "Node layout of custom backends that name none: auto (quantized from 4M primitives) | float | quantized "
                                         "(or per backend: custom:sah:quantized)")
        ->check(CLI::IsMember({"auto", "float", "quantized"}));
    app.add_flag("--quick", quick, "Smoke run: 5000 rays, 1 repeat, default scene only unless --scene");
    bool no_pin = false;
    app.add_flag("--no-pin", no_pin, "Leave the timed threads unpinned (default: thread i of a timed arena runs on "
                                     "the i-th CPU this process may use)");
    app.add_flag("--no-course", no_course, "Skip the course's with/without-BVH comparison on cow");
    double wait_for_cores = 0;
    app.add_option("--wait-for-cores", wait_for_cores,
                   "Before each trace of a study with N > 1 threads (its 1-thread traces too), wait up to "
                   "SECONDS for the machine probe to read >= 0.9 N (the host giving N cores) and each of "
                   "the N CPUs to issue instructions at >= 0.9 of the best rate it has shown (no other "
                   "thread on its core; default 0: time at once); a round after which some CPU issues "
                   "below that is timed again, at most twice. Rows report the median of the kept rounds; "
                   "stderr shows the rounds timed again")
        ->check(CLI::Range(0.0, 60.0));
    tools::parse_or_exit(app, argc, argv, "accel_bench");
    const bool pin = !no_pin;
    if (quick) {
        rays = std::min<size_t>(rays, 5000);
        repeats = 1;
    }
    if (scene_paths.empty()) {
        scene_paths.push_back(std::string(PT_SOURCE_DIR_BENCH) + "/scenes/cornell.dae");
        if (!quick)
            for (const char* f : {"cow.dae", "CBbunny.dae", "maxplanck.dae"})
                if (std::filesystem::exists(shared + f)) scene_paths.push_back(shared + f);
    }
    if (thread_counts.empty()) {
        thread_counts = {1};
        const int all = int(std::max(1u, std::thread::hardware_concurrency()));
        if (all > 1) thread_counts.push_back(all);
    }
    std::vector<renderer::RayKind> kinds;
    {
        std::stringstream ss(kinds_arg);
        for (std::string k; std::getline(ss, k, ',');) {
            renderer::RayKind kind;
            if (!renderer::parse_ray_kind(k, kind)) fail("--kinds: unknown ray kind '" + k + "'");
            kinds.push_back(kind);
        }
    }
    const auto available = accel::available_backends();
    const bool have_embree = std::find(available.begin(), available.end(), "embree") != available.end();

    std::vector<Row> rows;
    const int max_threads = *std::max_element(thread_counts.begin(), thread_counts.end());
    const bench::MachineProbe probe(pin);
    /// (scene, backend, kind) -> Mrays/s of one thread alone on the 2nd, 3rd, ... CPU.
    std::map<std::tuple<std::string, std::string, std::string>, std::vector<double>> alone;
    // Rewritten after every scene, so a long run that is stopped keeps what it measured.
    auto write_csv = [&] {
        if (!csv_path.empty()) {
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
    };
    for (const std::string& path : scene_paths) {
        scenes::Scene scene;
        try {
            scene = scenes::load_scene(path);
        } catch (const scenes::SceneError& e) {
            fail(e.what());
        }
        const uint64_t tris = scene.num_triangles();
        std::string list = backends_arg;
        if (list.empty()) {
            list = "custom:midpoint,custom:sah";
            if (have_embree) list += ",embree:high,embree:high:count";
            if (tris <= 10000) list = "naive," + list;
        }
        std::vector<renderer::BackendSpec> specs;
        try {
            specs = renderer::parse_backend_specs(list);
            accel::Isa isa = accel::Isa::Auto;
            accel::parse_isa(isa_arg, isa);
            renderer::apply_isa(specs, isa);
            accel::NodeLayout layout = accel::NodeLayout::Auto;
            accel::parse_layout(nodes_arg, layout);
            renderer::apply_layout(specs, layout);
        } catch (const std::invalid_argument& e) {
            fail(e.what());
        }
        renderer::SceneGeometry geometry(scene);
        if (!build_threads.empty()) build_study(std::filesystem::path(path).filename().string(), geometry, specs,
                                                build_threads, std::max(1, build_repeats));
        std::vector<std::unique_ptr<accel::Accelerator>> accels;
        std::vector<double> build_ms;
        for (const auto& s : specs) {
            // Median of --build-repeats builds (the last one is kept for tracing): a single
            // build on a shared machine can be off by tens of percent.
            std::vector<double> times;
            std::unique_ptr<accel::Accelerator> a;
            for (int k = 0; k < std::max(1, build_repeats); ++k) {
                a.reset();  // free the previous build first, so peak memory stays one BVH
                const auto t0 = Clock::now();
                a = renderer::build_accelerator(s.backend, geometry, s.options, false);
                times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
            }
            accels.push_back(std::move(a));
            build_ms.push_back(median(times));
        }
        // The ray sets, generated once with the first BVH-like backend, traced by all.
        const accel::Accelerator& gen = *accels[std::min<size_t>(accels.size() - 1, tris <= 10000 ? 1 : 0)];
        const std::string name = std::filesystem::path(path).filename().string();
        for (renderer::RayKind kind : kinds) {
            renderer::RaySetOptions ro;
            ro.count = rays;
            const renderer::RaySet set = renderer::make_ray_set(kind, scene, gen, ro);
            // Every (threads, backend) cell is timed once per round, rounds repeated: a
            // shared machine's load drifts over minutes, and interleaving spreads that drift
            // over all cells instead of biasing whichever was measured during a busy spell.
            struct Cell {
                int threads;
                size_t backend;
                std::vector<double> rates;
                double wall = 0, cpu = 0;
                accel::TraceStats stats;
                int first_cpu = 0;  ///< > 0: one thread alone on that CPU (see `alone`)
                std::vector<double> machine;  ///< per round, in a study of several threads: MachineProbe
            };
            std::vector<Cell> cells;
            for (int threads : thread_counts)
                for (size_t i = 0; i < accels.size(); ++i)
                    // Naive only for the single-threaded camera rays: enough to show its cost.
                    if (specs[i].backend != "naive" || (threads == 1 && kind == renderer::RayKind::Camera))
                        cells.push_back({threads, i, {}, 0, 0, {}, 0, {}});
            // With several threads, one thread alone on each further CPU they use, too:
            // on a shared host one vCPU can run a kernel much slower than another (its
            // core's other hardware thread busy), so N threads are set against the sum of
            // the N CPUs alone as well as N times the first.
            if (pin)
                for (int cpu = 1; cpu < std::min(max_threads, bench::usable_cpus()); ++cpu)
                    for (size_t i = 0; i < accels.size(); ++i)
                        if (specs[i].backend != "naive") cells.push_back({1, i, {}, 0, 0, {}, cpu, {}});
            std::fprintf(stderr, "[accel_bench] %s %s rays: %zu cells x %d rounds\n", name.c_str(),
                         renderer::ray_kind_name(kind), cells.size(), repeats);
            for (int round = 0; round < std::max(1, repeats); ++round)
                for (Cell& c : cells) {
                    if (specs[c.backend].backend == "naive" && round > 0) continue;  // minutes per trace
                    if (round == 0 && c.first_cpu == 0) {
                        // Counts come from one untimed counting pass (it also warms the
                        // caches); the timed traces run the backends' lean, uncounted path.
                        tbb::task_arena arena(c.threads);
                        bench::PinArena pinned(arena, pin);
                        arena.execute([&] { renderer::trace_set(*accels[c.backend], set, c.stats); });
                    }
                    accel::TraceStats st;
                    st.counting = false;
                    double util = 0;
                    // The probe brackets the trace; the lower of the two is what the
                    // machine gave at least, around it. One-thread traces are probed too
                    // when the study has several threads: a lone thread whose core's other
                    // hardware thread is busy runs slower, which inflates the scaling
                    // measured against it (session 12: 2.2-2.5x "scalings" of course meshes).
                    const int probed = c.threads > 1 ? c.threads : (max_threads > 1 ? max_threads : 0);
                    const bool waiting = probed > 0 && wait_for_cores > 0;
                    double before = 0.0;
                    std::vector<double> issue, after;
                    bool timed_out = false;  // timed anyway, on fewer or narrower cores
                    const auto wait = [&] {
                        before = probed > 0 ? probe.scaling(probed) : 0.0;
                        if (!waiting) return;
                        // On a shared host the machine gives N cores or fewer from one
                        // second to the next, and a core's other hardware thread may be
                        // another tenant's (machine_probe.h); wait for N cores of full
                        // width, within limits.
                        const auto limit = Clock::now() + std::chrono::duration<double>(wait_for_cores);
                        bool full = probe.full_issue(probed, kFullIssue, &issue);
                        while ((before < 0.9 * probed || !full) && Clock::now() < limit) {
                            std::this_thread::sleep_for(std::chrono::milliseconds(50));
                            before = probe.scaling(probed);
                            full = probe.full_issue(probed, kFullIssue, &issue);
                        }
                        timed_out = before < 0.9 * probed || !full;
                    };
                    const std::string label = fmt::format(
                        "[accel_bench] {} {} {}, {} thread{}{}, round {}", name, renderer::ray_kind_name(kind),
                        specs[c.backend].label, c.threads, c.threads > 1 ? "s" : "",
                        c.first_cpu > 0 ? fmt::format(" alone on CPU {}", c.first_cpu) : "", round + 1);
                    const auto trace = [&] {
                        return measure(*accels[c.backend], set, c.threads, 1, st, util, pin, c.first_cpu);
                    };
                    // Waiting, each CPU's issue rate is read after the trace too, and a
                    // round that ended on a narrower core is timed again (bench::timed_round).
                    std::vector<std::string> narrow;  // the readings of each attempt that failed the check
                    const auto full_after = [&] {
                        if (!waiting) return true;
                        const bool full = probe.full_issue(probed, kFullIssue, &after);
                        if (!full)
                            narrow.push_back(fmt::format("issue {:.1f}, after {:.1f}", fmt::join(issue, "/"),
                                                         fmt::join(after, "/")));
                        return full;
                    };
                    std::vector<double> discarded;
                    const double mr = bench::timed_round(wait, trace, full_after, waiting ? kRetimes : 0, discarded);
                    for (size_t k = 0; k < discarded.size(); ++k)
                        std::fprintf(stderr, "%s: %.3f Mrays/s, %s: timed again\n", label.c_str(), discarded[k],
                                     narrow[k].c_str());
                    if (probed > 0) c.machine.push_back(std::min(before, probe.scaling(probed)));
                    c.rates.push_back(mr);
                    std::fprintf(stderr, "%s: %.3f Mrays/s%s%s%s%s%s\n", label.c_str(), mr,
                                 probed > 0 ? fmt::format(", probe {:.2f}", c.machine.back()).c_str() : "",
                                 issue.empty() ? "" : fmt::format(", issue {:.1f}", fmt::join(issue, "/")).c_str(),
                                 after.empty() ? "" : fmt::format(", after {:.1f}", fmt::join(after, "/")).c_str(),
                                 timed_out ? " (wait limit reached)" : "",
                                 narrow.size() > discarded.size() ? " (below full issue after it: the last attempt, kept)" : "");
                    const double wall = double(set.rays.size()) / (mr * 1e6);
                    c.wall += wall;
                    c.cpu += util * wall;
                }
            for (int threads : thread_counts) {
                std::map<std::string, double> rate;
                size_t first = rows.size();
                for (Cell& c : cells) {
                    if (c.threads != threads) continue;
                    const double mr = median(c.rates);
                    if (c.first_cpu > 0) {
                        alone[{name, specs[c.backend].label, renderer::ray_kind_name(kind)}].push_back(mr);
                        continue;
                    }
                    const size_t i = c.backend;
                    const auto& info = accels[i]->info();
                    rows.push_back({name, tris, specs[i].label, renderer::kernel_name(specs[i], info), renderer::ray_kind_name(kind), threads, mr, 0,
                                    c.stats.tests_per_ray(), c.stats.nodes_per_ray(), build_ms[i], info.bytes,
                                    info.counts_prims, info.counts_nodes, c.cpu / std::max(c.wall, 1e-9)});
                    rate[specs[i].label] = mr;
                    Row& row = rows.back();
                    if (!c.machine.empty()) row.machine = median(c.machine);
                    if (threads > 1) {
                        // The same backend's 1-thread cells: alone[k] on CPU k, round by round.
                        std::vector<std::vector<double>> cpus(static_cast<size_t>(threads));
                        const Cell* one = nullptr;
                        for (const Cell& o : cells)
                            if (o.threads == 1 && o.backend == c.backend && o.first_cpu < threads) {
                                cpus[size_t(o.first_cpu)] = o.rates;
                                if (o.first_cpu == 0) one = &o;
                            }
                        if (one && !c.machine.empty()) {
                            const auto full = bench::scaling_over_full_rounds(c.rates, c.machine, one->rates,
                                                                              one->machine, threads);
                            row.full_rounds = full.rounds;
                            row.scaling_full = full.scaling;
                        }
                        const bool all = std::all_of(cpus.begin(), cpus.end(), [](const auto& v) { return !v.empty(); });
                        if (all) row.efficiency = bench::efficiency_over_cpus_alone(c.rates, cpus);
                    }
                }
                const double ref = rate.count("embree:high") ? rate["embree:high"] : 0.0;
                for (size_t r = first; r < rows.size(); ++r) rows[r].ratio = ref > 0 ? rows[r].mrays / ref : 0.0;
            }
        }
        write_csv();
    }

    std::printf("%-18s %9s %-22s %-7s %-8s %3s %9s %9s %10s %10s %9s %10s %5s\n", "scene", "triangles", "backend",
                "kernel", "rays",
                "thr", "Mrays/s", "vs embree", "tests/ray", "nodes/ray", "build ms", "MiB", "cpus");
    for (const Row& r : rows)
        std::printf("%-18s %9llu %-22s %-7s %-8s %3d %9.3f %9.3f %10s %10s %9.1f %10.2f %5.2f\n", r.scene.c_str(),
                    (unsigned long long)r.triangles, r.backend.c_str(), r.kernel.c_str(), r.kind.c_str(), r.threads, r.mrays,
                    r.ratio, r.counts_prims ? fmt::format("{:.2f}", r.tests_per_ray).c_str() : "-",
                    r.counts_nodes ? fmt::format("{:.2f}", r.nodes_per_ray).c_str() : "-", r.build_ms,
                    double(r.bytes) / (1024.0 * 1024.0), r.cpu_util);
    // The two ratios the issue asks about, computed from the rows above: throughput with
    // all threads over one thread, and each BVH's build time over Embree high's.
    std::printf("\nthread scaling (Mrays/s with the most threads / with 1 thread) and build time / embree:high\n");
    for (const Row& a : rows) {
        if (a.threads != 1) continue;
        const Row* b = nullptr;
        for (const Row& r : rows)
            if (r.scene == a.scene && r.backend == a.backend && r.kind == a.kind && r.threads > 1 &&
                (!b || r.threads > b->threads))
                b = &r;
        double embree_build = 0;
        for (const Row& r : rows)
            if (r.scene == a.scene && r.backend == "embree:high") embree_build = r.build_ms;
        if (!b) continue;
        std::string sum;
        const auto it = alone.find({a.scene, a.backend, a.kind});
        if (it != alone.end() && int(it->second.size()) + 1 >= b->threads) {
            // The CPUs' own speeds: each alone against the first, and what N threads
            // reach of the sum of the N CPUs alone.
            double total = a.mrays;
            std::string each = "1.00";
            for (int k = 0; k + 1 < b->threads; ++k) {
                total += it->second[size_t(k)];
                each += fmt::format("/{:.2f}", a.mrays > 0 ? it->second[size_t(k)] / a.mrays : 0.0);
            }
            sum = fmt::format("; CPUs alone {} of the first, {} threads = {:.2f} of their sum", each, b->threads,
                              total > 0 ? b->mrays / total : 0.0);
        }
        if (b->efficiency > 0)
            sum += fmt::format("; per round {:.2f} of the CPUs alone ({:.2f}x on equal CPUs)", b->efficiency,
                               b->efficiency * b->threads);
        if (b->machine > 0)
            sum += fmt::format("; machine probe {:.2f}x, {}", b->machine,
                               b->full_rounds > 0 ? fmt::format("{:.2f}x in the {} of {} rounds it reached {:.2f}",
                                                                b->scaling_full, b->full_rounds, std::max(1, repeats),
                                                                0.9 * b->threads)
                                                  : fmt::format("no round reached {:.2f}", 0.9 * b->threads));
        std::printf("  %-18s %-22s %-8s %d threads: %.2fx (%.2f CPUs obtained%s)   build %.2fx embree:high\n",
                    a.scene.c_str(), a.backend.c_str(), a.kind.c_str(), b->threads, a.mrays > 0 ? b->mrays / a.mrays : 0.0,
                    b->cpu_util, sum.c_str(), embree_build > 0 ? a.build_ms / embree_build : 0.0);
    }
    if (!csv_path.empty()) std::printf("wrote %s\n", csv_path.c_str());
    if (!no_course && !quick && std::filesystem::exists(shared + "cow.dae")) course_comparison(shared + "cow.dae", 800, 600);
    return 0;
}
