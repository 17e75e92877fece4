// Embree 3 backend. The only translation unit of the project that includes Embree.
#include "accel/embree/embree.h"

#include <embree3/rtcore.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <limits>
#include <malloc.h>
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
/// `inst_base` is the Embree geomID of instance 0 in the top scene (instances are
/// attached after the views' slots), so a hit's instID[0] - inst_base is our instance.
struct UserGeom {
    const GeometryView* view;
    uint32_t geom_id;
    const uint32_t* prims;
    uint32_t inst_base;
};

/// Our instance index from Embree's instID[0] (the instance's geomID in the top scene;
/// RTC_INVALID_GEOMETRY_ID at the top level, which is our kInvalidId too).
inline uint32_t our_instance(unsigned embree_inst, uint32_t inst_base) {
    return embree_inst == RTC_INVALID_GEOMETRY_ID ? kInvalidId : uint32_t(embree_inst) - inst_base;
}

inline uint32_t user_prim(const UserGeom& g, unsigned prim) { return g.prims ? g.prims[prim] : prim; }

void user_bounds(const RTCBoundsFunctionArguments* args) {
    const auto& g = *static_cast<const UserGeom*>(args->geometryUserPtr);
    Bounds3f b = primitive_bounds(*g.view, user_prim(g, args->primID));
    RTCBounds* o = args->bounds_o;
    o->lower_x = b.lo.x; o->lower_y = b.lo.y; o->lower_z = b.lo.z;
    o->upper_x = b.hi.x; o->upper_y = b.hi.y; o->upper_z = b.hi.z;
}

/// The renderer's test of a candidate hit on masked geometry (GeometryView::filter).
/// `world` is always the caller's ray, never Embree's object-space copy of it: HitFilter
/// promises the world ray bit for bit, so that a filter sees one ray for every placement.
inline bool keep_hit(const UserGeom& g, uint32_t prim, uint32_t inst, float u, float v, const Ray& world) {
    return !g.view->masked() || g.view->filter(g.view->filter_user, g.geom_id, prim, inst, u, v, world);
}

/// Intersection and occlusion filter of masked triangle geometry (Embree 3 API,
/// rtcSetGeometryIntersectFilterFunction / rtcSetGeometryOccludedFilterFunction): set
/// on masked geometry only, so Embree calls nothing for the opaque rest. Embree calls it
/// for each candidate before committing it; clearing valid[i] makes it go on as if the
/// triangle were not there. primID is Embree's index, which names the kept copy's
/// triangles where some were dropped (UserGeom::prims maps it back).
/// Inside an instance Embree hands the filter the ray and hit in object space ("If the
/// hit geometry is instanced, the instID member of the hit is valid, and the ray and the
/// potential hit are in object space", rtcSetGeometryIntersectFilterFunction(3)): we
/// take only the hit's u, v (invariant under the affine map), its primID and instID from
/// it, and give the HitFilter the caller's world ray that CallContext carries.
void filter_triangles(const RTCFilterFunctionNArguments* args) {
    const auto& g = *static_cast<const UserGeom*>(args->geometryUserPtr);
    const auto* ctx = reinterpret_cast<const CallContext*>(args->context);
    for (unsigned i = 0; i < args->N; ++i) {
        if (args->valid[i] != -1) continue;
        const uint32_t prim = user_prim(g, RTCHitN_primID(args->hit, args->N, i));
        const uint32_t inst = our_instance(RTCHitN_instID(args->hit, args->N, i, 0), g.inst_base);
        if (!keep_hit(g, prim, inst, RTCHitN_u(args->hit, args->N, i), RTCHitN_v(args->hit, args->N, i),
                      ctx->rc->ray))
            args->valid[i] = 0;
    }
}

/// One primitive of a user geometry against the ray Embree hands its callback. At the top
/// level that is the caller's ray as to_rtc_ray gave it, so the RayContext made once per
/// ray serves (the flat path, unchanged). Inside an instance it is Embree's own
/// object-space copy (the instance's world-to-object transform applied to origin and
/// direction, t unscaled: RTC_GEOMETRY_TYPE_INSTANCE(3)), which Embree's traversal of the
/// prototype's BVH used as well; testing it, not the world ray, is what makes the test
/// agree with the boxes that led here, and one transformed ray for the whole instance
/// keeps the watertight test watertight within it. Its WatertightRay is made here, per
/// test: counting mode measures tests, not time.
template <TriangleTest Test>
inline bool test_user_prim(const UserGeom& g, uint32_t prim, const CallContext& ctx, const RTCRay& r,
                           unsigned embree_inst, Hit& h) {
    if (embree_inst == RTC_INVALID_GEOMETRY_ID) return intersect_primitive<Test>(*g.view, g.geom_id, prim, *ctx.rc, h);
    Ray local;
    local.org = Vec3f(r.org_x, r.org_y, r.org_z);
    local.dir = Vec3f(r.dir_x, r.dir_y, r.dir_z);
    local.t_min = r.tnear;
    local.t_max = r.tfar;
    const RayContext rc(local, Test);
    return intersect_primitive<Test>(*g.view, g.geom_id, prim, rc, h);
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
    const unsigned embree_inst = args->context->instID[0];
    ++ctx->tests;
    Hit h;
    h.t = rh->ray.tfar;
    if (!test_user_prim<Test>(g, prim, *ctx, rh->ray, embree_inst, h)) return;
    if (!keep_hit(g, prim, our_instance(embree_inst, g.inst_base), h.u, h.v, ctx->rc->ray)) return;
    rh->ray.tfar = h.t;
    rh->hit.u = h.u;
    rh->hit.v = h.v;
    // User geometries (spheres, the counting mode) report no Ng: intersect() computes ours
    // with finish_hit.
    rh->hit.Ng_x = rh->hit.Ng_y = rh->hit.Ng_z = 0.0f;
    // Embree's geomID of this geometry in its scene (our view index at the top level, the
    // index within its prototype inside an instance): intersect() maps both alike.
    rh->hit.geomID = args->geomID;
    rh->hit.primID = prim;  // already the view's own index: no remapping later
    rh->hit.instID[0] = embree_inst;
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
    const unsigned embree_inst = args->context->instID[0];
    if (test_user_prim<Test>(g, prim, *ctx, *ray, embree_inst, h) &&
        keep_hit(g, prim, our_instance(embree_inst, g.inst_base), h.u, h.v, ctx->rc->ray))
        ray->tfar = -std::numeric_limits<float>::infinity();
}

// Owning handles, so a constructor that throws half-way still releases what it made.
struct DeviceHandle {
    RTCDevice h = nullptr;
    ~DeviceHandle() { if (h) rtcReleaseDevice(h); }
};
struct SceneHandle {
    RTCScene h = nullptr;
    SceneHandle() = default;
    SceneHandle(SceneHandle&& o) noexcept : h(o.h) { o.h = nullptr; }
    SceneHandle(const SceneHandle&) = delete;
    SceneHandle& operator=(const SceneHandle&) = delete;
    ~SceneHandle() { if (h) rtcReleaseScene(h); }
};

/// Bytes the C heap holds now. Embree's memory monitor reports its buffers and BVHs but
/// not its geometry objects (allocated with plain alignedMalloc), and an instance is
/// mostly geometry object: measured on Embree 3.13.5, about 290 bytes of heap per
/// RTC_GEOMETRY_TYPE_INSTANCE before the top scene's commit, none of it seen by the
/// monitor, against about 95 bytes of monitored BVH after it. So the instances' objects
/// are counted as the heap's growth while we create them. glibc's mallinfo2 sums every
/// arena (glibc 2.33+); another thread allocating meanwhile would be counted too, which
/// a build that runs before rendering does not meet. 0 where there is no mallinfo2.
uint64_t heap_in_use() {
#if defined(__GLIBC__) && (__GLIBC__ > 2 || (__GLIBC__ == 2 && __GLIBC_MINOR__ >= 33))
    const struct mallinfo2 m = mallinfo2();
    return uint64_t(m.uordblks) + uint64_t(m.hblkhd);
#else
    return 0;
#endif
}

/// cof(L) n, where L is the instance's linear part: the object-space normal n carried to
/// world space as Hit::ng's convention wants it (the cross product of the transformed
/// edges: cross(L a, L b) = cof(L) cross(a, b), so a mirror's normal follows the mirrored
/// winding). It equals to_world_normal's W^T n / det(W) with W = L^-1 (cof(L) = det(L)
/// L^-T), but needs no inverse: the rows of cof(L) are r1 x r2, r2 x r0, r0 x r1 of L's
/// rows, read from the caller's InstanceView, so we keep nothing per instance (at 10^7
/// instances a stored inverse would be 480 MB). Evaluated in double, rounded once.
Vec3f cofactor_normal(const Affine3f& a, const Vec3f& n) {
    const double r[3][3] = {{a.m[0][0], a.m[0][1], a.m[0][2]},
                            {a.m[1][0], a.m[1][1], a.m[1][2]},
                            {a.m[2][0], a.m[2][1], a.m[2][2]}};
    const double nx = n.x, ny = n.y, nz = n.z;
    double out[3];
    for (int k = 0; k < 3; ++k) {
        const double* p = r[(k + 1) % 3];
        const double* q = r[(k + 2) % 3];
        out[k] = (p[1] * q[2] - p[2] * q[1]) * nx + (p[2] * q[0] - p[0] * q[2]) * ny + (p[0] * q[1] - p[1] * q[0]) * nz;
    }
    return {float(out[0]), float(out[1]), float(out[2])};
}

class EmbreeAccelerator final : public Accelerator {
public:
    EmbreeAccelerator(std::span<const GeometryView> geometry, const AccelOptions& options,
                      const std::string& extra_config, const InstanceSet& instances)
        : geometry_(geometry.begin(), geometry.end()),
          prototypes_(instances.prototypes),
          instances_(instances.instances),
          inst_base_(uint32_t(geometry.size())),
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

        scene_ = scene_holder_.h = new_scene(options);

        // Instances (Embree 3 API, RTC_GEOMETRY_TYPE_INSTANCE(3)): one child scene per
        // prototype holds its geometries, numbered from 0 within it (Embree sizes a
        // scene's geometry table by its largest ID, so global IDs in every child would
        // cost prototypes x views slots); the top scene holds the world-space views under
        // their own index, as a flat scene does, and instance i under inst_base_ + i, so
        // a hit's instID[0] and geomID map back by one subtraction and one addition.
        // A flat scene makes none of this: the top scene is built exactly as before.
        std::vector<int32_t> owner;  // prototype of each view, -1 = world space
        if (!instances.empty()) {
            if (uint64_t(inst_base_) + instances_.size() >= uint64_t(RTC_INVALID_GEOMETRY_ID))
                throw AccelError("embree: too many views and instances for 32-bit geometry IDs");
            owner.assign(geometry_.size(), -1);
            proto_scenes_.reserve(prototypes_.size());
            for (uint32_t p = 0; p < prototypes_.size(); ++p) {
                for (uint32_t k = 0; k < prototypes_[p].num_geoms; ++k) owner[prototypes_[p].first_geom + k] = int32_t(p);
                proto_scenes_.emplace_back().h = new_scene(options);
            }
        }
        std::vector<uint64_t> proto_prims(prototypes_.size(), 0);  // kept primitives per prototype
        bool top_has_geometry = false;

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
            const int32_t p = owner.empty() ? -1 : owner[gi];
            RTCScene target = p < 0 ? scene_ : proto_scenes_[size_t(p)].h;
            const uint32_t id = p < 0 ? gi : gi - prototypes_[size_t(p)].first_geom;
            if (p < 0)
                top_has_geometry = true;
            else
                proto_prims[size_t(p)] += kept;
            if (counting_ || g.type == GeometryType::Spheres)
                add_user_geometry(gi, uint32_t(kept), options, target, id);
            else
                add_triangles(gi, options, target, id);
        }
        std::vector<PrimRef>().swap(refs);

        // build_threads: every commit inside one arena (see above). The children first:
        // an instance must see its scene committed before its own commit, and the top
        // scene's commit last (RTC_GEOMETRY_TYPE_INSTANCE(3)).
        auto build = [&] {
            if (!instances.empty()) {
                for (SceneHandle& ps : proto_scenes_) rtcCommitScene(ps.h);
                check("rtcCommitScene(prototype)");
                top_has_geometry |= add_instances(proto_prims);
            }
            rtcCommitScene(scene_);
        };
        if (options.build_threads > 0) {
            tbb::task_arena arena(options.build_threads);
            arena.execute(build);
        } else {
            build();
        }
        check("rtcCommitScene");

        if (top_has_geometry) {
            RTCBounds b;
            rtcGetSceneBounds(scene_, &b);
            check("rtcGetSceneBounds");
            bounds_.lo = {b.lower_x, b.lower_y, b.lower_z};
            bounds_.hi = {b.upper_x, b.upper_y, b.upper_z};
        }
        if (!instances.empty()) {
            // Embree boxes an instance by its own float transform of the child's box; the
            // union with Affine3f::bounds (widened by the rounding of point(), as naive and
            // the custom BVH report it) keeps bounds() conservative on our terms as well.
            std::vector<Bounds3f> proto_bounds(proto_scenes_.size());
            for (size_t p = 0; p < proto_scenes_.size(); ++p) {
                if (proto_prims[p] == 0) continue;
                RTCBounds b;
                rtcGetSceneBounds(proto_scenes_[p].h, &b);
                proto_bounds[p].lo = {b.lower_x, b.lower_y, b.lower_z};
                proto_bounds[p].hi = {b.upper_x, b.upper_y, b.upper_z};
            }
            check("rtcGetSceneBounds(prototype)");
            for (const InstanceView& iv : instances_) {
                info_.instanced_primitives += proto_prims[iv.prototype];
                if (proto_prims[iv.prototype] > 0) bounds_.extend(iv.object_to_world.bounds(proto_bounds[iv.prototype]));
            }
            info_.instances = instances_.size();
        }

        const char* quality = quality_name(options.embree_quality);
        const char* robust = options.embree_robust ? ", robust" : "";
        // ", instances": the two-level traversal runs (a flat scene's label is unchanged).
        const char* two_level = instances.empty() ? "" : ", instances";
        if (counting_) {
            info_.backend = std::string("embree(count, ") + quality + ", " +
                            (test_ == TriangleTest::Watertight ? "watertight" : "fast") + robust + two_level + ")";
        } else {
            info_.backend = std::string("embree(") + quality + robust + two_level + ")";
        }
        info_.counts_prims = counting_;  // in normal mode Embree's own tests are invisible
        info_.counts_nodes = false;
        uint64_t own = user_.capacity() * sizeof(UserGeom);
        for (const auto& m : prim_map_) own += m.capacity() * sizeof(uint32_t);
        for (const auto& ix : indices_) own += ix.capacity() * sizeof(uint32_t);
        const int64_t embree_bytes = state_->bytes.load();
        info_.bytes = own + uint64_t(embree_bytes > 0 ? embree_bytes : 0) + instance_object_bytes_;
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
        // Inside an instance Embree names the instance's top-scene geomID (instID[0]) and
        // the geometry's index within its prototype's scene (RTC_GEOMETRY_TYPE_INSTANCE(3)).
        const Affine3f* object_to_world = nullptr;
        if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
            h.inst_id = rh.hit.instID[0] - inst_base_;
            const InstanceView& iv = instances_[h.inst_id];
            h.geom_id += prototypes_[iv.prototype].first_geom;
            object_to_world = &iv.object_to_world;
        }
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
        // Inside an instance either is in object space (Embree: "the unnormalized geometric
        // normal in object space", RTCHit(3); finish_hit: the prototype's own vertices; the
        // ray it takes matters for spheres only, which prototypes never hold) and goes to
        // world space by the cofactor of the instance's linear part.
        if (g.type == GeometryType::Triangles && !counting_)
            h.ng = Vec3f(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        else
            finish_hit(geometry_, ray, h);
        if (object_to_world) h.ng = cofactor_normal(*object_to_world, h.ng);
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

    /// A scene with the options' flags and build quality: the top scene and every
    /// prototype's (robust applies where the triangles are tested, i.e. in the children).
    RTCScene new_scene(const AccelOptions& options) {
        RTCScene scene = rtcNewScene(device_);
        check("rtcNewScene");
        rtcSetSceneFlags(scene, options.embree_robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
        rtcSetSceneBuildQuality(scene, to_rtc(options.embree_quality));
        check("scene setup");
        return scene;
    }

    /// Attaches `geom` to `scene` under `id` (our view index at the top level, the index
    /// within the prototype in a child scene) and drops our handle: the scene keeps its
    /// own reference.
    void attach(RTCGeometry geom, RTCScene scene, uint32_t id, const char* what) {
        rtcCommitGeometry(geom);
        rtcAttachGeometryByID(scene, geom, id);
        rtcReleaseGeometry(geom);
        check(what);
    }

    /// One RTC_GEOMETRY_TYPE_INSTANCE per instance of a non-empty prototype, in the top
    /// scene under inst_base_ + i, its transform the caller's row-major 3x4 as it is
    /// (RTC_FORMAT_FLOAT3X4_ROW_MAJOR, rtcSetGeometryTransform(3)). An instance of a
    /// prototype with nothing hittable gets no Embree object: it could never be hit.
    /// Returns whether any was attached. The heap these objects take is counted in
    /// instance_object_bytes_ (see heap_in_use).
    bool add_instances(const std::vector<uint64_t>& proto_prims) {
        const uint64_t heap_before = heap_in_use();
        bool any = false;
        for (uint32_t i = 0; i < instances_.size(); ++i) {
            const InstanceView& iv = instances_[i];
            if (proto_prims[iv.prototype] == 0) continue;
            RTCGeometry geom = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
            if (!geom) check("rtcNewGeometry(instance)");
            rtcSetGeometryInstancedScene(geom, proto_scenes_[iv.prototype].h);
            rtcSetGeometryTransform(geom, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, &iv.object_to_world.m[0][0]);
            rtcCommitGeometry(geom);
            rtcAttachGeometryByID(scene_, geom, inst_base_ + i);
            rtcReleaseGeometry(geom);
            any = true;
            // One check per instance would take the state mutex 10^7 times: errors are
            // sticky (the first is kept), so once every 64k and once at the end suffice.
            if ((i & 0xFFFFu) == 0xFFFFu) check("instance geometry");
        }
        check("instance geometry");
        const uint64_t heap_after = heap_in_use();
        instance_object_bytes_ = heap_after > heap_before ? heap_after - heap_before : 0;
        return any;
    }

    void add_triangles(uint32_t gi, const AccelOptions& options, RTCScene scene, uint32_t id) {
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
            u.inst_base = inst_base_;
            rtcSetGeometryUserData(geom, &u);
            rtcSetGeometryIntersectFilterFunction(geom, filter_triangles);
            rtcSetGeometryOccludedFilterFunction(geom, filter_triangles);
        }
        attach(geom, scene, id, "triangle geometry");
    }

    void add_user_geometry(uint32_t gi, uint32_t count, const AccelOptions& options, RTCScene scene, uint32_t id) {
        UserGeom& u = user_[gi];
        u.view = &geometry_[gi];
        u.geom_id = gi;
        u.prims = prim_map_[gi].empty() ? nullptr : prim_map_[gi].data();
        u.inst_base = inst_base_;
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
        attach(geom, scene, id, "user geometry");
    }

    // Declaration order is destruction order reversed: the scene goes first, then the
    // device, and only then the data their callbacks and shared buffers point into.
    std::vector<GeometryView> geometry_;
    /// The caller's instances, not copied (InstanceSet: they outlive us): a hit reads its
    /// instance's prototype and transform from them.
    std::span<const PrototypeView> prototypes_;
    std::span<const InstanceView> instances_;
    uint32_t inst_base_;  ///< Embree geomID of instance 0 in the top scene
    TriangleTest test_;
    bool counting_;
    std::unique_ptr<DeviceState> state_;
    std::vector<UserGeom> user_;
    std::vector<std::vector<uint32_t>> prim_map_;
    std::vector<std::vector<uint32_t>> indices_;
    DeviceHandle device_holder_;
    /// Released after the top scene (declared before it), which references them.
    std::vector<SceneHandle> proto_scenes_;
    SceneHandle scene_holder_;
    RTCDevice device_ = nullptr;  // aliases of the holders' handles, for brevity
    RTCScene scene_ = nullptr;
    Bounds3f bounds_;
    BuildInfo info_;
    uint64_t instance_object_bytes_ = 0;  ///< heap the instance geometry objects took
};

}  // namespace

std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView> geometry,
                                         const AccelOptions& options,
                                         const std::string& extra_device_config, const InstanceSet& instances) {
    return std::make_unique<EmbreeAccelerator>(geometry, options, extra_device_config, instances);
}

std::unique_ptr<Accelerator> make_embree(std::span<const GeometryView> geometry,
                                         const AccelOptions& options, const InstanceSet& instances) {
    return make_embree(geometry, options, std::string(), instances);
}

}  // namespace accel
