// The backend edge: one interface, one virtual call per ray, chosen by name.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "accel/instance.h"
#include "accel/math.h"
#include "accel/ray.h"
#include "accel/stats.h"

namespace accel {

enum class GeometryType : uint8_t { Triangles, Spheres };

/// A test of candidate hits on one geometry, supplied by whoever builds the views (the
/// renderer: alpha masks and stochastic transparency, renderer/scene_geometry.h); accel/
/// knows nothing of what it decides. Called with a triangle the ray hits at (u, v) in
/// [t_min, t_max], before it becomes the closest hit (intersect) or an occluder
/// (occluded); false drops the hit and traversal goes on as if the triangle were not
/// there. Backends call it in no particular order, may call it more than once for one
/// hit and from many threads at once, so it must be a pure function of its arguments
/// (no per-call state, no random numbers of its own): that is what makes every backend,
/// thread count and tile split see the same surface. `ray` is the caller's ray,
/// unchanged, in world space even for a hit inside an instance; `inst_id` names that
/// instance (kInvalidId for world-space geometry), so that two placements of one leaf
/// on one ray can decide apart. The same role as Embree's filter functions (Embree 3 API,
/// rtcSetGeometryIntersectFilterFunction / rtcSetGeometryOccludedFilterFunction) and
/// pbrt-v4's alpha test in GeometricPrimitive::Intersect/IntersectP.
using HitFilter = bool (*)(const void* user, uint32_t geom_id, uint32_t prim_id, uint32_t inst_id, float u,
                           float v, const Ray& ray);

/// Non-owning view of one geometry. The memory must outlive the accelerator (Embree
/// shares it without copying).
///  - Triangles: `positions` holds `num_vertices` Vec3f; `indices` holds 3*num_prims
///    vertex indices. The positions buffer must be readable for 4 bytes past the last
///    vertex (Embree reads vertices with 16-byte loads); scenes::Mesh guarantees it.
///  - Spheres: `spheres` holds num_prims (centre.xyz, radius) quadruples; other fields
///    unused.
struct GeometryView {
    GeometryType type = GeometryType::Triangles;
    const Vec3f* positions = nullptr;
    uint32_t num_vertices = 0;
    const uint32_t* indices = nullptr;
    const float* spheres = nullptr;
    uint32_t num_prims = 0;
    /// Masked geometry (triangles only): every candidate hit goes through filter(user,
    /// ...). Null (the default) = opaque: no backend calls anything for it, and the
    /// custom BVH runs its unfiltered kernel unless some geometry is masked.
    HitFilter filter = nullptr;
    const void* filter_user = nullptr;

    bool masked() const { return filter != nullptr; }

    /// A triangle mesh: num_vertices positions (plus one padding element after them, for
    /// Embree's 16-byte loads) and three indices per triangle.
    static GeometryView triangles(const Vec3f* positions, uint32_t num_vertices, const uint32_t* indices,
                                  uint32_t num_triangles) {
        GeometryView v;
        v.type = GeometryType::Triangles;
        v.positions = positions;
        v.num_vertices = num_vertices;
        v.indices = indices;
        v.num_prims = num_triangles;
        return v;
    }
    /// Spheres as (x, y, z, radius) quadruples.
    static GeometryView sphere_list(const float* xyzr, uint32_t count) {
        GeometryView v;
        v.type = GeometryType::Spheres;
        v.spheres = xyzr;
        v.num_prims = count;
        return v;
    }
};

enum class TriangleTest : uint8_t { Fast, Watertight };  // Möller–Trumbore | Woop 2013
enum class BvhSplit : uint8_t { Midpoint, Sah, Sbvh };  // Sbvh: SAH + spatial splits
enum class EmbreeQuality : uint8_t { Low, Medium, High };
/// Instruction set of the custom BVH's traversal kernel; Auto picks by CPUID at run time.
enum class Isa : uint8_t { Auto, Sse2, Avx2, Avx512 };
/// Custom BVH node layout: float child boxes (256-byte nodes) or quantized ones
/// (128 bytes, Ylitie et al. 2017); Auto picks by the tree's size (accel/bvh/bvh.cpp).
enum class NodeLayout : uint8_t { Auto, Float, Quantized };
/// Custom BVH: whether traversal prefetches a bottom node's leaf blocks on entering it.
/// Auto: where the blocks outgrow the caches (accel/bvh/wide.h, kLeafHintBytes).
enum class LeafPrefetch : uint8_t { Auto, Off, On };

struct AccelOptions {
    TriangleTest triangle = TriangleTest::Fast;
    BvhSplit split = BvhSplit::Sah;
    /// Maximum primitives per leaf (custom BVH); 0 = the builder's own (default_leaf_size
    /// in accel/bvh/build.h: 8 for sah, 16 for sbvh, 4 for midpoint).
    uint32_t leaf_size = 0;
    EmbreeQuality embree_quality = EmbreeQuality::High;
    bool embree_robust = false;
    /// Embree counting mode: triangles become a user geometry tested by our own
    /// intersector, so Embree's primitive tests per ray are counted on our terms.
    bool embree_count = false;
    int build_threads = 0;           ///< 0 = all cores
    Isa isa = Isa::Auto;             ///< custom BVH kernel (see accel/bvh/bvh.h)
    NodeLayout nodes = NodeLayout::Auto;  ///< custom BVH node layout
    /// Custom BVH: keep the binary tree the wide one was collapsed from, and its slot
    /// map, after the build, for inspect_bvh. Traversal never reads them; freed by
    /// default, they would hold 32 bytes per binary node and 8 per leaf slot (about a
    /// third of the whole on the 5M sphere).
    bool keep_binary_tree = false;
    LeafPrefetch leaf_prefetch = LeafPrefetch::Auto;  ///< custom BVH (see LeafPrefetch)
};

/// The instances of a scene (accel/instance.h): prototypes name ranges of the geometry
/// views, which are then in object space and traced only through instances; every
/// view outside the prototypes is in world space and traced directly. Empty (the
/// default): every view is in world space. Views are not copied: both spans must
/// outlive the accelerator, as the views' memory.
///
/// Every backend traces a hit inside an instance as it would the flattened copy, up to
/// the rounding of the transform: the ray is carried into object space by the inverse
/// transform (t keeps its meaning, as the direction is not renormalised), tested there,
/// and the hit names the instance (Hit::inst_id). Watertightness holds within an
/// instance (one transformed ray meets every triangle of it).
struct InstanceSet {
    std::span<const PrototypeView> prototypes;
    std::span<const InstanceView> instances;
    bool empty() const { return instances.empty() && prototypes.empty(); }
};

/// Facts about a built accelerator, for the summary and the benchmarks.
struct BuildInfo {
    std::string backend;       ///< e.g. "custom(sah, watertight, avx2)": names the kernel that runs
    uint64_t primitives = 0;   ///< primitives actually inserted
    uint64_t dropped = 0;      ///< degenerate primitives dropped at build time
    uint64_t nodes = 0;        ///< interior + leaf nodes (0 if not applicable)
    uint64_t leaves = 0;
    uint32_t depth = 0;
    double sah_cost = 0.0;     ///< SAH cost of the tree (custom BVH), 0 if unknown
    uint64_t bytes = 0;        ///< memory owned by the accelerator
    double build_seconds = 0.0;
    bool counts_nodes = false; ///< nodes_visited is meaningful for this backend
    bool counts_prims = true;  ///< prim_tests is meaningful for this backend
    uint64_t instances = 0;    ///< instances inserted (0: a flat scene)
    /// Primitives the instances place (each instance's prototype's primitives): what a
    /// flattened copy would hold besides the world-space ones.
    uint64_t instanced_primitives = 0;
};

class Accelerator {
public:
    virtual ~Accelerator() = default;

    /// Closest hit with t in [ray.t_min, ray.t_max]. On a hit fills `hit` and returns
    /// true; on a miss leaves `hit` untouched and returns false.
    virtual bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const = 0;

    /// Any hit with t in [ray.t_min, ray.t_max]; may stop at the first one found.
    virtual bool occluded(const Ray& ray, TraceStats& stats) const = 0;

    /// Whether the backend traces many rays faster together than one by one (a plugin's
    /// batched entry points). Tools that trace whole ray sets (xcheck, accel_bench) then
    /// hand it chunks through the two calls below; everyone else traces ray by ray.
    /// False here. Out of line, as the two below (accel/accelerator.cpp): an inline virtual
    /// would be emitted as a weak symbol into every per-ISA kernel object
    /// (tests/bvh/kernel_symbols.cmake).
    virtual bool has_batches() const;

    /// intersect for each ray: hits[i] as intersect leaves it, a default Hit on a miss.
    virtual void intersect_batch(std::span<const Ray> rays, Hit* hits, TraceStats& stats) const;

    /// occluded for each ray: occluded[i] = 1 or 0.
    virtual void occluded_batch(std::span<const Ray> rays, uint8_t* occluded, TraceStats& stats) const;

    virtual const BuildInfo& info() const = 0;

    /// Union of all primitive bounds.
    virtual Bounds3f bounds() const = 0;
};

/// Thrown by backends for unusable input or options (unknown backend, Embree device
/// errors). Tools turn it into a message and exit status 2.
class AccelError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// Backend names: "naive", "custom", "embree", or "plugin:PATH[:OPTIONS]" (a library
/// implementing accel/plugin/accel_plugin.h; accel/plugin/host.h).
/// `instances`: see InstanceSet; a backend that cannot trace instances (a plugin)
/// throws AccelError for a non-empty set, and the caller flattens.
std::unique_ptr<Accelerator> create_accelerator(const std::string& name,
                                                std::span<const GeometryView> geometry,
                                                const AccelOptions& options, const InstanceSet& instances = {});

/// Whether the backend `name` traces instances (InstanceSet) itself.
bool backend_traces_instances(const std::string& name);

/// Whether `name` names a backend a tool may pass to create_accelerator: one of
/// available_backends(), or "plugin:PATH[:OPTIONS]" (accel/plugin/README.md).
bool is_backend_name(const std::string& name);

/// Backends compiled into this build, in a stable order.
std::vector<std::string> available_backends();

}  // namespace accel
