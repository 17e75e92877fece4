// Embree 3 backend. The only translation unit of the project that includes Embree.
#include "accel/embree/embree.h"

#include <embree3/rtcore.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>
#include <mutex>
#include <string>
#include <type_traits>
#include <vector>

#include "accel/out_of_memory.h"
#include "accel/primitive.h"

namespace accel {
namespace {

const char* error_name(RTCError code) {
    switch (code) {
        case RTC_ERROR_NONE: return "RTC_ERROR_NONE";
        case RTC_ERROR_UNKNOWN: return "RTC_ERROR_UNKNOWN";
        case RTC_ERROR_INVALID_ARGUMENT: return "RTC_ERROR_INVALID_ARGUMENT";
        case RTC_ERROR_INVALID_OPERATION: return "RTC_ERROR_INVALID_OPERATION";
        case RTC_ERROR_OUT_OF_MEMORY: return "RTC_ERROR_OUT_OF_MEMORY";
        case RTC_ERROR_UNSUPPORTED_CPU: return "RTC_ERROR_UNSUPPORTED_CPU";
        case RTC_ERROR_CANCELLED: return "RTC_ERROR_CANCELLED";
    }
    return "RTC_ERROR_(unrecognised code)";
}

const char* quality_name(EmbreeQuality q) {
    switch (q) {
        case EmbreeQuality::Low: return "low";
        case EmbreeQuality::Medium: return "medium";
        case EmbreeQuality::High: return "high";
    }
    return "high";
}

RTCBuildQuality to_rtc(EmbreeQuality q) {
    switch (q) {
        case EmbreeQuality::Low: return RTC_BUILD_QUALITY_LOW;
        case EmbreeQuality::Medium: return RTC_BUILD_QUALITY_MEDIUM;
        case EmbreeQuality::High: return RTC_BUILD_QUALITY_HIGH;
    }
    return RTC_BUILD_QUALITY_HIGH;
}

/// What the device callbacks write into. Heap-allocated so its address stays fixed for
/// the callbacks, and destroyed after the device (Embree reports frees on release).
struct DeviceState {
    std::mutex mutex;  // errors may be reported from Embree's build threads
    RTCError error = RTC_ERROR_NONE;
    std::string message;
    /// Net bytes Embree allocated on this device. Embree has no "how big is my BVH"
    /// query; the memory monitor callback is the only honest source.
    std::atomic<int64_t> bytes{0};
    /// The latest request the monitor saw: Embree allocates outside operator new and its
    /// RTC_ERROR_OUT_OF_MEMORY carries no size, so this is the size an error names.
    std::atomic<int64_t> last_request{0};
};

void on_error(void* user, RTCError code, const char* str) {
    auto* s = static_cast<DeviceState*>(user);
    std::lock_guard lock(s->mutex);
    // Keep the first error: later ones are usually consequences of it.
    if (s->error == RTC_ERROR_NONE) {
        s->error = code;
        s->message = str ? str : "";
    }
}

bool on_memory(void* user, ssize_t bytes, bool /*post*/) {
    auto* s = static_cast<DeviceState*>(user);
    s->bytes.fetch_add(int64_t(bytes), std::memory_order_relaxed);
    if (bytes > 0) s->last_request.store(int64_t(bytes), std::memory_order_relaxed);
    return true;  // never veto an allocation
}

/// Per-ray payload for our callbacks. Embree passes the RTCIntersectContext pointer we
/// gave rtcIntersect1/rtcOccluded1 through to user-geometry callbacks unchanged, so a
/// struct that starts with it can be cast back (Embree's documented extension pattern).
struct CallContext {
    RTCIntersectContext rtc;  // must stay the first member
    const RayContext* rc;
    uint64_t tests;  // primitive tests done by our callbacks for this ray
};
static_assert(std::is_standard_layout_v<CallContext>);

/// Our ray as Embree's: t range, full mask, no motion blur. Shared by intersect/occluded.
void to_rtc_ray(const Ray& ray, RTCRay& r) {
    r.org_x = ray.org.x; r.org_y = ray.org.y; r.org_z = ray.org.z;
    r.dir_x = ray.dir.x; r.dir_y = ray.dir.y; r.dir_z = ray.dir.z;
    r.tnear = ray.t_min;
    r.tfar = ray.t_max;
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
}

/// A fresh context carrying the per-ray data our callbacks need.
void init_context(CallContext& ctx, const RayContext& rc) {
    rtcInitIntersectContext(&ctx.rtc);
    ctx.rc = &rc;
    ctx.tests = 0;
}

/// What a user geometry's callbacks need. `prims` maps Embree's primID (an index into
/// the primitives we kept) to the primitive index in the view; null = identity.
struct UserGeom {
    const GeometryView* view;
    uint32_t geom_id;
    const uint32_t* prims;
};

inline uint32_t user_prim(const UserGeom& g, unsigned prim) { return g.prims ? g.prims[prim] : prim; }

void user_bounds(const RTCBoundsFunctionArguments* args) {
    const auto& g = *static_cast<const UserGeom*>(args->geometryUserPtr);
    Bounds3f b = primitive_bounds(*g.view, user_prim(g, args->primID));
    RTCBounds* o = args->bounds_o;
    o->lower_x = b.lo.x; o->lower_y = b.lo.y; o->lower_z = b.lo.z;
    o->upper_x = b.hi.x; o->upper_y = b.hi.y; o->upper_z = b.hi.z;
}

/// The renderer's test of a candidate hit on masked geometry (GeometryView::filter).
inline bool keep_hit(const UserGeom& g, uint32_t prim, float u, float v, const Ray& ray) {
    return !g.view->masked() || g.view->filter(g.view->filter_user, g.geom_id, prim, kInvalidId, u, v, ray);
}

/// Intersection and occlusion filter of masked triangle geometry (Embree 3 API,
/// rtcSetGeometryIntersectFilterFunction / rtcSetGeometryOccludedFilterFunction): set
/// on masked geometry only, so Embree calls nothing for the opaque rest. Embree calls it
/// for each candidate before committing it; clearing valid[i] makes it go on as if the
/// triangle were not there. primID is Embree's index, which names the kept copy's
/// triangles where some were dropped (UserGeom::prims maps it back).
void filter_triangles(const RTCFilterFunctionNArguments* args) {
    const auto& g = *static_cast<const UserGeom*>(args->geometryUserPtr);
    const auto* ctx = reinterpret_cast<const CallContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        const uint32_t prim = user_prim(g, RTCHitN_primID(args->hit, args->N, i));
        if (!keep_hit(g, prim, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i), ctx->rc->ray))
            args->valid[i] = 0;
    }
}

// We only ever trace single rays (rtcIntersect1 / rtcOccluded1), so N == 1 and the
// RTCRayHitN / RTCRayN pointers are an RTCRayHit / RTCRay.
template <TriangleTest Test>
void user_intersect(const RTCIntersectFunctionNArguments* args) {
    if (args->N != 1 || !args->valid[0]) return;
    const auto& g = *static_cast<const UserGeom*>(args->geometryUserPtr);
    auto* ctx = reinterpret_cast<CallContext*>(args->context);
    auto* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);
    const uint32_t prim = user_prim(g, args->primID);
    ++ctx->tests;
    Hit h;
    h.t = rh->ray.tfar;
    if (!intersect_primitive<Test>(*g.view, g.geom_id, prim, *ctx->rc, h)) return;
    if (!keep_hit(g, prim, h.u, h.v, ctx->rc->ray)) return;
    rh->ray.tfar = h.t;
    rh->hit.u = h.u;
    rh->hit.v = h.v;
    // User geometries (spheres, the counting mode) report no Ng: intersect() computes ours
    // with finish_hit.
    rh->hit.Ng_x = rh->hit.Ng_y = rh->hit.Ng_z = 0.0f;
    rh->hit.geomID = g.geom_id;
    rh->hit.primID = prim;  // already the view's own index: no remapping later
    rh->hit.instID[0] = args->context->instID[0];
}

template <TriangleTest Test>
void user_occluded(const RTCOccludedFunctionNArguments* args) {
    if (args->N != 1 || !args->valid[0]) return;
    const auto& g = *static_cast<const UserGeom*>(args->geometryUserPtr);
    auto* ctx = reinterpret_cast<CallContext*>(args->context);
    auto* ray = reinterpret_cast<RTCRay*>(args->ray);
    ++ctx->tests;
    Hit h;
    h.t = ray->tfar;
    const uint32_t prim = user_prim(g, args->primID);
    if (intersect_primitive<Test>(*g.view, g.geom_id, prim, *ctx->rc, h) && keep_hit(g, prim, h.u, h.v, ctx->rc->ray))
        ray->tfar = -std::numeric_limits<float>::infinity();
}

// Owning handles, so a constructor that throws half-way still releases what it made.
struct DeviceHandle {
    RTCDevice h = nullptr;
    ~DeviceHandle() { if (h) rtcReleaseDevice(h); }
};
struct SceneHandle {
    RTCScene h = nullptr;
    ~SceneHandle() { if (h) rtcReleaseScene(h); }
};

class EmbreeAccelerator final : public Accelerator {
public:
    EmbreeAccelerator(std::span<const GeometryView> geometry, const AccelOptions& options,
                      const std::string& extra_config)
        : geometry_(geometry.begin(), geometry.end()),
          test_(options.triangle),
          counting_(options.embree_count),
          state_(std::make_unique<DeviceState>()) {
        const auto start = std::chrono::steady_clock::now();

        // build_threads is honoured by committing inside a task arena, not by Embree's
        // "threads=N": with TBB that installs a process-wide tbb::global_control
        // (max_allowed_parallelism = N) for the device's lifetime, which would also cap
        // the renderer's own arena for as long as this accelerator lives.
        const std::string config = extra_config;
        device_ = device_holder_.h = rtcNewDevice(config.c_str());
        if (!device_) {
            // No device, no callback: the code is all Embree 3 can tell us.
            const RTCError code = rtcGetDeviceError(nullptr);
            const std::string msg = std::string("Embree error ") + error_name(code) +
                                    ": rtcNewDevice failed (config \"" + config + "\")";
            if (code == RTC_ERROR_OUT_OF_MEMORY) throw OutOfMemory(0, msg);
            throw AccelError(msg);
        }
        rtcSetDeviceErrorFunction(device_, on_error, state_.get());
        rtcSetDeviceMemoryMonitorFunction(device_, on_memory, state_.get());
        // An Embree built without filter functions would ignore them and draw masked
        // geometry opaque: refused instead.
        for (const GeometryView& g : geometry_)
            if (g.masked() && !rtcGetDeviceProperty(device_, RTC_DEVICE_PROPERTY_FILTER_FUNCTION_SUPPORTED))
                throw AccelError("this Embree was built without filter functions (EMBREE_FILTER_FUNCTION), "
                                 "which masked geometry needs; use the custom or naive backend");

        scene_ = scene_holder_.h = rtcNewScene(device_);
        check("rtcNewScene");
        rtcSetSceneFlags(scene_, options.embree_robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
        rtcSetSceneBuildQuality(scene_, to_rtc(options.embree_quality));
        check("scene setup");

        // The same validity rules as every other backend, so BuildInfo.dropped and the
        // set of hittable primitives agree with naive and the custom BVH.
        std::vector<PrimRef> refs = collect_primitives(geometry_, info_.dropped);
        info_.primitives = refs.size();

        user_.resize(geometry_.size());  // never resized again: callbacks point into it
        prim_map_.resize(geometry_.size());
        indices_.resize(geometry_.size());
        size_t begin = 0;  // refs come grouped by view, in primitive order
        for (uint32_t gi = 0; gi < geometry_.size(); ++gi) {
            const GeometryView& g = geometry_[gi];
            size_t end = begin;
            while (end < refs.size() && refs[end].geom == gi) ++end;
            const size_t kept = end - begin;
            if (kept == 0) continue;  // nothing hittable: no Embree geometry at all
            // A list of kept primitives only when some were dropped: identity otherwise.
            if (kept != g.num_prims) {
                prim_map_[gi].reserve(kept);
                for (size_t i = begin; i < end; ++i) prim_map_[gi].push_back(refs[i].prim);
            }
            begin = end;
            if (counting_ || g.type == GeometryType::Spheres)
                add_user_geometry(gi, uint32_t(kept), options);
            else
                add_triangles(gi, options);
        }
        std::vector<PrimRef>().swap(refs);

        if (options.build_threads > 0) {
            tbb::task_arena arena(options.build_threads);
            arena.execute([&] { rtcCommitScene(scene_); });
        } else {
            rtcCommitScene(scene_);
        }
        check("rtcCommitScene");

        if (info_.primitives > 0) {
            RTCBounds b;
            rtcGetSceneBounds(scene_, &b);
            check("rtcGetSceneBounds");
            bounds_.lo = {b.lower_x, b.lower_y, b.lower_z};
            bounds_.hi = {b.upper_x, b.upper_y, b.upper_z};
        }

        const char* quality = quality_name(options.embree_quality);
        const char* robust = options.embree_robust ? ", robust" : "";
        if (counting_) {
            info_.backend = std::string("embree(count, ") + quality + ", " +
                            (test_ == TriangleTest::Watertight ? "watertight" : "fast") + robust + ")";
        } else {
            info_.backend = std::string("embree(") + quality + robust + ")";
        }
        info_.counts_prims = counting_;  // in normal mode Embree's own tests are invisible
        info_.counts_nodes = false;
        uint64_t own = user_.capacity() * sizeof(UserGeom);
        for (const auto& m : prim_map_) own += m.capacity() * sizeof(uint32_t);
        for (const auto& ix : indices_) own += ix.capacity() * sizeof(uint32_t);
        const int64_t embree_bytes = state_->bytes.load();
        info_.bytes = own + uint64_t(embree_bytes > 0 ? embree_bytes : 0);
        info_.build_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }

    EmbreeAccelerator(const EmbreeAccelerator&) = delete;
    EmbreeAccelerator& operator=(const EmbreeAccelerator&) = delete;

    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        RayContext rc(ray, test_);
        CallContext ctx;
        init_context(ctx, rc);
        RTCRayHit rh;
        to_rtc_ray(ray, rh.ray);
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene_, &ctx.rtc, &rh);
        if (counting_) stats.prim_tests += ctx.tests;
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
        Hit h;
        h.t = rh.ray.tfar;
        h.geom_id = rh.hit.geomID;
        h.prim_id = rh.hit.primID;
        const GeometryView& g = geometry_[h.geom_id];
        if (g.type == GeometryType::Triangles) {
            h.u = rh.hit.u;
            h.v = rh.hit.v;
            // Embree triangles built from a filtered copy number the kept triangles.
            const std::vector<uint32_t>& map = prim_map_[h.geom_id];
            if (!counting_ && !map.empty()) h.prim_id = map[h.prim_id];
        }
        // Embree's Ng points as ours, cross(v1 - v0, v2 - v0), equal up to rounding
        // (EmbreeRays.* check the orientation). Taking it from Embree (which computes it from its own leaf data)
        // rather than recomputing it from the scene's arrays spares a read of the hit
        // triangle's indices and vertices, which on large scenes misses the caches: the
        // custom BVH takes its normal from its leaf block for the same reason, and the
        // comparison gives each backend its cheapest correct path (accel/DECISIONS.md,
        // "hit data from the leaf block").
        // The counting mode's user geometry reports no Ng of ours: finish_hit there.
        if (g.type == GeometryType::Triangles && !counting_)
            h.ng = Vec3f(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        else
            finish_hit(geometry_, ray, h);
        hit = h;
        return true;
    }

    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        RayContext rc(ray, test_);
        CallContext ctx;
        init_context(ctx, rc);
        RTCRay r;
        to_rtc_ray(ray, r);
        rtcOccluded1(scene_, &ctx.rtc, &r);
        if (counting_) stats.prim_tests += ctx.tests;
        return r.tfar == -std::numeric_limits<float>::infinity();
    }

    const BuildInfo& info() const override { return info_; }
    Bounds3f bounds() const override { return bounds_; }

private:
    /// Turns an error recorded by the callback into an exception, naming the step.
    void check(const char* what) {
        std::lock_guard lock(state_->mutex);
        if (state_->error == RTC_ERROR_NONE) return;
        std::string msg = std::string("Embree error ") + error_name(state_->error) + ": " +
                          state_->message + " (during " + what + ")";
        const RTCError code = state_->error;
        state_->error = RTC_ERROR_NONE;
        state_->message.clear();
        if (code == RTC_ERROR_OUT_OF_MEMORY)
            throw OutOfMemory(uint64_t(std::max<int64_t>(0, state_->last_request.load())), msg);
        throw AccelError(msg);
    }

    /// Attaches `geom` under `id` (our view index = Embree geomID) and drops our handle:
    /// the scene keeps its own reference.
    void attach(RTCGeometry geom, uint32_t id, const char* what) {
        rtcCommitGeometry(geom);
        rtcAttachGeometryByID(scene_, geom, id);
        rtcReleaseGeometry(geom);
        check(what);
    }

    void add_triangles(uint32_t gi, const AccelOptions& options) {
        const GeometryView& g = geometry_[gi];
        RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
        if (!geom) check("rtcNewGeometry(triangle)");
        rtcSetGeometryBuildQuality(geom, to_rtc(options.embree_quality));
        rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, g.positions,
                                   0, sizeof(Vec3f), g.num_vertices);
        bool in_range = true;
        const uint64_t n_idx = 3ull * g.num_prims;
        for (uint64_t i = 0; i < n_idx && in_range; ++i) in_range = g.indices[i] < g.num_vertices;
        std::vector<uint32_t>& map = prim_map_[gi];
        if (in_range) {
            // Degenerate triangles stay in: Embree never reports a hit on zero area (nor
            // builds non-finite ones), and sharing the caller's buffer is worth more.
            map.clear();
            map.shrink_to_fit();
            rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, g.indices,
                                       0, 3 * sizeof(uint32_t), g.num_prims);
        } else {
            // An out-of-range index is undefined behaviour for Embree: give it a copy of
            // just the primitives collect_primitives kept; `map` takes its primIDs back.
            std::vector<uint32_t>& ix = indices_[gi];
            ix.reserve(3 * map.size());
            for (uint32_t p : map)
                ix.insert(ix.end(), g.indices + 3 * size_t(p), g.indices + 3 * size_t(p) + 3);
            rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, ix.data(),
                                       0, 3 * sizeof(uint32_t), map.size());
        }
        if (g.masked()) {
            UserGeom& u = user_[gi];
            u.view = &g;
            u.geom_id = gi;
            u.prims = map.empty() ? nullptr : map.data();
            rtcSetGeometryUserData(geom, &u);
            rtcSetGeometryIntersectFilterFunction(geom, filter_triangles);
            rtcSetGeometryOccludedFilterFunction(geom, filter_triangles);
        }
        attach(geom, gi, "triangle geometry");
    }

    void add_user_geometry(uint32_t gi, uint32_t count, const AccelOptions& options) {
        UserGeom& u = user_[gi];
        u.view = &geometry_[gi];
        u.geom_id = gi;
        u.prims = prim_map_[gi].empty() ? nullptr : prim_map_[gi].data();
        RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
        if (!geom) check("rtcNewGeometry(user)");
        rtcSetGeometryBuildQuality(geom, to_rtc(options.embree_quality));
        rtcSetGeometryUserPrimitiveCount(geom, count);
        rtcSetGeometryUserData(geom, &u);
        rtcSetGeometryBoundsFunction(geom, user_bounds, nullptr);
        if (test_ == TriangleTest::Watertight) {
            rtcSetGeometryIntersectFunction(geom, user_intersect<TriangleTest::Watertight>);
            rtcSetGeometryOccludedFunction(geom, user_occluded<TriangleTest::Watertight>);
        } else {
            rtcSetGeometryIntersectFunction(geom, user_intersect<TriangleTest::Fast>);
            rtcSetGeometryOccludedFunction(geom, user_occluded<TriangleTest::Fast>);
        }
        attach(geom, gi, "user geometry");
    }

    // Declaration order is destruction order reversed: the scene goes first, then the
    // device, and only then the data their callbacks and shared buffers point into.
    std::vector<GeometryView> geometry_;
    TriangleTest test_;
    bool counting_;
    std::unique_ptr<DeviceState> state_;
    std::vector<UserGeom> user_;
    std::vector<std::vector<uint32_t>> prim_map_;
    std::vector<std::vector<uint32_t>> indices_;
    DeviceHandle device_holder_;
    SceneHandle scene_holder_;
    RTCDevice device_ = nullptr;  // aliases of the holders' handles, for brevity
    RTCScene scene_ = nullptr;
    Bounds3f bounds_;
    BuildInfo info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView> geometry,
                                         const AccelOptions& options,
                                         const std::string& extra_device_config, const InstanceSet& instances) {
    if (!instances.empty()) throw AccelError("embree: instances not implemented yet");
    return std::make_unique<EmbreeAccelerator>(geometry, options, extra_device_config);
}

std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView> geometry,
                                         const AccelOptions& options, const InstanceSet& instances) {
    return make_embree(geometry, options, std::string(), instances);
}

}  // namespace accel
