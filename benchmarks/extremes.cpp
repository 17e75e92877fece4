// extremes: the numerical-stability sweep (leaks, acne, grazing/axis rays, t and
// barycentrics against a double-precision reference) over generated closed meshes and the
// CS184 meshes, at scales 1e-6 .. 1e7 and translations up to 1e6, for every backend and
// both ray-offset modes. The measurements live in benchmarks/extremes.h (shared with
// tests/stability/).
//
// Exit status: 0 when the custom watertight mode leaked no ray and the error-bound
// offset's false self-hit rate stayed below 1e-6 for every backend at every placement;
// 1 otherwise; 2 on bad options.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "accel/bvh/bvh.h"
#include "benchmarks/extremes.h"
#include "renderer/backend_spec.h"
#include "tools/cli.h"

using namespace extremes;

namespace {

/// Every option, as CLI11 fills it.
struct Options {
    uint64_t rays = 1000000;
    uint64_t acne = 0, ref = 0;  ///< 0: rays/5 and rays/10
    bool quick = false, no_embree = false, no_cs184 = false;
    std::string csv = "extremes.csv";
    std::string scenes_dir = std::string(PT_SOURCE_DIR_BENCH) + "/../shared/scenes/cs184";
    uint64_t seed = 8;
    std::string isa = "auto", nodes = "auto";
    std::string backends;  ///< --backends: specs replacing the default cases
    std::vector<double> only;
};

void add_options(CLI::App& app, Options& o) {
    app.add_option("--rays", o.rays,
                   "Edge-and-vertex (leak) rays per placement and backend, split over the meshes");
    app.add_option("--acne", o.acne, "Surface points per placement and backend for the acne rays (default rays/5)");
    app.add_option("--ref", o.ref, "Reference-comparison rays per placement and backend (default rays/10)");
    app.add_flag("--quick", o.quick, "Smoke run: 20000 leak rays, a reduced placement list");
    app.add_flag("--no-embree", o.no_embree, "Only the custom backends");
    app.add_option("--backends", o.backends,
                   "Backend specs to sweep instead of the default ones (custom fast and watertight, Embree, "
                   "Embree robust), e.g. custom:sah:watertight,plugin:build/plugins/libaccel_plugin_example.so");
    app.add_flag("--no-cs184", o.no_cs184, "Only the generated meshes");
    app.add_option("--scenes", o.scenes_dir, "Folder with cow.dae, teapot.dae, bunny.dae");
    app.add_option("--csv", o.csv, "CSV output (one row per placement, mesh and backend)");
    app.add_option("--seed", o.seed, "Random seed");
    app.add_option("--isa", o.isa, "Kernel of the custom backends: auto | sse2 | avx2 | avx512")
        ->check(CLI::IsMember({"auto", "sse2", "avx2", "avx512"}));
    app.add_option("--nodes", o.nodes, "Node layout of the custom backends: auto (quantized from 4M primitives) | float | quantized")
        ->check(CLI::IsMember({"auto", "float", "quantized"}));
    app.add_option("--placement", o.only, "Only this placement: SCALE OFFSET (e.g. --placement 1e3 1e6)")
        ->expected(2);
}

std::string rate(uint64_t bad, uint64_t n) {
    if (n == 0) return "n/a";
    if (bad == 0) return fmt::format("0/{:.1e}", double(n));
    return fmt::format("{:.2e}", double(bad) / double(n));
}

/// Two generated closed convex meshes, then the CS184 meshes if present.
std::vector<UnitMesh> load_meshes(const Options& o) {
    std::vector<UnitMesh> meshes = {make_icosphere(3), make_cube(8)};
    if (o.no_cs184) return meshes;
    for (const char* name : {"cow", "teapot", "bunny"}) {
        const std::string path = o.scenes_dir + "/" + name + ".dae";
        if (!std::filesystem::exists(path)) {
            std::printf("skip %s: %s not found\n", name, path.c_str());
            continue;
        }
        try {
            meshes.push_back(load_unit_mesh(path, name));
        } catch (const std::exception& e) {
            std::printf("skip %s: %s\n", name, e.what());
        }
    }
    return meshes;
}

/// Scales 1e-6 .. 1e7, each at the origin and translated far away (offset / scale up to
/// 1e4, absolute offset up to 1e6), plus s = 1 at 1e6: the unit mesh on a grid of 1/16
/// (float spacing at 1e6), where many triangles collapse.
std::vector<Placement> placements(const Options& o) {
    std::vector<Placement> places = {{1e-6, 0}, {1e-6, 1e-2}, {1e-3, 0}, {1e-3, 10},  {1, 0},    {1, 1e4},
                                     {1, 1e6},  {1e3, 0},    {1e3, 1e6}, {1e7, 0},   {1e7, 1e6}};
    if (o.quick) places = {{1e-6, 1e-2}, {1, 0}, {1, 1e6}, {1e7, 1e6}};
    if (o.only.size() == 2) {
        if (!(o.only[0] > 0) || !std::isfinite(o.only[0]) || !std::isfinite(o.only[1]))
            tools::fail("extremes", "--placement needs a positive finite scale and a finite offset");
        places = {{o.only[0], o.only[1]}};
    }
    return places;
}

/// Every backend case, the custom ones on --isa's kernel and --nodes' layout.
std::vector<BackendCase> backends(const Options& o) {
    if (!o.backends.empty()) {
        std::vector<BackendCase> cases;
        try {
            for (const renderer::BackendSpec& s : renderer::parse_backend_specs(o.backends, o.isa, o.nodes)) {
                // A plugin that cannot be loaded or built is refused now, not mid-sweep:
                // one triangle is enough to load it and run its build.
                const accel::Vec3f tri[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}};
                const uint32_t idx[3] = {0, 1, 2};
                const accel::GeometryView gv = accel::GeometryView::triangles(tri, 3, idx, 1);
                accel::create_accelerator(s.backend, std::span<const accel::GeometryView>(&gv, 1), s.options);
                cases.push_back({s.label, s.backend, s.options});
            }
        } catch (const std::invalid_argument& e) {
            tools::fail("extremes", e.what());
        } catch (const accel::AccelError& e) {
            tools::fail("extremes", e.what());
        }
        return cases;
    }
    std::vector<std::string> available = accel::available_backends();
    const bool have_embree =
        !o.no_embree && std::find(available.begin(), available.end(), "embree") != available.end();
    if (!o.no_embree && !have_embree) std::printf("embree: not in this build, skipped\n");
    std::vector<BackendCase> cases = backend_cases(have_embree);
    for (BackendCase& b : cases)
        if (b.backend == "custom") {
            accel::parse_isa(o.isa, b.options.isa);
            accel::parse_layout(o.nodes, b.options.nodes);
            if (b.options.nodes != accel::NodeLayout::Auto) b.label += std::string("-") + o.nodes;
        }
    return cases;
}

/// One CSV row per placement, mesh and backend, flushed as it comes.
class SweepCsv {
public:
    explicit SweepCsv(const std::string& path) : out_(path) {
        out_ << "scale,offset,mesh,backend,dropped,leak_rays,leaks,axis_rays,axis_leaks,vertex_rays,vertex_leaks,"
                "hemi_rays_eb,hemi_false_eb,hemi_ambiguous_eb,shadow_rays_eb,shadow_false_eb,shadow_ambiguous_eb,"
                "hemi_rays_eps,hemi_false_eps,hemi_ambiguous_eps,shadow_rays_eps,shadow_false_eps,shadow_ambiguous_eps,"
                "ref_rays,ref_compared,grazing_rays,wrong_miss,max_rel_t,max_rel_t_grazing,max_t_over_bound,max_bary\n";
    }
    void row(const Placement& pl, const std::string& mesh, const std::string& backend, const Counts& c) {
        out_ << fmt::format("{:g},{:g},{},{},{},{},{},{},{},{},{}", pl.scale, pl.offset, mesh, backend, c.dropped,
                            c.leak_rays, c.leaks, c.axis_rays, c.axis_leaks, c.vertex_rays, c.vertex_leaks);
        for (int m = 0; m < 2; ++m)
            out_ << fmt::format(",{},{},{},{},{},{}", c.hemi_rays[m], c.hemi_false[m], c.hemi_ambiguous[m],
                                c.shadow_rays[m], c.shadow_false[m], c.shadow_ambiguous[m]);
        out_ << fmt::format(",{},{},{},{},{:.3e},{:.3e},{:.3e},{:.3e}\n", c.ref_rays, c.ref_compared, c.grazing_rays,
                            c.wrong_miss, c.max_rel_t, c.max_rel_t_grazing, c.max_t_over_bound, c.max_bary);
        out_.flush();
    }

private:
    std::ofstream out_;
};

/// One backend at one placement, over every mesh: the CSV's rows and their sum.
Counts measure_placement(const Options& o, const std::vector<UnitMesh>& meshes, const Placement& pl,
                         const BackendCase& bc, SweepCsv& csv) {
    std::vector<World> worlds;
    for (const UnitMesh& m : meshes) worlds.push_back(place_mesh(m, pl));
    Counts sum;
    for (size_t mi = 0; mi < worlds.size(); ++mi) {
        const World& w = worlds[mi];
        const accel::GeometryView gv = w.view();
        std::unique_ptr<accel::Accelerator> acc =
            accel::create_accelerator(bc.backend, std::span<const accel::GeometryView>(&gv, 1), bc.options);
        RayBudget b;
        b.leak = o.rays / worlds.size() + (mi < o.rays % worlds.size());
        b.acne = o.acne / worlds.size() + 1;
        b.ref = o.ref / worlds.size() + 1;
        g_debug_label = bc.label + " " + pl.label();
        const Counts c = measure(w, *acc, b, o.seed + mi);
        sum.add(c);
        csv.row(pl, w.name, bc.label, c);
    }
    return sum;
}

/// Leaks, acne, grazing rays and t against the reference: one table row per placement and
/// backend. Returns the failures (a watertight leak, an error-bound false self-hit rate
/// of 1e-6 or more).
std::vector<std::string> sweep(const Options& o, const std::vector<UnitMesh>& meshes,
                               const std::vector<Placement>& places, const std::vector<BackendCase>& cases) {
    SweepCsv csv(o.csv);
    fmt::print("extremes: {} leak rays, {} acne points, {} reference rays per placement and backend; "
               "{} meshes, {} placements, {} backends\n",
               o.rays, o.acne, o.ref, meshes.size(), places.size(), cases.size());
    fmt::print("false/ambig: per acne ray (hemisphere + shadow); 0/N means none in N (95% bound 3/N).\n"
               "dt/t: random and axis rays; graz: grazing rays; /bound: |dt| over pbrt-v4's delta_t.\n");
    fmt::print("{:<13} {:<17} {:>4} {:>9} {:>7} | {:>8} {:>9} {:>8} | {:>9} {:>8} | {:>7} {:>5} {:>8} {:>8} {:>7}\n",
               "placement", "backend", "drop", "leakrays", "leaks", "acne", "false.eb", "ambig.eb", "false.eps",
               "ambig.ep", "ref", "wmiss", "dt/t", "graz", "/bound");
    std::vector<std::string> failures;
    for (const Placement& pl : places)
        for (const BackendCase& bc : cases) {
            const Counts sum = measure_placement(o, meshes, pl, bc, csv);
            fmt::print("{:<13} {:<17} {:>4} {:>9} {:>7} | {:>8} {:>9} {:>8} | {:>9} {:>8} | {:>7} {:>5} {:>8.1e} {:>8.1e} {:>7.1e}\n",
                       pl.label(), bc.label, sum.dropped, sum.leak_rays, sum.leaks, sum.acne_rays(0),
                       rate(sum.acne_false(0), sum.acne_rays(0)), rate(sum.acne_ambiguous(0), sum.acne_rays(0)),
                       rate(sum.acne_false(1), sum.acne_rays(1)), rate(sum.acne_ambiguous(1), sum.acne_rays(1)),
                       sum.ref_rays, sum.wrong_miss, sum.max_rel_t, sum.max_rel_t_grazing, sum.max_t_over_bound);
            std::fflush(stdout);
            if (bc.backend == "custom" && bc.options.triangle == accel::TriangleTest::Watertight && sum.leaks > 0)
                failures.push_back(fmt::format("{} {}: {} leaks", pl.label(), bc.label, sum.leaks));
            if (sum.acne_rays(0) > 0 && double(sum.acne_false(0)) / double(sum.acne_rays(0)) >= 1e-6)
                failures.push_back(fmt::format("{} {}: error-bound false self-hit rate {:.2e}", pl.label(),
                                               bc.label, double(sum.acne_false(0)) / double(sum.acne_rays(0))));
        }
    return failures;
}

/// Leaks through instances: each generated mesh as the one prototype of a two-level
/// scene, placed once at scales 1e-3 .. 1e3, at the origin and translated by up to 1e4
/// times the scale (at most 1e6: the flat sweep's rule, beyond which float cannot place
/// the mesh's features apart), rotated. Returns the failures (a custom watertight leak).
std::vector<std::string> instanced(const Options& o, const std::vector<UnitMesh>& meshes,
                                   const std::vector<BackendCase>& cases) {
    std::vector<std::string> failures;
    fmt::print("\ninstances: {} leak rays per placement, mesh and backend, the mesh placed by a rotation, a scale "
               "and a translation\n",
               o.rays / 4);
    fmt::print("{:<18}{:<12}{:<20}{:>10}{:>8}\n", "placement", "mesh", "backend", "leakrays", "leaks");
    for (double s : {1e-3, 1e-2, 1e-1, 1.0, 1e1, 1e2, 1e3})
        for (double off : {0.0, std::min(1e4 * s, 1e6)}) {
            const Placement pl{s, off};
            const accel::Affine3f m = extremes::instance_transform(pl);
            for (const UnitMesh& um : meshes) {
                const World unit = place_mesh(um, Placement{1, 0});
                const accel::GeometryView view = unit.view();
                const accel::PrototypeView proto{0, 1};
                const accel::InstanceView inst{0, m};
                const accel::InstanceSet set{std::span(&proto, 1), std::span(&inst, 1)};
                for (const BackendCase& bc : cases) {
                    std::unique_ptr<accel::Accelerator> acc;
                    try {
                        acc = accel::create_accelerator(bc.backend, std::span(&view, 1), bc.options, set);
                    } catch (const accel::AccelError& e) {
                        fmt::print("{:<18}{:<12}{:<20} skipped: {}\n", pl.label(), um.name, bc.label, e.what());
                        continue;
                    }
                    const Counts c = extremes::measure_instance_leaks(unit, m, *acc, o.rays / 4, o.seed);
                    fmt::print("{:<18}{:<12}{:<20}{:>10}{:>8}\n", pl.label(), um.name, bc.label, c.leak_rays, c.leaks);
                    if (bc.backend == "custom" && bc.options.triangle == accel::TriangleTest::Watertight && c.leaks > 0)
                        failures.push_back(fmt::format("instanced {} {} {}: {} leaks", pl.label(), um.name, bc.label,
                                                       c.leaks));
                }
            }
        }
    return failures;
}

/// Thin walls: light leaking through a wall 1e-3 of the scene thick, to its own CSV
/// (NAME_wall.csv beside --csv). Returns the failures (error-bound leaks not explained by
/// a start within rounding of the wall).
std::vector<std::string> thin_walls(const Options& o, const std::vector<Placement>& places,
                                    const std::vector<BackendCase>& cases) {
    const uint64_t wall_rays = std::max<uint64_t>(1, o.rays / 10);
    fmt::print("\nthin wall (1e-3 of the scene thick, at least 64 ulps), {} shadow segments per placement and "
               "backend; leaks = segments through the wall, of which 'within' start within rounding of it\n",
               wall_rays);
    fmt::print("{:<13} {:<17} {:>9} {:>4} | {:>9} {:>8} | {:>9} {:>8}\n", "placement", "backend", "thickness", "drop",
               "leaks.eb", "within", "leaks.eps", "within");
    std::filesystem::path wall_csv(o.csv);
    wall_csv.replace_filename(wall_csv.stem().string() + "_wall.csv");
    std::ofstream wall_out(wall_csv);
    wall_out << "scale,offset,thickness,backend,dropped,rays,leaks_eb,leaks_within_eb,leaks_eps,leaks_within_eps\n";
    std::vector<std::string> failures;
    for (const Placement& pl : places) {
        const double thickness = thin_wall_thickness(pl);
        const World w = make_thin_wall(thickness, pl);
        const accel::GeometryView gv = w.view();
        for (const BackendCase& bc : cases) {
            std::unique_ptr<accel::Accelerator> acc =
                accel::create_accelerator(bc.backend, std::span<const accel::GeometryView>(&gv, 1), bc.options);
            const WallCounts c = measure_thin_wall(w, thickness, *acc, wall_rays, o.seed + 99);
            fmt::print("{:<13} {:<17} {:>9.2e} {:>4} | {:>9} {:>8} | {:>9} {:>8}\n", pl.label(), bc.label,
                       thickness * pl.scale, c.dropped,
                       rate(c.leaks[0], c.rays[0]), c.leaks_within[0], rate(c.leaks[1], c.rays[1]),
                       c.leaks_within[1]);
            wall_out << fmt::format("{:g},{:g},{:g},{},{},{},{},{},{},{}\n", pl.scale, pl.offset, thickness * pl.scale,
                                    bc.label, c.dropped,
                                    c.rays[0], c.leaks[0], c.leaks_within[0], c.leaks[1], c.leaks_within[1]);
            if (c.leaks[0] > c.leaks_within[0])
                failures.push_back(fmt::format("{} {}: {} error-bound leaks through the thin wall", pl.label(),
                                               bc.label, c.leaks[0] - c.leaks_within[0]));
        }
    }
    return failures;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Numerical-stability sweep: leaks at shared edges and vertices, false "
                 "self-hits (acne) per ray-offset mode, grazing and axis-parallel rays, t and "
                 "barycentrics against a double-precision reference; per backend, per scale."};
    Options o;
    add_options(app, o);
    tools::parse_or_exit(app, argc, argv, "extremes");
    if (o.quick) o.rays = 20000;
    if (o.acne == 0) o.acne = std::max<uint64_t>(1, o.rays / 5);
    if (o.ref == 0) o.ref = std::max<uint64_t>(1, o.rays / 10);

    const std::vector<UnitMesh> meshes = load_meshes(o);
    const std::vector<Placement> places = placements(o);
    const std::vector<BackendCase> cases = backends(o);

    const auto t_start = std::chrono::steady_clock::now();
    std::vector<std::string> failures = sweep(o, meshes, places, cases);
    for (std::string& f : thin_walls(o, places, cases)) failures.push_back(std::move(f));
    if (o.only.empty())
        for (std::string& f : instanced(o, meshes, cases)) failures.push_back(std::move(f));
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
    fmt::print("wrote {} ({:.1f} s)\n", o.csv, secs);
    for (const std::string& f : failures) fmt::print("FAIL {}\n", f);
    const bool failed = !failures.empty();
    fmt::print("{}\n", failed ? "FAILED" : "OK: no watertight leak, error-bound false self-hit rate < 1e-6 everywhere");
    return failed ? 1 : 0;
}
