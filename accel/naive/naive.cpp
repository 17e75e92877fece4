#include "accel/naive/naive.h"

#include <chrono>
#include <vector>

#include "accel/primitive.h"

namespace accel {
namespace {

/// Tests every primitive: the reference every other backend is checked against.
template <TriangleTest Test>
class NaiveAccelerator final : public Accelerator {
public:
    NaiveAccelerator(std::span<const GeometryView> geometry, const AccelOptions&)
        : geometry_(geometry.begin(), geometry.end()) {
        auto start = std::chrono::steady_clock::now();
        prims_ = collect_primitives(geometry_, info_.dropped);
        for (const PrimRef& p : prims_) bounds_.extend(primitive_bounds(geometry_[p.geom], p.prim));
        info_.backend = Test == TriangleTest::Watertight ? "naive(watertight)" : "naive(fast)";
        info_.primitives = prims_.size();
        info_.bytes = prims_.capacity() * sizeof(PrimRef);
        info_.build_seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }

    bool intersect(const Ray& ray, Hit& hit, TraceStats& stats) const override {
        ++stats.rays;
        stats.prim_tests += prims_.size();
        RayContext rc(ray, Test);
        Hit h;
        h.t = ray.t_max;
        bool found = false;
        for (const PrimRef& p : prims_) {
            const GeometryView& g = geometry_[p.geom];
            if (!g.masked()) {
                found |= intersect_primitive<Test>(g, p.geom, p.prim, rc, h);
                continue;
            }
            // A candidate that would become the closest hit, kept only if the filter says so.
            Hit c = h;
            if (intersect_primitive<Test>(g, p.geom, p.prim, rc, c) &&
                g.filter(g.filter_user, p.geom, p.prim, c.u, c.v, ray))
                h = c, found = true;
        }
        if (!found) return false;
        finish_hit(geometry_, ray, h);
        hit = h;
        return true;
    }

    bool occluded(const Ray& ray, TraceStats& stats) const override {
        ++stats.shadow_rays;
        RayContext rc(ray, Test);
        Hit h;
        h.t = ray.t_max;
        for (const PrimRef& p : prims_) {
            ++stats.prim_tests;
            const GeometryView& g = geometry_[p.geom];
            Hit c = h;
            if (intersect_primitive<Test>(g, p.geom, p.prim, rc, c) &&
                (!g.masked() || g.filter(g.filter_user, p.geom, p.prim, c.u, c.v, ray)))
                return true;
        }
        return false;
    }

    const BuildInfo& info() const override { return info_; }
    Bounds3f bounds() const override { return bounds_; }

private:
    std::vector<GeometryView> geometry_;
    std::vector<PrimRef> prims_;
    Bounds3f bounds_;
    BuildInfo info_;
};

}  // namespace

std::unique_ptr<Accelerator> make_naive(std::span<const GeometryView> geometry,
                                        const AccelOptions& options) {
    if (options.triangle == TriangleTest::Watertight)
        return std::make_unique<NaiveAccelerator<TriangleTest::Watertight>>(geometry, options);
    return std::make_unique<NaiveAccelerator<TriangleTest::Fast>>(geometry, options);
}

}  // namespace accel
