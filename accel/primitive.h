// One place that tests "primitive (geom, prim) of these GeometryViews" against a ray, so
// that naive, BVH leaves and Embree's counting mode run the very same arithmetic.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "accel/accelerator.h"
#include "accel/sphere.h"
#include "accel/triangle.h"

namespace accel {

struct PrimRef {
    uint32_t geom;
    uint32_t prim;
};

/// Per-ray data computed once and reused for every primitive test.
struct RayContext {
    const Ray& ray;
    WatertightRay wt;
    RayContext(const Ray& r, TriangleTest test)
        : ray(r), wt(test == TriangleTest::Watertight ? WatertightRay(r.dir) : WatertightRay()) {}
};

inline void triangle_vertices(const GeometryView& g, uint32_t prim, Vec3f& v0, Vec3f& v1,
                              Vec3f& v2) {
    const uint32_t* idx = g.indices + 3 * size_t(prim);
    v0 = g.positions[idx[0]];
    v1 = g.positions[idx[1]];
    v2 = g.positions[idx[2]];
}

inline Vec3f sphere_center(const GeometryView& g, uint32_t prim) {
    const float* s = g.spheres + 4 * size_t(prim);
    return {s[0], s[1], s[2]};
}
inline float sphere_radius(const GeometryView& g, uint32_t prim) { return g.spheres[4 * size_t(prim) + 3]; }

/// Tests one primitive against [t_min, hit.t]; on a closer hit updates t, u, v and ids
/// (not the normal: finish_hit computes it once for the final hit).
template <TriangleTest Test>
inline bool intersect_primitive(const GeometryView& g, uint32_t geom, uint32_t prim,
                                const RayContext& rc, Hit& hit) {
    if (g.type == GeometryType::Triangles) {
        Vec3f v0, v1, v2;
        triangle_vertices(g, prim, v0, v1, v2);
        TriangleHit th;
        bool ok = Test == TriangleTest::Watertight
                      ? intersect_triangle_wt(rc.ray, rc.wt, v0, v1, v2, hit.t, th)
                      : intersect_triangle_mt(rc.ray, v0, v1, v2, hit.t, th);
        if (!ok) return false;
        hit.t = th.t;
        hit.u = th.u;
        hit.v = th.v;
    } else {
        float t;
        if (!intersect_sphere(rc.ray, sphere_center(g, prim), sphere_radius(g, prim), hit.t, t))
            return false;
        hit.t = t;
        hit.u = hit.v = 0.0f;
    }
    hit.geom_id = geom;
    hit.prim_id = prim;
    return true;
}

/// Fills the geometric normal of a hit found by intersect_primitive.
inline void finish_hit(std::span<const GeometryView> geometry, const Ray& ray, Hit& hit) {
    const GeometryView& g = geometry[hit.geom_id];
    if (g.type == GeometryType::Triangles) {
        Vec3f v0, v1, v2;
        triangle_vertices(g, hit.prim_id, v0, v1, v2);
        hit.ng = triangle_normal(v0, v1, v2);
    } else {
        hit.ng = sphere_normal(ray, hit.t, sphere_center(g, hit.prim_id));
    }
}

/// The ray in an instance's object space, given its world-to-object transform: origin
/// and direction carried by the affine map, the direction not renormalised, so a t means
/// the same point in both spaces (pbrt-v4's Transform::ApplyInverse(Ray); Embree's
/// instances). The segment is [ray.t_min, t_max].
inline Ray to_object_ray(const Affine3f& world_to_object, const Ray& ray, float t_max) {
    Ray r;
    r.org = world_to_object.point(ray.org);
    r.dir = world_to_object.vector(ray.dir);
    r.t_min = ray.t_min;
    r.t_max = t_max;
    return r;
}

/// An object-space geometric normal carried to world space as the cross product of the
/// transformed edges is: cof(L) n = det(L) L^-T n, which from the inverse W = L^-1 is
/// W^T n / det(W) (Hit::ng's convention; orientation follows the transform).
inline Vec3f to_world_normal(const Affine3f& world_to_object, const Vec3f& n) {
    return world_to_object.transpose_vector(n) * float(1.0 / world_to_object.det());
}

inline Bounds3f primitive_bounds(const GeometryView& g, uint32_t prim) {
    if (g.type == GeometryType::Triangles) {
        Vec3f v0, v1, v2;
        triangle_vertices(g, prim, v0, v1, v2);
        return triangle_bounds(v0, v1, v2);
    }
    return sphere_bounds(sphere_center(g, prim), sphere_radius(g, prim));
}

/// Every primitive worth inserting: indices in range, finite coordinates, non-zero area
/// (triangles) or positive finite radius (spheres). `dropped` counts the rest.
inline std::vector<PrimRef> collect_primitives(std::span<const GeometryView> geometry,
                                               uint64_t& dropped) {
    std::vector<PrimRef> refs;
    size_t total = 0;
    for (const GeometryView& g : geometry) total += g.num_prims;
    refs.reserve(total);
    dropped = 0;
    for (uint32_t gi = 0; gi < geometry.size(); ++gi) {
        const GeometryView& g = geometry[gi];
        for (uint32_t p = 0; p < g.num_prims; ++p) {
            bool ok;
            if (g.type == GeometryType::Triangles) {
                const uint32_t* idx = g.indices + 3 * size_t(p);
                ok = idx[0] < g.num_vertices && idx[1] < g.num_vertices &&
                     idx[2] < g.num_vertices;
                if (ok) {
                    Vec3f v0, v1, v2;
                    triangle_vertices(g, p, v0, v1, v2);
                    ok = !triangle_is_degenerate(v0, v1, v2);
                }
            } else {
                float r = sphere_radius(g, p);
                ok = is_finite(sphere_center(g, p)) && std::isfinite(r) && r > 0.0f;
            }
            if (ok)
                refs.push_back({gi, p});
            else
                ++dropped;
        }
    }
    return refs;
}

}  // namespace accel
