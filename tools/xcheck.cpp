// xcheck [options] SCENE: trace the very same rays through several backends and report,
// per ray kind, how far they agree with a reference; classify every disagreement.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>

#include "accel/bvh/bvh.h"
#include "renderer/backend_spec.h"
#include "renderer/ray_record.h"
#include "renderer/raysets.h"
#include "renderer/scene_geometry.h"
#include "renderer/xcheck.h"
#include "scenes/load.h"
#include "tools/cli.h"
#include "tools/memory/memory.h"

namespace {

[[noreturn]] void fail(const std::string& message) { tools::fail("xcheck", message); }

/// Every option, as CLI11 fills it.
struct Options {
    std::string scene_path, backends_arg, reference_arg, kinds_arg, dump_path, replay_path, record_path;
    size_t rays = 200000;
    uint64_t seed = 1;
    std::string isa_arg = "auto", nodes_arg = "auto";
    std::string instancing = "auto";
};

void add_options(CLI::App& app, Options& o) {
    app.add_option("scene", o.scene_path, "Scene file (.dae, .gltf, .glb)")->required();
    app.add_option("--rays", o.rays, "Rays per kind")->check(CLI::Range(size_t(1), size_t(100000000)));
    app.add_option("--backends", o.backends_arg,
                   "Comma-separated backends to check, e.g. custom:sah:fast,custom:midpoint:watertight,"
                   "embree:high (default: custom with every split and both triangle tests, embree; "
                   "naive too up to 10k triangles)");
    app.add_option("--reference", o.reference_arg,
                   "Reference backend (default: naive:watertight up to 10k triangles, else embree:high)");
    app.add_option("--kinds", o.kinds_arg, "Comma-separated ray kinds (default: all): camera,random,"
                                           "edge-vertex,grazing,shadow,diffuse; render-closest,render-shadow "
                                           "with --ray-record");
    app.add_option("--seed", o.seed, "Seed of the ray sets");
    app.add_option("--isa", o.isa_arg, "Kernel of custom backends that name none: auto | sse2 | avx2 | avx512")
        ->check(CLI::IsMember({"auto", "sse2", "avx2", "avx512"}));
    app.add_option("--nodes", o.nodes_arg, "Node layout of custom backends that name none: auto (quantized from 4M primitives) | float | quantized")
        ->check(CLI::IsMember({"auto", "float", "quantized"}));
    app.add_option("--instancing", o.instancing,
                   "auto: the backends checked trace the file's instances, the reference their flattened copy "
                   "(hits compared in the copy's ids); keep: every backend, the reference too, traces the "
                   "instances (hits compared by instance, geometry and primitive), for scenes whose flattened "
                   "copy does not fit; flatten: everything traces the copy")
        ->check(CLI::IsMember({"auto", "keep", "flatten"}));
    app.add_option("--dump", o.dump_path, "Write the disagreeing rays to FILE (replayable)");
    app.add_option("--replay", o.replay_path, "Trace the rays of FILE (from --dump) instead of generating rays")
        ->check(CLI::ExistingFile);
    app.add_option("--ray-record", o.record_path,
                   "A render's rays (pathtracer --record-rays FILE) for --kinds render-closest,render-shadow");
}

/// Hex floats: a dumped ray replays bit for bit.
std::string ray_line(renderer::RayKind kind, const accel::Ray& r) {
    return fmt::format("{} {:a} {:a} {:a} {:a} {:a} {:a} {:a} {:a}", renderer::ray_kind_name(kind),
                       r.org.x, r.org.y, r.org.z, r.dir.x, r.dir.y, r.dir.z, r.t_min, r.t_max);
}

std::string outcome_text(const renderer::RayOutcome& o) {
    if (!o.hit) return "miss";
    return fmt::format("hit geom {} prim {} t {:.9g} uv ({:.6g}, {:.6g})", o.geom, o.prim, o.t, o.u, o.v);
}

std::vector<renderer::RaySet> read_replay(const std::string& path) {
    std::ifstream in(path);
    if (!in) fail(path + ": cannot be opened for reading");
    std::map<renderer::RayKind, renderer::RaySet> sets;
    std::string line;
    for (int lineno = 1; std::getline(in, line); ++lineno) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream ls(line);
        std::string kind_name, f[8];
        ls >> kind_name;
        for (auto& s : f) ls >> s;
        renderer::RayKind kind;
        if (!renderer::parse_ray_kind(kind_name, kind))
            fail(fmt::format("{}:{}: unknown ray kind '{}'", path, lineno, kind_name));
        float v[8];
        for (int i = 0; i < 8; ++i) {
            char* end = nullptr;
            v[i] = std::strtof(f[i].c_str(), &end);
            if (f[i].empty() || *end != '\0')
                fail(fmt::format("{}:{}: expected 8 numbers after the kind", path, lineno));
        }
        accel::Ray r;
        r.org = {v[0], v[1], v[2]};
        r.dir = {v[3], v[4], v[5]};
        r.t_min = v[6];
        r.t_max = v[7];
        sets[kind].kind = kind;
        sets[kind].rays.push_back(r);
    }
    std::vector<renderer::RaySet> out;
    for (auto& [k, s] : sets) out.push_back(std::move(s));
    return out;
}

/// The reference and the backends checked against it (the reference itself left out).
struct Backends {
    renderer::BackendSpec ref;
    std::vector<renderer::BackendSpec> specs;
};

/// Small scenes (up to 10k triangles) get the exact naive reference; larger ones Embree.
/// `instanced`: the reference traces the flattened copy and the others the instances, so
/// a backend named like the reference is checked too (against its own flat copy).
Backends choose_backends(const Options& o, bool small, bool instanced) {
    const auto available = accel::available_backends();
    const bool have_embree = std::find(available.begin(), available.end(), "embree") != available.end();
    Backends b;
    try {
        b.ref = renderer::parse_backend_spec(!o.reference_arg.empty() ? o.reference_arg
                                             : small                  ? "naive:watertight"
                                             : have_embree            ? "embree:high"
                                                                      : "custom:sah:watertight");
        std::string list = o.backends_arg;
        if (list.empty()) {
            list = "custom:sah:fast,custom:sah:watertight,custom:midpoint:fast,custom:midpoint:watertight,"
                   "custom:sbvh:fast,custom:sbvh:watertight";
            if (have_embree) list += ",embree:high";
            if (small) list += ",naive:fast";
        }
        for (auto& s : renderer::parse_backend_specs(list, o.isa_arg, o.nodes_arg))
            if (instanced || s.label != b.ref.label) b.specs.push_back(s);
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    return b;
}

std::vector<renderer::RayKind> parse_kinds(const std::string& kinds_arg) {
    std::vector<renderer::RayKind> kinds;
    if (kinds_arg.empty()) {
        kinds.assign(std::begin(renderer::kAllRayKinds), std::end(renderer::kAllRayKinds));
    } else {
        std::stringstream ss(kinds_arg);
        for (std::string k; std::getline(ss, k, ',');) {
            renderer::RayKind kind;
            if (!renderer::parse_ray_kind(k, kind)) fail("--kinds: unknown ray kind '" + k + "'");
            kinds.push_back(kind);
        }
    }
    return kinds;
}

/// An instanced backend seen through the flattened copy's ids, so that its hits compare
/// with the reference's on that copy (scenes::flatten_instances: world-space meshes first,
/// in scene order, then each instance's prototype meshes, then the spheres). Only the
/// ids change: t is the instanced backend's own, whose difference from the copy's is the
/// transform's rounding (the object-space ray's origin is off by about 2^-24 (|W| |o| +
/// |w|) per axis, and the copy's vertices by 2^-24 (|L| |p| + |t|)): far below the
/// tolerances compare_backends allows an agreeing pair, and a hit/miss flip it causes lies
/// within them of an edge (renderer/xcheck.h, "numerical").
class FlatIds final : public accel::Accelerator {
public:
    FlatIds(std::unique_ptr<accel::Accelerator> inner, const scenes::Scene& scene) : inner_(std::move(inner)) {
        const std::vector<int32_t> owner = scene.mesh_prototypes();
        world_.assign(scene.meshes.size(), accel::kInvalidId);
        uint32_t next = 0;
        for (size_t m = 0; m < scene.meshes.size(); ++m)
            if (owner[m] < 0) world_[m] = next++;
        first_.reserve(scene.instances.size());
        for (const scenes::Instance& i : scene.instances) {
            first_.push_back(next);
            next += scene.prototypes[i.prototype].num_meshes;
        }
        proto_first_.reserve(scene.prototypes.size());
        for (const scenes::Prototype& p : scene.prototypes) proto_first_.push_back(p.first_mesh);
        for (const scenes::Instance& i : scene.instances) inst_proto_.push_back(i.prototype);
        spheres_ = uint32_t(scene.meshes.size());
        flat_spheres_ = next;
    }
    bool intersect(const accel::Ray& ray, accel::Hit& hit, accel::TraceStats& stats) const override {
        if (!inner_->intersect(ray, hit, stats)) return false;
        if (hit.inst_id != accel::kInvalidId)
            hit.geom_id = first_[hit.inst_id] + (hit.geom_id - proto_first_[inst_proto_[hit.inst_id]]);
        else
            hit.geom_id = hit.geom_id == spheres_ ? flat_spheres_ : world_[hit.geom_id];
        hit.inst_id = accel::kInvalidId;
        return true;
    }
    bool occluded(const accel::Ray& ray, accel::TraceStats& stats) const override {
        return inner_->occluded(ray, stats);
    }
    const accel::BuildInfo& info() const override { return inner_->info(); }
    accel::Bounds3f bounds() const override { return inner_->bounds(); }

private:
    std::unique_ptr<accel::Accelerator> inner_;
    std::vector<uint32_t> world_, first_, proto_first_, inst_proto_;
    uint32_t spheres_ = 0, flat_spheres_ = 0;
};

/// Every backend, built; the reference first.
struct Built {
    std::unique_ptr<accel::Accelerator> ref;
    std::vector<std::unique_ptr<accel::Accelerator>> others;
};

/// `instanced`: the scene whose instances the checked backends trace (`geometry` then
/// being its flattened copy, which the reference traces); null when there is none.
Built build_all(const Backends& b, const renderer::SceneGeometry& geometry, const scenes::Scene* instanced,
                const renderer::SceneGeometry* instanced_geometry) {
    Built built;
    const tools::memory::Stage stage("building the BVHs");
    const uint64_t failures = tools::memory::failures();
    try {
        built.ref = renderer::build_accelerator(b.ref.backend, geometry, b.ref.options, false);
        for (const auto& s : b.specs) {
            if (instanced)
                built.others.push_back(std::make_unique<FlatIds>(
                    renderer::build_accelerator(s.backend, *instanced_geometry, s.options, false), *instanced));
            else
                built.others.push_back(renderer::build_accelerator(s.backend, geometry, s.options, false));
        }
    } catch (const accel::AccelError& e) {
        // A plugin reports its failed allocation as an error of its own.
        if (tools::memory::failures() != failures) tools::memory::out_of_memory();
        fail(e.what());
    }
    return built;
}

/// The rays: replayed from --replay, else generated per kind (through the reference).
std::vector<renderer::RaySet> make_sets(const Options& o, const std::vector<renderer::RayKind>& kinds,
                                        const scenes::Scene& scene, const accel::Accelerator& ref) {
    if (!o.replay_path.empty()) return read_replay(o.replay_path);
    std::vector<renderer::RaySet> sets;
    renderer::RaySetOptions ro;
    ro.seed = o.seed;
    ro.count = o.rays;
    renderer::RayRecord record;
    try {
        if (!o.record_path.empty()) {
            record = renderer::read_ray_record_for(o.record_path, scene);
            ro.record = &record;
        }
        for (renderer::RayKind k : kinds) {
            std::fprintf(stderr, "[xcheck] generating %zu %s rays\n", o.rays, renderer::ray_kind_name(k));
            sets.push_back(renderer::make_ray_set(k, scene, ref, ro));
        }
    } catch (const std::invalid_argument& e) {
        fail(e.what());
    }
    return sets;
}

/// The table: one row per (ray kind, backend). Returns the real disagreements' count and
/// collects every disagreement in `bad`.
uint64_t compare_all(const Backends& b, const Built& built, const std::vector<renderer::RaySet>& sets,
                     const renderer::SceneGeometry& geometry, std::vector<renderer::Disagreement>& bad) {
    int w = 26;  // the backend column, widened for long labels (plugins' file names)
    for (const auto& s : b.specs) w = std::max(w, int(s.label.size()));
    std::printf("%-12s %-*s %9s %10s %10s %11s %7s %9s %6s %9s\n", "kind", w, "backend", "rays", "hit-agree",
                "prim-agree", "max|dt|/t", "ties", "numerical", "real", "tests/ray");
    uint64_t total_real = 0, total_rays = 0;
    for (const auto& set : sets) {
        for (size_t i = 0; i < built.others.size(); ++i) {
            const accel::Accelerator& other = *built.others[i];
            std::fprintf(stderr, "[xcheck] %s rays through %s\n", renderer::ray_kind_name(set.kind),
                         b.specs[i].label.c_str());
            renderer::KindReport r = renderer::compare_backends(*built.ref, b.ref.label, other,
                                                                b.specs[i].label, set, geometry, &bad);
            total_real += r.real;
            total_rays += r.rays;
            std::string tpr = other.info().counts_prims ? fmt::format("{:.2f}", r.stats.tests_per_ray()) : "-";
            std::printf("%-12s %-*s %9llu %9.5f%% %9.5f%% %11.3g %7llu %9llu %6llu %9s\n",
                        renderer::ray_kind_name(set.kind), w, b.specs[i].label.c_str(), (unsigned long long)r.rays,
                        r.rays ? 100.0 * double(r.hit_agree) / double(r.rays) : 100.0,
                        r.rays ? 100.0 * double(r.prim_agree) / double(r.rays) : 100.0, r.max_rel_dt,
                        (unsigned long long)r.ties, (unsigned long long)r.numerical,
                        (unsigned long long)r.real, tpr.c_str());
            std::fflush(stdout);
        }
    }
    std::printf("total: %llu ray comparisons, %llu real disagreements\n", (unsigned long long)total_rays,
                (unsigned long long)total_real);
    return total_real;
}

/// --replay: every replayed ray's outcome per backend.
void print_replayed(const Backends& b, const Built& built, const std::vector<renderer::RaySet>& sets) {
    for (const auto& set : sets)
        for (const auto& ray : set.rays) {
            std::printf("%s\n", ray_line(set.kind, ray).c_str());
            renderer::RaySet one;
            one.kind = set.kind;
            one.rays = {ray};
            accel::TraceStats st;
            auto a = renderer::trace_set(*built.ref, one, st, true);
            std::printf("  %-26s %s\n", b.ref.label.c_str(), outcome_text(a[0]).c_str());
            for (size_t i = 0; i < built.others.size(); ++i) {
                auto o = renderer::trace_set(*built.others[i], one, st, true);
                std::printf("  %-26s %s\n", b.specs[i].label.c_str(), outcome_text(o[0]).c_str());
            }
        }
}

/// --dump: the disagreeing rays, each after a comment line saying how it disagreed.
void write_dump(const std::string& dump_path, const std::string& scene_path, const std::string& ref_label,
                const std::vector<renderer::Disagreement>& bad) {
    const std::string tmp = dump_path + ".tmp";
    {
        std::ofstream out(tmp);
        if (!out) fail(dump_path + ": cannot be written");
        out << "# xcheck disagreements on " << scene_path << "; reference " << ref_label << "\n";
        for (const auto& d : bad)
            out << "# " << d.backend << " " << renderer::verdict_name(d.verdict) << ": ref "
                << outcome_text(d.ref) << " / other " << outcome_text(d.other) << "\n"
                << ray_line(d.kind, d.ray) << "\n";
        if (!out) fail(dump_path + ": write failed");
    }
    if (std::rename(tmp.c_str(), dump_path.c_str()) != 0) fail(dump_path + ": cannot rename into place");
    std::printf("wrote %zu disagreeing rays to %s\n", bad.size(), dump_path.c_str());
}

}  // namespace

int main(int argc, char** argv) try {
    tools::memory::install("xcheck");
    CLI::App app{"Cross-check backends ray by ray: camera, random, edge/vertex, grazing, shadow and "
                 "diffuse-bounce rays, each disagreement classified (tie, numerical, real)."};
    Options o;
    add_options(app, o);
    tools::parse_or_exit(app, argc, argv, "xcheck");
    scenes::Scene scene = tools::load_scene_or_exit(o.scene_path, "xcheck");
    // Instances (--instancing): under auto the reference traces the flattened copy and the
    // others the instances; under keep every backend traces the instances, so `scene`
    // stays as loaded; under flatten every backend traces the copy.
    std::optional<scenes::Scene> instanced;
    const bool keep = o.instancing == "keep" && !scene.instances.empty();
    if (!scene.instances.empty() && !keep) {
        if (o.instancing == "auto") instanced = scene;
        try {
            scenes::flatten_instances(scene);
        } catch (const scenes::SceneError& e) {
            fail(std::string(e.what()) + "; xcheck compares instances with their flattened copy");
        }
    }
    const uint64_t tris = scene.num_triangles();
    if (tris == 0 && scene.spheres.empty()) fail(o.scene_path + ": the scene has no geometry");
    // The naive reference loops over every placed triangle, so under keep the instanced count decides.
    const Backends b = choose_backends(o, (keep ? scene.instanced_triangles() : tris) <= 10000, instanced.has_value());
    const std::vector<renderer::RayKind> kinds = parse_kinds(o.kinds_arg);  // before the builds: fail fast

    const renderer::SceneGeometry geometry(scene);
    std::optional<renderer::SceneGeometry> instanced_geometry;
    if (instanced) instanced_geometry.emplace(*instanced);
    const Built built = build_all(b, geometry, instanced ? &*instanced : nullptr,
                                  instanced_geometry ? &*instanced_geometry : nullptr);
    tools::memory::set_stage("making the rays");
    const std::vector<renderer::RaySet> sets = make_sets(o, kinds, scene, *built.ref);
    tools::memory::set_stage("tracing the rays");

    std::printf("scene %s: %llu triangles, %zu spheres; reference %s (%s)\n", o.scene_path.c_str(),
                (unsigned long long)tris, scene.spheres.size(), b.ref.label.c_str(),
                built.ref->info().backend.c_str());
    if (instanced)
        std::printf("instances: %zu placing %llu triangles of %llu unique; the reference traces the flattened "
                    "copy, every other backend the instances\n",
                    instanced->instances.size(), (unsigned long long)instanced->instanced_triangles(),
                    (unsigned long long)instanced->num_triangles());
    if (keep)
        std::printf("instances: %zu placing %llu triangles of %llu unique; every backend, the reference too, "
                    "traces the instances\n",
                    scene.instances.size(), (unsigned long long)scene.instanced_triangles(),
                    (unsigned long long)scene.num_triangles());
    std::vector<renderer::Disagreement> bad;
    const uint64_t total_real = compare_all(b, built, sets, geometry, bad);
    if (!o.replay_path.empty()) print_replayed(b, built, sets);
    if (!o.dump_path.empty()) write_dump(o.dump_path, o.scene_path, b.ref.label, bad);
    return total_real > 0 ? 1 : 0;
} catch (const std::bad_alloc& e) {
    tools::memory::out_of_memory(e);
}
