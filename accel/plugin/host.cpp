#include "accel/plugin/host.h"

#include <dlfcn.h>
#include <signal.h>
#include <ucontext.h>
#include <unistd.h>

#include <algorithm>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <vector>

#include "accel/plugin/accel_plugin.h"
#include "accel/primitive.h"

namespace accel {
namespace {

// The ABI's ray and hit have the host's own layouts, so one ray crosses the boundary as a
// pointer to the caller's Ray and Hit: no copy and no conversion per ray (the plugin is
// opaque code the compiler cannot see into, so it cannot assume the hit unchanged).
static_assert(sizeof(Ray) == sizeof(AccelPluginRay) && offsetof(Ray, dir) == offsetof(AccelPluginRay, dir) &&
              offsetof(Ray, t_min) == offsetof(AccelPluginRay, t_min) &&
              offsetof(Ray, t_max) == offsetof(AccelPluginRay, t_max));
// The ABI's hit is the first 32 bytes of ours: plugins trace no instances, and the host
// clears inst_id after each of their hits.
static_assert(sizeof(AccelPluginHit) == offsetof(Hit, inst_id) && offsetof(Hit, u) == offsetof(AccelPluginHit, u) &&
              offsetof(Hit, v) == offsetof(AccelPluginHit, v) &&
              offsetof(Hit, geom_id) == offsetof(AccelPluginHit, geom_id) &&
              offsetof(Hit, prim_id) == offsetof(AccelPluginHit, prim_id) &&
              offsetof(Hit, ng) == offsetof(AccelPluginHit, ng));
static_assert(sizeof(Vec3f) == 3 * sizeof(float), "positions are passed as packed xyz floats");

// Counters are added to by the plugin in place, in the caller's per-thread statistics.
static_assert(offsetof(TraceStats, prim_tests) == offsetof(TraceStats, nodes_visited) + sizeof(uint64_t) &&
              offsetof(AccelPluginCounters, prim_tests) == sizeof(uint64_t));
AccelPluginCounters* as_abi(TraceStats& stats) {
    return stats.counting ? reinterpret_cast<AccelPluginCounters*>(&stats.nodes_visited) : nullptr;
}

const AccelPluginRay* as_abi(const Ray& ray) { return reinterpret_cast<const AccelPluginRay*>(&ray); }
AccelPluginHit* as_abi(Hit& hit) { return reinterpret_cast<AccelPluginHit*>(&hit); }

constexpr size_t kErrorBytes = 256;

// ---- Crash reporting ------------------------------------------------------------------
// A plugin that crashes takes the process with it (its memory is ours), but the user is
// told which library was loaded and, where the faulting address lies in one, which.
// The line is written with write(2) from the handler; the previous disposition is then
// restored and the signal raised again, so the exit status is the signal's.

constexpr int kCrashSignals[] = {SIGSEGV, SIGBUS, SIGILL, SIGFPE};
struct sigaction g_previous[std::size(kCrashSignals)];
std::mutex g_plugins_mutex;
char g_plugin_paths[512] = {0};  // "a.so, b.so": read by the handler, written under the mutex

void write_str(const char* s) {
    ssize_t ignored = ::write(STDERR_FILENO, s, std::strlen(s));
    (void)ignored;
}

/// The address of the instruction that faulted, where the platform tells it.
void* faulting_pc(siginfo_t* info, void* context) {
#if defined(__x86_64__) && defined(REG_RIP)
    if (context) return reinterpret_cast<void*>(static_cast<ucontext_t*>(context)->uc_mcontext.gregs[REG_RIP]);
#endif
    (void)context;
    return info ? info->si_addr : nullptr;
}

void on_crash(int sig, siginfo_t* info, void* context) {
    const char* name = sig == SIGSEGV ? "SIGSEGV" : sig == SIGBUS ? "SIGBUS" : sig == SIGILL ? "SIGILL" : "SIGFPE";
    write_str("error: fatal signal ");
    write_str(name);
    Dl_info where{};
    // dladdr is not on POSIX's async-signal-safe list, but it only reads the loader's
    // tables; in a process that is about to die anyway, naming the library is worth it.
    void* pc = faulting_pc(info, context);
    if (pc && dladdr(pc, &where) && where.dli_fname &&
        std::strstr(g_plugin_paths, where.dli_fname)) {
        write_str(" at an address inside plugin ");
        write_str(where.dli_fname);
    } else {
        write_str(" while plugin ");
        write_str(g_plugin_paths);
        write_str(" was loaded");
    }
    write_str(" (a crash in a plugin cannot be survived; see accel/plugin/README.md)\n");
    for (size_t i = 0; i < std::size(kCrashSignals); ++i)
        if (kCrashSignals[i] == sig) sigaction(sig, &g_previous[i], nullptr);
    raise(sig);
}

void note_loaded(const std::string& path) {
    std::lock_guard lock(g_plugins_mutex);
    const bool first = g_plugin_paths[0] == 0;
    if (std::strstr(g_plugin_paths, path.c_str()) == nullptr) {
        std::string all = first ? path : std::string(g_plugin_paths) + ", " + path;
        std::snprintf(g_plugin_paths, sizeof g_plugin_paths, "%s", all.c_str());
    }
    if (!first) return;
    for (size_t i = 0; i < std::size(kCrashSignals); ++i) {
        struct sigaction sa {};
        sa.sa_sigaction = on_crash;
        sa.sa_flags = SA_SIGINFO;
        sigemptyset(&sa.sa_mask);
        sigaction(kCrashSignals[i], &sa, &g_previous[i]);
    }
}

// ---- Loading --------------------------------------------------------------------------

struct Library {
    void* handle = nullptr;
    ~Library() {
        if (handle) dlclose(handle);
    }
};

[[noreturn]] void refuse(const std::string& path, const std::string& why) {
    throw AccelError("plugin " + path + ": " + why);
}

const char* code_name(int rc) {
    switch (rc) {
    case ACCEL_PLUGIN_BAD_OPTIONS: return "bad options";
    case ACCEL_PLUGIN_OUT_OF_MEMORY: return "out of memory";
    default: return "error";
    }
}

/// A plugin's structure behind the Accelerator edge: one call through the plugin's table
/// per ray, on top of the edge's own virtual call.
class PluginAccelerator final : public Accelerator {
public:
    PluginAccelerator(std::string path, std::unique_ptr<Library> lib, const AccelPluginApi* api,
                      std::span<const GeometryView> geometry, const std::string& options)
        : path_(std::move(path)), lib_(std::move(lib)), api_(api), geometry_(geometry.begin(), geometry.end()) {
        std::vector<AccelPluginGeometry> views;
        views.reserve(geometry_.size());
        for (const GeometryView& g : geometry_) {
            AccelPluginGeometry v{};
            v.num_prims = g.num_prims;
            if (g.type == GeometryType::Triangles) {
                v.type = ACCEL_PLUGIN_TRIANGLES;
                v.positions = reinterpret_cast<const float*>(g.positions);
                v.num_vertices = g.num_vertices;
                v.indices = g.indices;
            } else {
                v.type = ACCEL_PLUGIN_SPHERES;
                v.spheres = g.spheres;
            }
            views.push_back(v);
            prims_.push_back(g.num_prims);
            for (uint32_t p = 0; p < g.num_prims; ++p) bounds_.extend(primitive_bounds(g, p));
        }
        AccelPluginBuildInfo bi{};
        char error[kErrorBytes] = {0};
        const int rc = api_->build(views.data(), uint32_t(views.size()), options.c_str(), &handle_, &bi, error,
                                   sizeof error);
        if (rc != ACCEL_PLUGIN_OK || handle_ == nullptr) {
            handle_ = nullptr;
            refuse(path_, std::string("build failed (") + code_name(rc) + "): " +
                              (error[0] ? std::string(error, strnlen(error, sizeof error)) : "no message"));
        }
        bi.description[sizeof bi.description - 1] = 0;
        info_.backend = std::string("plugin ") + api_->name + " " + api_->version;
        if (bi.description[0]) info_.backend += std::string(" (") + bi.description + ")";
        info_.primitives = bi.primitives;
        info_.dropped = bi.dropped;
        info_.nodes = bi.nodes;
        info_.leaves = bi.leaves;
        info_.depth = bi.depth;
        info_.sah_cost = bi.sah_cost;
        info_.bytes = api_->memory_used ? api_->memory_used(handle_) : 0;
        info_.counts_nodes = (api_->capabilities & ACCEL_PLUGIN_COUNTS_NODES) != 0;
        info_.counts_prims = (api_->capabilities & ACCEL_PLUGIN_COUNTS_PRIMS) != 0;
        normals_ = (api_->capabilities & ACCEL_PLUGIN_REPORTS_NORMALS) != 0;
    }

    ~PluginAccelerator() override {
        if (handle_) api_->destroy(handle_);
    }

    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        char error[kErrorBytes];
        error[0] = 0;
        const int rc = api_->intersect(handle_, as_abi(ray), as_abi(hit), as_abi(stats), error, sizeof error);
        if (rc == ACCEL_PLUGIN_MISS) return false;
        if (rc != ACCEL_PLUGIN_HIT) fail("intersect", rc, error);
        check(hit.geom_id, hit.prim_id);
        hit.inst_id = kInvalidId;
        if (!normals_) finish_hit(geometry_, ray, hit);
        return true;
    }

    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        char error[kErrorBytes];
        error[0] = 0;
        const int rc = api_->occluded(handle_, as_abi(ray), as_abi(stats), error, sizeof error);
        if (rc == ACCEL_PLUGIN_MISS) return false;
        if (rc != ACCEL_PLUGIN_HIT) fail("occluded", rc, error);
        return true;
    }

    bool has_batches() const override { return api_->intersect_n && api_->occluded_n; }

    void intersect_batch(std::span<const Ray> rays, Hit* hits, TraceStats& stats) const override {
        if (!has_batches()) return Accelerator::intersect_batch(rays, hits, stats);
        const uint32_t n = uint32_t(rays.size());
        Soa soa(rays);
        std::vector<float> t(n), u(n), v(n), nx(n), ny(n), nz(n);
        std::vector<uint32_t> geom(n), prim(n);
        AccelPluginHitsSoA out{t.data(), u.data(), v.data(), geom.data(), prim.data(), nx.data(), ny.data(), nz.data()};
        AccelPluginCounters c{0, 0};
        char error[kErrorBytes];
        error[0] = 0;
        const int rc = api_->intersect_n(handle_, &soa.view, n, &out, stats.counting ? &c : nullptr, error,
                                         sizeof error);
        stats.rays += n;
        add(stats, c);
        if (rc != ACCEL_PLUGIN_OK) fail("intersect_n", rc, error);
        for (uint32_t i = 0; i < n; ++i) {
            hits[i] = Hit{};
            if (geom[i] == kInvalidId) continue;
            take(rays[i], AccelPluginHit{t[i], u[i], v[i], geom[i], prim[i], {nx[i], ny[i], nz[i]}}, hits[i]);
        }
    }

    void occluded_batch(std::span<const Ray> rays, uint8_t* occluded, TraceStats& stats) const override {
        if (!has_batches()) return Accelerator::occluded_batch(rays, occluded, stats);
        const uint32_t n = uint32_t(rays.size());
        Soa soa(rays);
        AccelPluginCounters c{0, 0};
        char error[kErrorBytes];
        error[0] = 0;
        const int rc = api_->occluded_n(handle_, &soa.view, n, occluded, stats.counting ? &c : nullptr, error,
                                        sizeof error);
        stats.shadow_rays += n;
        add(stats, c);
        if (rc != ACCEL_PLUGIN_OK) fail("occluded_n", rc, error);
        for (uint32_t i = 0; i < n; ++i) occluded[i] = occluded[i] ? 1 : 0;
    }

    const BuildInfo& info() const override { return info_; }
    Bounds3f bounds() const override { return bounds_; }

private:
    /// The rays of a batch as the ABI's structure of arrays.
    struct Soa {
        std::vector<float> data;
        AccelPluginRaysSoA view;
        explicit Soa(std::span<const Ray> rays) : data(8 * rays.size()) {
            const size_t n = rays.size();
            float* f[8];
            for (int k = 0; k < 8; ++k) f[k] = data.data() + k * n;
            for (size_t i = 0; i < n; ++i) {
                const Ray& r = rays[i];
                f[0][i] = r.org.x, f[1][i] = r.org.y, f[2][i] = r.org.z;
                f[3][i] = r.dir.x, f[4][i] = r.dir.y, f[5][i] = r.dir.z;
                f[6][i] = r.t_min, f[7][i] = r.t_max;
            }
            view = {f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7]};
        }
    };

    static void add(TraceStats& stats, const AccelPluginCounters& c) {
        stats.nodes_visited += c.nodes_visited;
        stats.prim_tests += c.prim_tests;
    }

    /// A plugin's hit must name a primitive: a wrong id would otherwise be read out of
    /// bounds by the renderer, far from its cause.
    void check(uint32_t geom_id, uint32_t prim_id) const {
        if (geom_id < prims_.size() && prim_id < prims_[geom_id]) [[likely]]
            return;
        bad_hit(geom_id, prim_id);
    }
    [[noreturn, gnu::cold, gnu::noinline]] void bad_hit(uint32_t geom_id, uint32_t prim_id) const {
        char msg[96];
        std::snprintf(msg, sizeof msg, "returned a hit on geometry %u, primitive %u, which does not exist", geom_id,
                      prim_id);
        fail("intersect", ACCEL_PLUGIN_ERROR, msg);
    }

    /// Takes a batched hit (checked as above).
    void take(const Ray& ray, const AccelPluginHit& h, Hit& hit) const {
        check(h.geom_id, h.prim_id);
        hit.t = h.t;
        hit.u = h.u;
        hit.v = h.v;
        hit.geom_id = h.geom_id;
        hit.prim_id = h.prim_id;
        hit.inst_id = kInvalidId;
        if (normals_)
            hit.ng = {h.ng[0], h.ng[1], h.ng[2]};
        else
            finish_hit(geometry_, ray, hit);
    }

    /// A failed trace is fatal: carrying on would render a silently wrong image, and the
    /// integrators have no error path per ray (accel_plugin.h, "Errors").
    [[noreturn, gnu::cold, gnu::noinline]] void fail(const char* what, int rc, const char* error) const {
        static std::mutex once;
        std::lock_guard lock(once);
        std::fprintf(stderr, "error: plugin %s: %s failed (%s): %s\n", path_.c_str(), what, code_name(rc),
                     error[0] ? error : "no message");
        std::fflush(stderr);
        std::_Exit(2);
    }

    std::string path_;
    std::unique_ptr<Library> lib_;
    const AccelPluginApi* api_;
    void* handle_ = nullptr;
    bool normals_ = false;  ///< the plugin's hits carry their geometric normal
    std::vector<GeometryView> geometry_;
    std::vector<uint32_t> prims_;  ///< primitives per geometry, for check()
    Bounds3f bounds_;
    BuildInfo info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_plugin(const std::string& spec, std::span<const GeometryView> geometry) {
    const size_t colon = spec.find(':');
    const std::string path = spec.substr(0, colon);
    const std::string options = colon == std::string::npos ? "" : spec.substr(colon + 1);
    if (path.empty()) throw AccelError("plugin: no path given (expected plugin:PATH[:OPTIONS])");
    // ABI version 1 has no hit filter, and a plugin that ignored one would draw cut-out
    // leaves as opaque cards without a word: refused, so the user picks another backend.
    for (size_t i = 0; i < geometry.size(); ++i)
        if (geometry[i].masked())
            refuse(path, "geometry " + std::to_string(i) +
                             " is masked (an alpha-tested or blended material), which the plugin ABI cannot "
                             "pass (no hit filter in version " + std::to_string(ACCEL_PLUGIN_ABI_VERSION) +
                             "); use the custom, embree or naive backend");
    std::error_code ec;
    // A bare name would make dlopen search the library path; a plugin is named by its file.
    if (!std::filesystem::exists(path, ec)) refuse(path, "no such file");
    if (!std::filesystem::is_regular_file(path, ec)) refuse(path, "not a regular file");
    const std::string open_path = path.find('/') == std::string::npos ? "./" + path : path;
    auto lib = std::make_unique<Library>();
    // RTLD_NODELETE: a plugin's static destructors and thread-locals (Rust's, C++'s) stay
    // valid until the process exits, whatever the order of teardown.
    lib->handle = dlopen(open_path.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
    if (!lib->handle) {
        const char* e = dlerror();
        refuse(path, std::string("cannot be loaded: ") + (e ? e : "unknown reason"));
    }
    dlerror();
    auto entry = reinterpret_cast<AccelPluginEntryFn>(dlsym(lib->handle, ACCEL_PLUGIN_ENTRY_NAME));
    if (!entry)
        refuse(path, "no entry point '" ACCEL_PLUGIN_ENTRY_NAME
                     "' (export it with C linkage, as accel/plugin/accel_plugin.h declares)");
    const AccelPluginApi* api = entry();
    if (!api) refuse(path, ACCEL_PLUGIN_ENTRY_NAME "() returned no function table");
    if (api->abi_version != ACCEL_PLUGIN_ABI_VERSION)
        refuse(path, "ABI version " + std::to_string(api->abi_version) + ", but this host speaks version " +
                         std::to_string(ACCEL_PLUGIN_ABI_VERSION) + " (rebuild it against this accel_plugin.h)");
    if (api->struct_size < sizeof(AccelPluginApi))
        refuse(path, "function table of " + std::to_string(api->struct_size) + " bytes, expected " +
                         std::to_string(sizeof(AccelPluginApi)));
    if (!api->build || !api->intersect || !api->occluded || !api->destroy)
        refuse(path, "function table lacks build, intersect, occluded or destroy");
    if (!api->name || !api->version) refuse(path, "function table lacks its name or version");
    if (bool(api->intersect_n) != bool(api->occluded_n))
        refuse(path, "gives one batched entry point without the other (both or neither)");
    note_loaded(path);
    return std::make_unique<PluginAccelerator>(path, std::move(lib), api, geometry, options);
}

}  // namespace accel
