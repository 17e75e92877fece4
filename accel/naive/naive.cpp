#include "accel/naive/naive.h"

#include <chrono>
#include <vector>

#include "accel/primitive.h"

namespace accel {
namespace {

/// Tests every primitive: the reference every other backend is checked against.
/// Instances: every primitive of every instance's prototype, against the ray carried
/// into the instance's object space (to_object_ray, primitive.h), as the BVH and
/// Embree do; the hit's normal is carried back by to_world_normal.
template <TriangleTest Test>
class NaiveAccelerator final : public Accelerator {
public:
    NaiveAccelerator(std::span<const GeometryView> geometry, const AccelOptions&, const InstanceSet& inst)
        : geometry_(geometry.begin(), geometry.end()) {
        auto start = std::chrono::steady_clock::now();
        std::vector<PrimRef> all = collect_primitives(geometry_, info_.dropped);
        std::vector<int32_t> owner(geometry_.size(), -1);
        for (uint32_t p = 0; p < inst.prototypes.size(); ++p)
            for (uint32_t g = 0; g < inst.prototypes[p].num_geoms; ++g) owner[inst.prototypes[p].first_geom + g] = int32_t(p);
        std::vector<Bounds3f> proto_bounds(inst.prototypes.size());
        proto_prims_.resize(inst.prototypes.size());
        for (const PrimRef& p : all) {
            const Bounds3f b = primitive_bounds(geometry_[p.geom], p.prim);
            if (owner[p.geom] < 0) {
                prims_.push_back(p);
                bounds_.extend(b);
            } else {
                proto_prims_[size_t(owner[p.geom])].push_back(p);
                proto_bounds[size_t(owner[p.geom])].extend(b);
            }
        }
        instances_.reserve(inst.instances.size());
        for (const InstanceView& i : inst.instances) {
            instances_.push_back({i.prototype, i.object_to_world.inverse()});
            bounds_.extend(i.object_to_world.bounds(proto_bounds[i.prototype]));
            info_.instanced_primitives += proto_prims_[i.prototype].size();
        }
        info_.backend = Test == TriangleTest::Watertight ? "naive(watertight)" : "naive(fast)";
        info_.primitives = all.size();
        info_.instances = instances_.size();
        info_.bytes = (prims_.capacity() + all.size() - prims_.size()) * sizeof(PrimRef) +
                      instances_.capacity() * sizeof(Placed);
        info_.build_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }

    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        Hit h;
        h.t = ray.t_max;
        bool found = closest(prims_, ray, ray, kInvalidId, h, stats);
        for (uint32_t i = 0; i < instances_.size(); ++i) {
            const Ray local = to_object_ray(instances_[i].world_to_object, ray, h.t);
            found |= closest(proto_prims_[instances_[i].prototype], local, ray, i, h, stats);
        }
        if (!found) return false;
        if (h.inst_id == kInvalidId) {
            finish_hit(geometry_, ray, h);
        } else {
            const Placed& pl = instances_[h.inst_id];
            finish_hit(geometry_, to_object_ray(pl.world_to_object, ray, h.t), h);
            h.ng = to_world_normal(pl.world_to_object, h.ng);
        }
        hit = h;
        return true;
    }

    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        if (any(prims_, ray, ray, kInvalidId, stats)) return true;
        for (uint32_t i = 0; i < instances_.size(); ++i)
            if (any(proto_prims_[instances_[i].prototype], to_object_ray(instances_[i].world_to_object, ray, ray.t_max),
                    ray, i, stats))
                return true;
        return false;
    }

    const BuildInfo& info() const override { return info_; }
    Bounds3f bounds() const override { return bounds_; }

private:
    struct Placed {
        uint32_t prototype;
        Affine3f world_to_object;
    };

    /// Closest hit among `prims` in [ray.t_min, h.t]; `world` is the caller's ray (the
    /// filters' argument), `ray` the one tested (the same, or its object-space copy).
    bool closest(const std::vector<PrimRef>& prims, const Ray& ray, const Ray& world, uint32_t inst, Hit& h,
                 TraceStats& stats) const {
        stats.prim_tests += prims.size();
        RayContext rc(ray, Test);
        bool found = false;
        for (const PrimRef& p : prims) {
            const GeometryView& g = geometry_[p.geom];
            // A candidate that would become the closest hit, kept only if the filter says so.
            Hit c = h;
            if (intersect_primitive<Test>(g, p.geom, p.prim, rc, c) &&
                (!g.masked() || g.filter(g.filter_user, p.geom, p.prim, inst, c.u, c.v, world))) {
                h = c;
                h.inst_id = inst;
                found = true;
            }
        }
        return found;
    }

    bool any(const std::vector<PrimRef>& prims, const Ray& ray, const Ray& world, uint32_t inst,
             TraceStats& stats) const {
        RayContext rc(ray, Test);
        Hit h;
        h.t = ray.t_max;
        for (const PrimRef& p : prims) {
            ++stats.prim_tests;
            const GeometryView& g = geometry_[p.geom];
            Hit c = h;
            if (intersect_primitive<Test>(g, p.geom, p.prim, rc, c) &&
                (!g.masked() || g.filter(g.filter_user, p.geom, p.prim, inst, c.u, c.v, world)))
                return true;
        }
        return false;
    }

    std::vector<GeometryView> geometry_;
    std::vector<PrimRef> prims_;                     ///< world-space primitives
    std::vector<std::vector<PrimRef>> proto_prims_;  ///< per prototype
    std::vector<Placed> instances_;
    Bounds3f bounds_;
    BuildInfo info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_naive(std::span<const GeometryView> geometry,
                                        const AccelOptions& options, const InstanceSet& instances) {
    if (options.triangle == TriangleTest::Watertight)
        return std::make_unique<NaiveAccelerator<TriangleTest::Watertight>>(geometry, options, instances);
    return std::make_unique<NaiveAccelerator<TriangleTest::Fast>>(geometry, options, instances);
}

}  // namespace accel
