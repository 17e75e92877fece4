// Numerical-stability stress kernel, shared by the `extremes` sweep
// (benchmarks/extremes.cpp) and its fast version in tests/stability/. Header-only so the
// test and the tool run the very same measurements.
//
// What is measured, per mesh, scale/translation and backend:
//  - leaks: rays aimed exactly at a point of a shared edge, or at a vertex, of a
//    consistently oriented manifold mesh, coming from the front of EVERY face around
//    that edge/vertex. The faces' projections along such a ray then cover a neighbourhood
//    of the target, so an exact intersector must report a hit at t <= 1 (the target
//    point is at t = 1, modulo one rounding of org/dir). No hit there is a leak: the
//    ray slipped between triangles (Woop, Benthin, Wald 2013 guarantee 0 for the
//    watertight test). Some of these rays are exactly axis-parallel (direction
//    components +-0), which also exercises the slab test (Williams 2005, Ize 2013).
//  - acne: hemisphere rays leaving surface points found by tracing (the integrator's
//    situation), and shadow segments between mutually visible points (a surface point
//    and the point its hemisphere ray reached; pairs of inner points of convex meshes),
//    spawned with each offset mode of renderer/spawn.h. Every hit is judged against the
//    exact points (the same barycentrics evaluated in double) and classed as
//      false: the ray hit its own surface (own triangle or a coplanar one in the same
//        plane), left a convex mesh outward and hit it, or found a triangle the exact
//        ray misses near its origin, or an occluder lies farther from the exact segment
//        than the endpoints' rounding allows;
//      ambiguous: the hit surface passes within rounding (error box plus offset) of an
//        endpoint, and the exact geometry disagrees with float there; these are
//        counted and printed, never folded into "clear";
//      clear: no hit, or a hit the exact geometry confirms.
//  - reference: rays aimed at interior points of triangles (random, grazing 1e-1..1e-6
//    and axis-parallel directions) compared with a double-precision intersector on the
//    same float ray. Only rays float can decide are kept: edge functions beyond twice
//    pbrt-v4's bound on their rounding (ref_bound). Reported: relative error of t (and
//    of the barycentrics) for the well-conditioned and the grazing rays, |dt| as a
//    fraction of pbrt-v4's bound on t's error, and "wrong misses" (a decidable ray the
//    backend missed, or passed through to something farther).
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "accel/accelerator.h"
#include "accel/primitive.h"
#include "accel/triangle.h"
#include "renderer/interaction.h"
#include "renderer/rng.h"
#include "renderer/sampling.h"
#include "renderer/spawn.h"
#include "scenes/load.h"

namespace extremes {

using accel::Vec3d;
using accel::Vec3f;
using renderer::OffsetMode;

/// A mesh in double precision, normalised to fit [-0.5, 0.5]^3 around the origin.
struct UnitMesh {
    std::string name;
    std::vector<Vec3d> pos;
    std::vector<uint32_t> idx;
    bool convex = false;
};

/// Geodesic icosphere (closed, convex, consistently wound outward).
inline UnitMesh make_icosphere(int subdiv) {
    UnitMesh m;
    m.name = "icosphere" + std::to_string(subdiv);
    m.convex = true;
    const double t = (1.0 + std::sqrt(5.0)) / 2.0;
    std::vector<Vec3d> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    std::vector<uint32_t> f = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4,
                               11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8,
                               3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
    for (Vec3d& p : v) p = p / accel::length(p);
    for (int s = 0; s < subdiv; ++s) {
        std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
        auto midpoint = [&](uint32_t a, uint32_t b) {
            auto key = std::minmax(a, b);
            auto it = mid.find(key);
            if (it != mid.end()) return it->second;
            Vec3d p = (v[a] + v[b]) * 0.5;
            v.push_back(p / accel::length(p));
            return mid[key] = uint32_t(v.size() - 1);
        };
        std::vector<uint32_t> g;
        for (size_t i = 0; i < f.size(); i += 3) {
            uint32_t a = f[i], b = f[i + 1], c = f[i + 2];
            uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
            g.insert(g.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
        }
        f.swap(g);
    }
    for (Vec3d& p : v) p = p * 0.5;
    m.pos = v;
    m.idx = f;
    return m;
}

/// Cube with each face split into n x n quads (two triangles each), shared vertices,
/// wound outward: closed, convex, with many coplanar neighbours and axis-aligned faces.
inline UnitMesh make_cube(int n) {
    UnitMesh m;
    m.name = "cube" + std::to_string(n);
    m.convex = true;
    std::map<std::array<int, 3>, uint32_t> ids;
    auto vid = [&](int x, int y, int z) {
        std::array<int, 3> k{x, y, z};
        auto it = ids.find(k);
        if (it != ids.end()) return it->second;
        m.pos.push_back(Vec3d(double(x) / n - 0.5, double(y) / n - 0.5, double(z) / n - 0.5));
        return ids[k] = uint32_t(m.pos.size() - 1);
    };
    for (int axis = 0; axis < 3; ++axis)
        for (int side = 0; side < 2; ++side)
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j) {
                    auto corner = [&](int a, int b) {
                        std::array<int, 3> c{};
                        c[axis] = side * n;
                        c[(axis + 1) % 3] = a;
                        c[(axis + 2) % 3] = b;
                        return vid(c[0], c[1], c[2]);
                    };
                    uint32_t q[4] = {corner(i, j), corner(i + 1, j), corner(i + 1, j + 1), corner(i, j + 1)};
                    // (axis+1, axis+2) is right-handed around +axis: counter-clockwise
                    // seen from outside on the + side, reversed on the - side.
                    if (side == 1)
                        m.idx.insert(m.idx.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
                    else
                        m.idx.insert(m.idx.end(), {q[0], q[2], q[1], q[0], q[3], q[2]});
                }
    return m;
}

/// All meshes of a scene file merged, normalised to the unit box. Throws SceneError.
inline UnitMesh load_unit_mesh(const std::string& path, const std::string& name) {
    scenes::Scene s = scenes::load_scene(path);
    UnitMesh m;
    m.name = name;
    for (const scenes::Mesh& mesh : s.meshes) {
        const uint32_t base = uint32_t(m.pos.size());
        for (uint32_t i = 0; i < mesh.num_vertices(); ++i) m.pos.push_back(Vec3d(mesh.positions[i]));
        for (uint32_t k : mesh.indices) m.idx.push_back(base + k);
    }
    Vec3d lo(1e300), hi(-1e300);
    for (const Vec3d& p : m.pos) { lo = accel::vmin(lo, p); hi = accel::vmax(hi, p); }
    const Vec3d c = (lo + hi) * 0.5;
    const double ext = accel::max_component(hi - lo);
    for (Vec3d& p : m.pos) p = (p - c) / ext;
    return m;
}

/// One placement in the sweep: p_world = p_unit * scale + offset (computed in double,
/// rounded once to float, so the float mesh is the best float picture of the shape).
struct Placement {
    double scale = 1, offset = 0;
    std::string label() const {
        char buf[64];
        std::snprintf(buf, sizeof buf, "s=%.0e t=%.0e", scale, offset);
        return buf;
    }
};
/// Translation direction: all three axes non-zero and different.
inline Vec3d offset_dir() { return Vec3d(1.0, -0.75, 0.5); }

/// The float mesh the backends see, plus adjacency for the leak rays.
struct World {
    std::string name;
    bool convex = false;
    Placement place;
    std::vector<Vec3f> pos;  ///< padded by one element (Embree's 16-byte loads)
    std::vector<uint32_t> idx;
    uint32_t num_vertices = 0, num_tris = 0;
    std::vector<uint8_t> degenerate;  ///< per triangle (dropped by the backends)
    std::vector<Vec3d> unit_normal;   ///< per triangle, from the float vertices, in double
    /// Interior edges shared by exactly two non-degenerate, consistently wound triangles.
    struct Edge { uint32_t a, b, t0, t1; };
    std::vector<Edge> edges;
    /// Vertices whose whole fan is manifold (every incident edge interior), with the
    /// fan's triangles.
    std::vector<uint32_t> vertices;
    std::vector<std::vector<uint32_t>> fan;
    Vec3d center;
    double radius = 1;  ///< of the bounding sphere
    accel::GeometryView view() const {
        return accel::GeometryView::triangles(pos.data(), num_vertices, idx.data(), num_tris);
    }
    Vec3f v(uint32_t tri, int k) const { return pos[idx[3 * size_t(tri) + k]]; }
};

inline World place_mesh(const UnitMesh& m, const Placement& pl) {
    World w;
    w.name = m.name;
    w.convex = m.convex;
    w.place = pl;
    const Vec3d off = offset_dir() * pl.offset;
    for (const Vec3d& p : m.pos) w.pos.push_back(Vec3f(p * pl.scale + off));
    w.num_vertices = uint32_t(w.pos.size());
    w.pos.push_back(Vec3f(0.0f));
    w.idx = m.idx;
    w.num_tris = uint32_t(w.idx.size() / 3);
    w.center = off;
    w.radius = pl.scale * std::sqrt(0.75);
    w.degenerate.resize(w.num_tris);
    w.unit_normal.resize(w.num_tris);
    std::unordered_map<uint64_t, std::vector<uint32_t>> by_edge;  // directed edge -> triangles
    auto key = [](uint32_t a, uint32_t b) { return (uint64_t(a) << 32) | b; };
    for (uint32_t t = 0; t < w.num_tris; ++t) {
        const Vec3f a = w.v(t, 0), b = w.v(t, 1), c = w.v(t, 2);
        w.degenerate[t] = accel::triangle_is_degenerate(a, b, c);
        const Vec3d n = accel::cross(Vec3d(b) - Vec3d(a), Vec3d(c) - Vec3d(a));
        const double ln = accel::length(n);
        if (!(ln > 0)) w.degenerate[t] = 1;
        w.unit_normal[t] = ln > 0 ? n / ln : Vec3d(0.0);
        if (w.degenerate[t]) continue;
        for (int k = 0; k < 3; ++k) by_edge[key(w.idx[3 * t + k], w.idx[3 * t + (k + 1) % 3])].push_back(t);
    }
    std::vector<uint8_t> vertex_ok(w.num_vertices, 1);
    w.fan.resize(w.num_vertices);
    for (const auto& [k, tris] : by_edge) {
        const uint32_t a = uint32_t(k >> 32), b = uint32_t(k);
        auto rev = by_edge.find(key(b, a));
        const bool interior = tris.size() == 1 && rev != by_edge.end() && rev->second.size() == 1;
        if (!interior) {
            vertex_ok[a] = vertex_ok[b] = 0;
            continue;
        }
        if (a < b) w.edges.push_back({a, b, tris[0], rev->second[0]});
    }
    // Degenerate triangles are dropped by the backends: their vertices' fans have holes
    // in the mesh's connectivity (though not in its coverage); skip such vertices.
    for (uint32_t t = 0; t < w.num_tris; ++t)
        for (int k = 0; k < 3; ++k) {
            const uint32_t vi = w.idx[3 * t + k];
            if (w.degenerate[t]) vertex_ok[vi] = 0;
            else w.fan[vi].push_back(t);
        }
    for (uint32_t vi = 0; vi < w.num_vertices; ++vi)
        if (vertex_ok[vi] && w.fan[vi].size() >= 3) w.vertices.push_back(vi);
    std::sort(w.edges.begin(), w.edges.end(), [](const World::Edge& x, const World::Edge& y) {
        return x.a != y.a ? x.a < y.a : x.b < y.b;
    });
    return w;
}

/// Double-precision reference: Möller–Trumbore on the float ray and float vertices
/// promoted to double (rounding ~1e-16 relative, far below float's 6e-8). Returns t and
/// the barycentrics of v1, v2 of the plane crossing, and whether it is inside (with the
/// smallest barycentric in `margin`).
struct RefHit {
    bool plane = false;  ///< ray not parallel to the plane
    double t = 0, u = 0, v = 0, margin = 0;
    bool inside() const { return plane && margin >= 0; }
};
inline RefHit ref_intersect(const Vec3d& org, const Vec3d& dir, const Vec3f& fv0, const Vec3f& fv1,
                            const Vec3f& fv2) {
    const Vec3d v0(fv0), v1(fv1), v2(fv2);
    const Vec3d e1 = v1 - v0, e2 = v2 - v0;
    const Vec3d p = accel::cross(dir, e2);
    const double det = accel::dot(e1, p);
    RefHit r;
    if (det == 0.0 || !std::isfinite(det)) return r;
    const Vec3d s = org - v0;
    const Vec3d q = accel::cross(s, e1);
    r.plane = true;
    r.u = accel::dot(s, p) / det;
    r.v = accel::dot(dir, q) / det;
    r.t = accel::dot(e2, q) / det;
    r.margin = std::min({r.u, r.v, 1.0 - r.u - r.v});
    return r;
}

/// Rounding-error yardsticks of a float ray-triangle test, evaluated in double for the
/// float ray and vertices: pbrt-v4's bounds for the watertight test (Pharr, Jakob,
/// Humphreys, "Physically Based Rendering" 4th ed., 6.8.4-6.8.6; the same algorithm as
/// Woop et al. 2013 and our TriangleTest::Watertight). delta_e bounds the error of each
/// edge function, delta_t the error of t. A ray whose three edge functions share a sign
/// and each exceed 2 delta_e is decidably inside: any float intersector worth the name
/// must report the hit. Grazing rays have small edge functions (the projected triangle
/// is thin) and mostly fall outside this set, which is the honest answer: float cannot
/// decide them.
struct RefBound {
    bool decidable_inside = false;
    double delta_t = 0;  ///< bound on |t_float - t_exact|
};
inline RefBound ref_bound(const Vec3d& org, const Vec3d& dir, const Vec3f& fv0, const Vec3f& fv1,
                          const Vec3f& fv2) {
    RefBound rb;
    const int kz = accel::max_dimension(accel::vabs(dir));
    int kx = kz + 1 == 3 ? 0 : kz + 1, ky = kx + 1 == 3 ? 0 : kx + 1;
    if (dir[kz] < 0) std::swap(kx, ky);
    const double sx = dir[kx] / dir[kz], sy = dir[ky] / dir[kz], sz = 1.0 / dir[kz];
    Vec3d pt[3];
    const Vec3d v[3] = {Vec3d(fv0), Vec3d(fv1), Vec3d(fv2)};
    double max_x = 0, max_y = 0, max_z = 0, max_az = 0;
    for (int i = 0; i < 3; ++i) {
        const Vec3d a = v[i] - org;
        pt[i] = Vec3d(a[kx] - sx * a[kz], a[ky] - sy * a[kz], a[kz] * sz);
        max_x = std::max(max_x, std::abs(pt[i].x));
        max_y = std::max(max_y, std::abs(pt[i].y));
        max_z = std::max(max_z, std::abs(pt[i].z));
        max_az = std::max(max_az, std::abs(a[kz]));
    }
    const double e0 = pt[2].x * pt[1].y - pt[2].y * pt[1].x;  // U (opposite v0)
    const double e1 = pt[0].x * pt[2].y - pt[0].y * pt[2].x;  // V
    const double e2 = pt[1].x * pt[0].y - pt[1].y * pt[0].x;  // W
    const double det = e0 + e1 + e2;
    if (det == 0.0 || !std::isfinite(det)) return rb;
    auto g = [](int n) { return double(renderer::gamma_bound(n)); };
    // The shear x' = a_x - s_x a_z rounds relative to the unscaled |a_z| (|s_x| <= 1).
    // pbrt-v4 writes gamma(5) (max|x'| + max|z'|) with the scaled z' = a_z / d_z, which
    // is the same for unit directions but too small for long unnormalised ones (our
    // shadow segments and these rays, |d| up to 1e7): measured here as decidable rays
    // every float intersector missed.
    const double dx = g(5) * (max_x + max_az), dy = g(5) * (max_y + max_az), dz = g(3) * max_z;
    const double delta_e = 2 * (g(2) * max_x * max_y + dy * max_x + dx * max_y);
    const double max_e = std::max({std::abs(e0), std::abs(e1), std::abs(e2)});
    rb.delta_t = 3 * (g(3) * max_e * max_z + delta_e * max_z + dz * max_e) / std::abs(det);
    const double lo = std::min({e0, e1, e2}), hi = std::max({e0, e1, e2});
    rb.decidable_inside = lo > 2 * delta_e || hi < -2 * delta_e;
    return rb;
}

/// Backends under test, by renderer::parse_backend_spec words.
struct BackendCase {
    std::string label;    ///< short column name
    std::string backend;  ///< custom | embree | naive
    accel::AccelOptions options;
};
inline std::vector<BackendCase> backend_cases(bool with_embree) {
    std::vector<BackendCase> v;
    BackendCase c;
    c.backend = "custom";
    c.label = "custom-fast";
    c.options.triangle = accel::TriangleTest::Fast;
    v.push_back(c);
    c.label = "custom-watertight";
    c.options.triangle = accel::TriangleTest::Watertight;
    v.push_back(c);
    if (with_embree) {
        BackendCase e;
        e.backend = "embree";
        e.label = "embree";
        v.push_back(e);
        e.label = "embree-robust";
        e.options.embree_robust = true;
        v.push_back(e);
    }
    return v;
}

/// Label printed by the EXTREMES_DEBUG diagnostics (set by the caller).
inline std::string g_debug_label;

inline constexpr OffsetMode kModes[] = {OffsetMode::ErrorBound, OffsetMode::Epsilon};

struct Counts {
    uint64_t leak_rays = 0, leaks = 0;          ///< edge and vertex rays (all directions)
    uint64_t axis_rays = 0, axis_leaks = 0;     ///< the axis-parallel subset of the above
    uint64_t vertex_rays = 0, vertex_leaks = 0; ///< the subset aimed at vertices
    uint64_t hemi_rays[2] = {}, hemi_false[2] = {};      ///< per OffsetMode
    uint64_t shadow_rays[2] = {}, shadow_false[2] = {};  ///< per OffsetMode
    /// Hits decided below the endpoints' rounding (detail::touches_box), per OffsetMode.
    uint64_t hemi_ambiguous[2] = {}, shadow_ambiguous[2] = {};
    uint64_t ref_rays = 0, ref_compared = 0, wrong_miss = 0, grazing_rays = 0;
    double max_rel_t = 0, max_bary = 0;  ///< random and axis-parallel rays
    double max_rel_t_grazing = 0;        ///< grazing rays (t is ill-conditioned there)
    double max_t_over_bound = 0;         ///< max |t - t_ref| / pbrt-v4's delta_t, all rays
    uint64_t dropped = 0;  ///< degenerate triangles the backend dropped

    void add(const Counts& o) {
        leak_rays += o.leak_rays; leaks += o.leaks; axis_rays += o.axis_rays; axis_leaks += o.axis_leaks;
        vertex_rays += o.vertex_rays; vertex_leaks += o.vertex_leaks;
        for (int m = 0; m < 2; ++m) {
            hemi_rays[m] += o.hemi_rays[m]; hemi_false[m] += o.hemi_false[m];
            shadow_rays[m] += o.shadow_rays[m]; shadow_false[m] += o.shadow_false[m];
            hemi_ambiguous[m] += o.hemi_ambiguous[m]; shadow_ambiguous[m] += o.shadow_ambiguous[m];
        }
        ref_rays += o.ref_rays; ref_compared += o.ref_compared; wrong_miss += o.wrong_miss;
        grazing_rays += o.grazing_rays;
        max_rel_t = std::max(max_rel_t, o.max_rel_t);
        max_bary = std::max(max_bary, o.max_bary);
        max_rel_t_grazing = std::max(max_rel_t_grazing, o.max_rel_t_grazing);
        max_t_over_bound = std::max(max_t_over_bound, o.max_t_over_bound);
        dropped += o.dropped;
    }
    uint64_t acne_rays(int m) const { return hemi_rays[m] + shadow_rays[m]; }
    uint64_t acne_false(int m) const { return hemi_false[m] + shadow_false[m]; }
    uint64_t acne_ambiguous(int m) const { return hemi_ambiguous[m] + shadow_ambiguous[m]; }
};

struct RayBudget {
    uint64_t leak = 100000;  ///< edge + vertex rays
    uint64_t acne = 20000;   ///< surface points (each: one hemisphere ray + one shadow segment per mode)
    uint64_t ref = 20000;    ///< reference-comparison rays
};

namespace detail {

inline double rnd(renderer::Rng& r) { return double(r.next_u32()) * 0x1p-32 + double(r.next_u32()) * 0x1p-64; }

inline Vec3d rand_dir(renderer::Rng& r) {
    const double z = 1 - 2 * rnd(r), phi = 2 * M_PI * rnd(r), s = std::sqrt(std::max(0.0, 1 - z * z));
    return {s * std::cos(phi), s * std::sin(phi), z};
}

/// A direction from which all `normals` face the ray (dot(d, n) <= -0.02 for each), or
/// (0,0,0) after a few tries. With probability 1/4 an exact axis direction is tried
/// first (components +-0), the case the slab test must get right.
inline Vec3d front_direction(const std::vector<Vec3d>& normals, renderer::Rng& r, bool& axis,
                             bool allow_axis) {
    Vec3d avg(0.0);
    for (const Vec3d& n : normals) avg += n;
    const double la = accel::length(avg);
    if (!(la > 0)) return Vec3d(0.0);
    avg = avg / la;
    auto ok = [&](const Vec3d& d) {
        for (const Vec3d& n : normals)
            if (!(accel::dot(d, n) <= -0.02)) return false;
        return true;
    };
    axis = false;
    if ((r.next_u32() & 3) == 0 && allow_axis) {
        const int k = accel::max_dimension(accel::vabs(avg));
        Vec3d d(0.0);
        // Signed zeros in the other components: -0 must behave as +0 in the slab test.
        if (r.next_u32() & 1) d = Vec3d(-0.0);
        d[k] = avg[k] > 0 ? -1.0 : 1.0;
        if (ok(d)) {
            axis = true;
            return d;
        }
    }
    for (int attempt = 0; attempt < 16; ++attempt) {
        const double spread = attempt < 8 ? 0.8 : 0.2;
        Vec3d d = -avg + rand_dir(r) * spread;
        d = d / accel::length(d);
        if (ok(d)) return d;
    }
    return Vec3d(0.0);
}

/// Float ray aimed at the exact (double) point `target` from distance L along -d, with
/// t_at = the ray parameter at the target. General directions: org is rounded once and
/// dir = target - org is computed in double then rounded, so the ray passes within an
/// ulp of |dir| of the exact target (a lerped float target would be an ulp of |target|
/// off an edge, which far from the origin is as large as the triangles). Axis
/// directions (exactly one non-zero component): only exact float targets (vertices) are
/// used; org differs from the target in that component only and dir is +-1 with the
/// requested signed zeros, which is what exercises the slab test.
inline accel::Ray ray_at(const Vec3d& target, const Vec3d& d, double L, float& t_at) {
    accel::Ray r;
    int nonzero = 0, k = 0;
    for (int i = 0; i < 3; ++i)
        if (d[i] != 0.0) { ++nonzero; k = i; }
    if (nonzero == 1) {
        r.org = Vec3f(target);
        r.org[k] = float(target[k] - d[k] * L);
        for (int i = 0; i < 3; ++i) r.dir[i] = float(d[i]);  // keeps -0
        t_at = std::abs(float(target[k]) - r.org[k]);
    } else {
        r.org = Vec3f(target - d * L);
        // Through memory: keeps the compiler honest about org being rounded to float.
        volatile float o[3] = {r.org.x, r.org.y, r.org.z};
        const Vec3d od{double(o[0]), double(o[1]), double(o[2])};
        r.dir = Vec3f(target - od);
        t_at = 1.0f;
    }
    r.t_min = 0.0f;
    r.t_max = accel::kInfinity;
    return r;
}

inline bool is_convex_side_outside(const World& w, const Vec3f& p, const Vec3f& n) {
    // On a convex mesh the outward side is the one facing away from the centre.
    return accel::dot(Vec3d(n), Vec3d(p) - w.center) > 0;
}

/// Runs body(counts, stats, rng, i) for i in [0, n) over TBB, in chunks of 4096 rays;
/// chunk k draws from its own stream (seed, tag + k), so the rays, and the counts, do
/// not depend on the thread count or the schedule.
template <class C, class Body>
void for_each_ray(tbb::enumerable_thread_specific<C>& local, uint64_t n, uint64_t seed, uint64_t tag, Body&& body) {
    constexpr uint64_t chunk = 4096;
    tbb::parallel_for(tbb::blocked_range<uint64_t>(0, (n + chunk - 1) / chunk), [&](const auto& range) {
        C& c = local.local();
        accel::TraceStats st;
        for (uint64_t ci = range.begin(); ci != range.end(); ++ci) {
            renderer::Rng rng(seed, tag + ci);
            for (uint64_t i = ci * chunk; i < std::min(n, (ci + 1) * chunk); ++i) body(c, st, rng, i);
        }
    });
}

/// A surface point as a renderer has it (computed p, error box err), the exact point it
/// stands for (the same barycentrics evaluated in double), and its triangle.
struct Endpoint {
    Vec3f p, err;
    Vec3d exact;
    uint32_t tri;
};

inline Endpoint make_endpoint(const World& w, uint32_t tri, float u, float v) {
    Endpoint e;
    e.tri = tri;
    renderer::triangle_point(w.v(tri, 0), w.v(tri, 1), w.v(tri, 2), u, v, e.p, e.err);
    e.exact = Vec3d(w.v(tri, 0)) * (1.0 - double(u) - double(v)) + Vec3d(w.v(tri, 1)) * double(u) +
              Vec3d(w.v(tri, 2)) * double(v);
    return e;
}

/// How far a spawned ray's start (or a segment's end) may stray from the exact endpoint:
/// the error box (|err|_1) plus the offset that clears it (at most |err|_1 again).
inline double reach(const Endpoint& e) { return 2.0 * (double(e.err.x) + double(e.err.y) + double(e.err.z)); }

enum class Verdict : uint8_t { Clear, Ambiguous, False };

/// Triangle t lies in e's own plane: e's triangle itself, or a coplanar one whose plane
/// passes within reach of e. Hitting it is the failure the offsets exist to prevent.
inline bool own_surface(const World& w, uint32_t t, const Endpoint& e) {
    if (e.tri == accel::kInvalidId) return false;
    if (t == e.tri) return true;
    const Vec3d n = w.unit_normal[t];
    if (std::abs(accel::dot(n, w.unit_normal[e.tri])) <= 1.0 - 1e-9) return false;
    // Same plane, not merely parallel (a box's opposite faces): the exact point lies in
    // t's plane up to the rounding of the vertices, far inside e's error box.
    return std::abs(accel::dot(e.exact - Vec3d(w.v(t, 0)), n)) <= accel::dot(accel::vabs(n), Vec3d(e.err));
}

/// True when the plane of t (not e's own surface) passes within reach of e: e lies
/// within rounding of t's surface (an edge or corner between non-coplanar faces, or a
/// place where another surface crosses e's), and whether a ray leaving e crosses t
/// there is decided by digits the floats do not have.
inline bool touches_box(const World& w, uint32_t t, const Endpoint& e) {
    if (e.tri == accel::kInvalidId || own_surface(w, t, e)) return false;
    const Vec3d n = w.unit_normal[t];
    return std::abs(accel::dot(Vec3d(e.p) - Vec3d(w.v(t, 0)), n)) <= reach(e);
}

/// Distance from x to the segment [a, b] (double).
inline double point_segment_distance(const Vec3d& x, const Vec3d& a, const Vec3d& b) {
    const Vec3d ab = b - a;
    const double l2 = accel::dot(ab, ab);
    const double s = l2 > 0 ? std::clamp(accel::dot(x - a, ab) / l2, 0.0, 1.0) : 0.0;
    return accel::length(x - (a + ab * s));
}

/// Occlusion of a segment the renderer spawned between endpoints a and b:
///  - False when an occluder is an endpoint's own surface (acne proper) the other
///    endpoint is not within rounding of, or lies
///    farther from the exact segment (a.exact to b.exact) than the rounding of the
///    endpoints allows: the float segment stays within (1-t) reach(a) + t reach(b) of
///    the exact one, so an occluder beyond twice that means the bounds or offsets are
///    wrong;
///  - Ambiguous when every occluder is a surface within reach of an endpoint
///    (touches_box) or within that rounding tube around the exact segment: the exact
///    geometry passes within rounding of it, and where the mesh's features are as small
///    as the error boxes (the CS184 meshes far from the origin) float cannot say;
///  - Clear otherwise.
inline Verdict classify_segment(const World& w, const accel::Accelerator& acc, accel::Ray sg, const Endpoint& a,
                                const Endpoint& b, accel::TraceStats& st) {
    if (!acc.occluded(sg, st)) return Verdict::Clear;
    for (int k = 0; k < 16; ++k) {
        accel::Hit ho;
        if (!acc.intersect(sg, ho, st)) return k == 0 ? Verdict::False : Verdict::Ambiguous;
        const uint32_t o = ho.prim_id;
        const bool own = own_surface(w, o, a) || own_surface(w, o, b);
        if (!own) {
            // The exact segment between the exact points is blocked too: the pair was
            // not mutually visible after all (a hemisphere ray's landing point on a
            // non-convex mesh), and the occlusion is right.
            const RefHit rh = ref_intersect(a.exact, b.exact - a.exact, w.v(o, 0), w.v(o, 1), w.v(o, 2));
            if (rh.plane && rh.margin >= 0 && rh.t > 0 && rh.t < 1) return Verdict::Clear;
        }
        const bool touches = touches_box(w, o, a) || touches_box(w, o, b);
        // An endpoint's own surface is a false hit unless the other endpoint also lies
        // within rounding of that plane: then the whole segment runs inside the plane's
        // rounding band (two points near a shared edge of nearly coplanar faces).
        bool is_false = own && !touches;
        if (!own && !touches) {
            const double t = double(ho.t);
            const Vec3d x = Vec3d(sg.org) + Vec3d(sg.dir) * t;
            const double tube = 2.0 * ((1.0 - t) * reach(a) + t * reach(b));
            is_false = point_segment_distance(x, a.exact, b.exact) > tube;
            if (is_false && std::getenv("EXTREMES_DEBUG"))
                std::fprintf(stderr, "tube %g dist %g x=(%.9g %.9g %.9g) a=(%.9g %.9g %.9g) b=(%.9g %.9g %.9g) org=(%.9g %.9g %.9g) end=(%.9g %.9g %.9g)\n", tube,
                             point_segment_distance(x, a.exact, b.exact), x.x, x.y, x.z, a.exact.x, a.exact.y, a.exact.z, b.exact.x, b.exact.y, b.exact.z,
                             sg.org.x, sg.org.y, sg.org.z, sg.org.x + sg.dir.x, sg.org.y + sg.dir.y, sg.org.z + sg.dir.z);
        }
        if (is_false) {
            if (std::getenv("EXTREMES_DEBUG") && sg.t_min > 0.0f)
                std::fprintf(stderr, "segment-false %s %s a.tri=%u b.tri=%u occ=%u t=%g tmin=%g tmax=%g len=%g reach=%g\n",
                             g_debug_label.c_str(), w.name.c_str(), a.tri, b.tri, o, ho.t, sg.t_min, sg.t_max,
                             accel::length(sg.dir), reach(a));
            return Verdict::False;
        }
        sg.t_min = renderer::next_float_up(ho.t);
    }
    return Verdict::Ambiguous;
}

}  // namespace detail

/// Runs every measurement of one backend on one placed mesh. Rays depend only on
/// (seed, mesh, placement), not on the backend, except the acne rays, which start where
/// the backend's own primary ray hit (as in a renderer).
inline Counts measure(const World& w, const accel::Accelerator& acc, const RayBudget& budget, uint64_t seed) {
    using namespace detail;
    tbb::enumerable_thread_specific<Counts> local;
    const double L = 3.0 * w.radius;  // origins well outside the mesh
    const float scene_scale = float(2.0 * w.radius);

    // (a) leaks at edges and vertices.
    if (!w.edges.empty() || !w.vertices.empty()) {
        const uint64_t n = budget.leak;
        for_each_ray(local, n, seed, 0x1EA4000000ull, [&](auto& c, accel::TraceStats& st, renderer::Rng& rng, uint64_t i) {
            thread_local std::vector<Vec3d> normals;  // scratch, reused per thread
            Vec3d target, d(0.0);
            const bool vertex = w.edges.empty() || (!w.vertices.empty() && (i & 1));
            bool axis = false;
            // A fan no direction sees all faces of from the front (folded by
            // rounding where the mesh collapses) is redrawn, so that the budget
            // counts rays cast, not attempts.
            for (int attempt = 0; attempt < 16 && d == Vec3d(0.0); ++attempt) {
                normals.clear();
                if (vertex) {
                    const uint32_t vi = w.vertices[rng.next_u32() % w.vertices.size()];
                    target = Vec3d(w.pos[vi]);
                    for (uint32_t t : w.fan[vi]) normals.push_back(w.unit_normal[t]);
                } else {
                    const World::Edge& e = w.edges[rng.next_u32() % w.edges.size()];
                    const Vec3d a(w.pos[e.a]), b(w.pos[e.b]);
                    target = a + (b - a) * rnd(rng);  // exact point of the edge, in double
                    normals = {w.unit_normal[e.t0], w.unit_normal[e.t1]};
                }
                d = front_direction(normals, rng, axis, vertex);
            }
            if (d == Vec3d(0.0)) return;
            float t_at;
            const accel::Ray ray = ray_at(target, d, L, t_at);
            accel::Hit h;
            // Slack past the target: the rounding of org and dir.
            const bool hit = acc.intersect(ray, h, st) && h.t <= t_at * (1.0f + 1e-3f);
            ++c.leak_rays;
            c.axis_rays += axis;
            c.vertex_rays += vertex;
            if (!hit && std::getenv("EXTREMES_DEBUG")) {
                std::vector<uint32_t> fan_tris;
                if (vertex) {
                    for (uint32_t vi = 0; vi < w.num_vertices; ++vi)
                        if (Vec3d(w.pos[vi]) == target) { fan_tris = w.fan[vi]; break; }
                }
                std::fprintf(stderr, "leak %s %s vertex=%d axis=%d org=(%.9g %.9g %.9g) dir=(%g %g %g) target=(%.12g %.12g %.12g) t_at=%g\n",
                             g_debug_label.c_str(), w.name.c_str(), int(vertex), int(axis), ray.org.x, ray.org.y, ray.org.z, ray.dir.x,
                             ray.dir.y, ray.dir.z, target.x, target.y, target.z, t_at);
                const Vec3d miss = Vec3d(ray.org) + Vec3d(ray.dir) - target;
                std::fprintf(stderr, "   miss (%g %g %g) hit=%d t=%g prim=%u\n", miss.x, miss.y, miss.z, int(acc.intersect(ray, h, st)), h.t, h.prim_id);
                for (uint32_t t : fan_tris) {
                    RefHit rh = ref_intersect(Vec3d(ray.org), Vec3d(ray.dir), w.v(t, 0), w.v(t, 1), w.v(t, 2));
                    std::fprintf(stderr, "   fan tri %u ref t=%.9g margin=%g\n", t, rh.t, rh.margin);
                }
            }
            if (!hit) {
                ++c.leaks;
                c.axis_leaks += axis;
                c.vertex_leaks += vertex;
            }
        });
    }

    // (b) acne.
    {
        const uint64_t n = budget.acne;
        for_each_ray(local, n, seed, 0xAC4E000000ull, [&](auto& c, accel::TraceStats& st, renderer::Rng& rng, uint64_t i) {
            // A primary ray: from outside toward a random surface point, or from
            // the centre outward (inner side of closed meshes).
            const uint32_t tri = rng.next_u32() % w.num_tris;
            if (w.degenerate[tri]) return;
            double a = rnd(rng), b = rnd(rng);
            if (a + b > 1) { a = 1 - a; b = 1 - b; }
            const Vec3d tp = Vec3d(w.v(tri, 0)) * (1 - a - b) + Vec3d(w.v(tri, 1)) * a + Vec3d(w.v(tri, 2)) * b;
            accel::Ray pr;
            if (i & 1) {
                pr.org = Vec3f(w.center);
                pr.dir = Vec3f(tp) - pr.org;
            } else {
                const Vec3d d = rand_dir(rng);
                float t_at;
                pr = ray_at(tp, d, L, t_at);
            }
            if (!accel::is_finite(pr.dir) || pr.dir == Vec3f(0.0f)) return;
            accel::Hit h;
            if (!acc.intersect(pr, h, st)) return;
            const Endpoint ep = make_endpoint(w, h.prim_id, h.u, h.v);
            const Vec3f p = ep.p, perr = ep.err;
            Vec3f ng = Vec3f(w.unit_normal[h.prim_id]);
            if (accel::dot(ng, pr.dir) > 0) ng = -ng;  // the side the ray arrived on
            const bool outward = w.convex && is_convex_side_outside(w, p, ng);
            const Vec3f wi = renderer::to_world(
                renderer::cosine_hemisphere(rng.next_float(), rng.next_float()), ng);
            if (!(accel::dot(wi, ng) > 0)) return;
            // Second point of the mutually visible pair on convex meshes: any
            // other inner point.
            Endpoint eq{};
            Vec3f nq;
            bool have_q = false;
            if (w.convex && !outward) {
                const uint32_t t2 = rng.next_u32() % w.num_tris;
                if (!w.degenerate[t2]) {
                    float a2 = rng.next_float(), b2 = rng.next_float();
                    if (a2 + b2 > 1) { a2 = 1 - a2; b2 = 1 - b2; }
                    eq = make_endpoint(w, t2, a2, b2);
                    nq = Vec3f(w.unit_normal[t2]);
                    if (is_convex_side_outside(w, eq.p, nq)) nq = -nq;
                    have_q = t2 != h.prim_id;
                }
            }
            for (int m = 0; m < 2; ++m) {
                const OffsetMode mode = kModes[m];
                const accel::Ray ray = renderer::spawn_ray(p, perr, ng, wi, scene_scale, mode);
                accel::Hit h2;
                ++c.hemi_rays[m];
                const bool hemi_hit = acc.intersect(ray, h2, st);
                Verdict hv = Verdict::Clear;
                if (hemi_hit) {
                    const RefHit rx = ref_intersect(ep.exact, Vec3d(wi), w.v(h2.prim_id, 0),
                                                    w.v(h2.prim_id, 1), w.v(h2.prim_id, 2));
                    if (own_surface(w, h2.prim_id, ep)) {
                        hv = Verdict::False;
                    } else if (rx.plane && rx.margin >= 0 && rx.t > 0) {
                        // The exact ray from the exact point hits it too.
                    } else if (touches_box(w, h2.prim_id, ep)) {
                        // A neighbour whose plane passes within reach of p (p sits
                        // within rounding of an edge): from some point of p's
                        // box the exact ray hits it too.
                        hv = Verdict::Ambiguous;
                    } else if (outward) {
                        hv = Verdict::False;  // left a convex mesh, yet hit it
                    } else if (double(h2.t) * accel::length(Vec3d(wi)) < 1e-3 * w.radius) {
                        // Near the origin, and the exact ray misses the triangle by
                        // more than a hair: the float ray found a surface that is
                        // not there.
                        if (!(rx.plane && rx.margin > -1e-6 && rx.t > 0)) hv = Verdict::False;
                    }
                }
                c.hemi_false[m] += hv == Verdict::False;
                c.hemi_ambiguous[m] += hv == Verdict::Ambiguous;
                if (hv == Verdict::False && m == 0 && std::getenv("EXTREMES_DEBUG"))
                    std::fprintf(stderr, "hemi-false %s %s src=%u hit=%u t=%g outward=%d p=(%.9g %.9g %.9g) perr=(%g %g %g) ng=(%g %g %g) wi=(%g %g %g)\n",
                                 g_debug_label.c_str(), w.name.c_str(), h.prim_id, h2.prim_id, h2.t, int(outward), p.x, p.y, p.z,
                                 perr.x, perr.y, perr.z, ng.x, ng.y, ng.z, wi.x, wi.y, wi.z);
                // Shadow segment back from where the hemisphere ray landed (a
                // mutually visible pair), both ends with their surface normals, as
                // the renderer spawns segments to surfaces and to area lights
                // (renderer::LightSample carries the light's normal; point lights
                // are exact points). What a segment without the target's normal
                // costs is measured in tests/stability (Lights.*).
                if (hemi_hit && hv == Verdict::Clear) {
                    const Endpoint e2 = make_endpoint(w, h2.prim_id, h2.u, h2.v);
                    Vec3f n2 = Vec3f(w.unit_normal[h2.prim_id]);
                    if (accel::dot(n2, wi) > 0) n2 = -n2;
                    const accel::Ray sg = renderer::spawn_segment(e2.p, e2.err, n2, p, perr, scene_scale, mode, ng);
                    ++c.shadow_rays[m];
                    const Verdict v = classify_segment(w, acc, sg, e2, ep, st);
                    c.shadow_false[m] += v == Verdict::False;
                    c.shadow_ambiguous[m] += v == Verdict::Ambiguous;
                }
                if (have_q) {
                    const accel::Ray sg = renderer::spawn_segment(p, perr, ng, eq.p, eq.err, scene_scale, mode, nq);
                    ++c.shadow_rays[m];
                    const Verdict v = classify_segment(w, acc, sg, ep, eq, st);
                    c.shadow_false[m] += v == Verdict::False;
                    c.shadow_ambiguous[m] += v == Verdict::Ambiguous;
                }
            }
        });
    }

    // (c, d) reference comparison: random, grazing and axis-parallel rays at interior
    // points of triangles.
    {
        const uint64_t n = budget.ref;
        for_each_ray(local, n, seed, 0x4EF0000000ull, [&](auto& c, accel::TraceStats& st, renderer::Rng& rng, uint64_t i) {
            const uint32_t tri = rng.next_u32() % w.num_tris;
            if (w.degenerate[tri]) return;
            // Uniform in the triangle, shrunk toward the centroid: every
            // barycentric >= 0.05.
            double a = rnd(rng), b = rnd(rng);
            if (a + b > 1) { a = 1 - a; b = 1 - b; }
            a = 1.0 / 3 + 0.85 * (a - 1.0 / 3);
            b = 1.0 / 3 + 0.85 * (b - 1.0 / 3);
            const Vec3d tp = Vec3d(w.v(tri, 0)) * (1 - a - b) + Vec3d(w.v(tri, 1)) * a + Vec3d(w.v(tri, 2)) * b;
            const Vec3d n = w.unit_normal[tri];
            Vec3d d;
            const uint32_t kind = i % 3;
            if (kind == 0) {
                d = rand_dir(rng);
            } else if (kind == 1) {
                // Grazing: tilt 1e-1 .. 1e-6 out of the plane.
                Vec3d t = accel::cross(n, std::abs(n.x) > 0.5 ? Vec3d(0, 1, 0) : Vec3d(1, 0, 0));
                t = t / accel::length(t);
                const Vec3d bt = accel::cross(n, t);
                const double phi = 2 * M_PI * rnd(rng), tilt = std::pow(10.0, -1.0 - 5.0 * rnd(rng));
                d = t * std::cos(phi) + bt * std::sin(phi) + n * ((rng.next_u32() & 1) ? tilt : -tilt);
                d = d / accel::length(d);
                ++c.grazing_rays;
            } else {
                d = Vec3d(0.0);
                const int k = int(rng.next_u32() % 3);
                d[k] = (rng.next_u32() & 1) ? 1.0 : -1.0;
            }
            float t_at;
            const accel::Ray ray = ray_at(tp, d, L, t_at);
            const RefHit ref = ref_intersect(Vec3d(ray.org), Vec3d(ray.dir), w.v(tri, 0), w.v(tri, 1),
                                             w.v(tri, 2));
            const RefBound rb = ref_bound(Vec3d(ray.org), Vec3d(ray.dir), w.v(tri, 0), w.v(tri, 1),
                                          w.v(tri, 2));
            // Only rays float can decide: inside by more than twice the edge
            // functions' error bound, in front of the origin by more than t's.
            if (!(ref.plane && rb.decidable_inside && ref.t > 2 * rb.delta_t)) return;
            ++c.ref_rays;
            accel::Hit h;
            const bool hit = acc.intersect(ray, h, st);
            // A miss, or a nearest hit beyond this triangle: the ray went through it.
            if (!hit || (h.prim_id != tri && double(h.t) > ref.t + 2 * rb.delta_t)) {
                if (std::getenv("EXTREMES_DEBUG"))
                    std::fprintf(stderr, "wmiss %s %s kind=%u tri=%u hit=%d ht=%g hprim=%u ref.t=%g dt=%g org=(%a %a %a) dir=(%a %a %a)\n",
                                 g_debug_label.c_str(), w.name.c_str(), kind, tri, int(hit), h.t, h.prim_id, ref.t, rb.delta_t,
                                 ray.org.x, ray.org.y, ray.org.z, ray.dir.x, ray.dir.y, ray.dir.z);
                ++c.wrong_miss;
                return;
            }
            if (h.prim_id != tri) return;  // something in front: fine, not comparable
            ++c.ref_compared;
            const double dt = std::abs(double(h.t) - ref.t);
            c.max_t_over_bound = std::max(c.max_t_over_bound, dt / rb.delta_t);
            if (kind == 1) {
                c.max_rel_t_grazing = std::max(c.max_rel_t_grazing, dt / ref.t);
            } else {
                c.max_rel_t = std::max(c.max_rel_t, dt / ref.t);
                c.max_bary = std::max({c.max_bary, std::abs(double(h.u) - ref.u), std::abs(double(h.v) - ref.v)});
            }
        });
    }

    Counts total;
    for (const Counts& c : local) total.add(c);
    total.dropped = acc.info().dropped;
    return total;
}

/// Thickness (unit-mesh units) of the thin wall at a placement: 1e-3 of the scene, but
/// at least 64 ulps of the placement's coordinates, since a wall thinner than a few ulps
/// cannot be represented (both faces round to the same plane) and every offset, pbrt's
/// included, steps through it.
inline double thin_wall_thickness(const Placement& pl) {
    const double coord = std::abs(pl.offset) * accel::length(offset_dir()) + pl.scale;
    const double ulp = std::nextafter(float(coord), INFINITY) - float(coord);
    return std::max(1e-3, 64.0 * ulp / pl.scale);
}

/// The instanced sweep's placement: the unit mesh as an instance, p_world = s * R p + t,
/// R a fixed rotation about a skew axis, t along offset_dir(). The float transform is
/// what the backends get; targets and normals are computed from its float entries in
/// double, so the exact surface is the float transform of the float mesh.
inline accel::Affine3f instance_transform(const Placement& pl) {
    const accel::Mat4f r = accel::Mat4f::rotate({0.3f, 1.0f, -0.6f}, 37.0f);
    const Vec3d off = offset_dir() * pl.offset;
    accel::Affine3f m;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) m.m[i][j] = float(double(r.m[i][j]) * pl.scale);
        m.m[i][3] = float(off[i]);
    }
    return m;
}

/// Leaks through an instance: the edge and vertex rays of measure()'s part (a), aimed
/// in world space at the exact image of an object-space edge point or vertex, from the
/// front of every face around it (the faces' world normals, by the inverse transpose).
/// `acc` holds `unit` (the object-space mesh at scale 1, at the origin) as the only
/// prototype, placed once by `m`. Inside an instance a watertight test stays watertight:
/// both faces of an edge meet the one object-space ray the transform made.
inline Counts measure_instance_leaks(const World& unit, const accel::Affine3f& m, const accel::Accelerator& acc,
                                     uint64_t n, uint64_t seed) {
    using namespace detail;
    tbb::enumerable_thread_specific<Counts> local;
    const auto apply = [&](const Vec3d& p) {
        Vec3d r;
        for (int i = 0; i < 3; ++i)
            r[i] = double(m.m[i][0]) * p.x + double(m.m[i][1]) * p.y + double(m.m[i][2]) * p.z + double(m.m[i][3]);
        return r;
    };
    // Normals by the inverse transpose, in double.
    double inv[3][3];
    {
        const auto& a = m.m;
        const double det = double(a[0][0]) * (double(a[1][1]) * a[2][2] - double(a[1][2]) * a[2][1]) -
                           double(a[0][1]) * (double(a[1][0]) * a[2][2] - double(a[1][2]) * a[2][0]) +
                           double(a[0][2]) * (double(a[1][0]) * a[2][1] - double(a[1][1]) * a[2][0]);
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) {
                const int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
                inv[j][i] = (double(a[i1][j1]) * a[i2][j2] - double(a[i1][j2]) * a[i2][j1]) / det;
            }
    }
    const accel::Affine3f inverse = m.inverse();
    double w_trans[3];  // the inverse's translation, -L^-1 t
    for (int i = 0; i < 3; ++i)
        w_trans[i] = -(inv[i][0] * double(m.m[0][3]) + inv[i][1] * double(m.m[1][3]) + inv[i][2] * double(m.m[2][3]));
    const auto normal = [&](const Vec3d& nn) {
        Vec3d r;
        for (int i = 0; i < 3; ++i) r[i] = inv[0][i] * nn.x + inv[1][i] * nn.y + inv[2][i] * nn.z;
        return r / accel::length(r);
    };
    double scale = 0;  // the largest row sum of |L|: bounds how far the transform stretches
    for (int i = 0; i < 3; ++i)
        scale = std::max(scale, std::fabs(double(m.m[i][0])) + std::fabs(double(m.m[i][1])) + std::fabs(double(m.m[i][2])));
    const double L = 3.0 * unit.radius * scale;  // origins well outside the instance
    if (unit.edges.empty() && unit.vertices.empty()) return {};
    for_each_ray(local, n, seed, 0x1A57000000ull, [&](auto& c, accel::TraceStats& st, renderer::Rng& rng, uint64_t i) {
        thread_local std::vector<Vec3d> normals;
        Vec3d target, d(0.0);
        const bool vertex = unit.edges.empty() || (!unit.vertices.empty() && (i & 1));
        bool axis = false;
        for (int attempt = 0; attempt < 16 && d == Vec3d(0.0); ++attempt) {
            normals.clear();
            if (vertex) {
                const uint32_t vi = unit.vertices[rng.next_u32() % unit.vertices.size()];
                target = apply(Vec3d(unit.pos[vi]));
                for (uint32_t t : unit.fan[vi]) normals.push_back(normal(unit.unit_normal[t]));
            } else {
                const World::Edge& e = unit.edges[rng.next_u32() % unit.edges.size()];
                const Vec3d a(unit.pos[e.a]), b(unit.pos[e.b]);
                target = apply(a + (b - a) * rnd(rng));
                normals = {normal(unit.unit_normal[e.t0]), normal(unit.unit_normal[e.t1])};
            }
            // World targets are not float points: no axis-parallel rays (ray_at keeps
            // those for exact float targets).
            d = front_direction(normals, rng, axis, false);
        }
        if (d == Vec3d(0.0)) return;
        float t_at;
        const accel::Ray ray = ray_at(target, d, L, t_at);
        // The backend tests the ray carried into object space, whose origin and direction
        // carry the transform's rounding: W org + w in float is within gamma(4) of
        // sum |W_ij org_j| + |w_i| per component (Higham 2002, 3.1; pbrt-v4 6.8.6), and W
        // itself is rounded (one more unit). The ray then passes that far (in object
        // units) from the target, and where it meets a face whose normal it makes
        // cos >= 0.02 with (front_direction), its t moves by at most that over
        // 0.02 |d_o|: the slack beyond which a hit is no longer the target's.
        double err = 0, dlen = 0;
        for (int r = 0; r < 3; ++r) {
            double mag = std::fabs(w_trans[r]), dmag = 0, dobj = 0;
            for (int k = 0; k < 3; ++k) {
                mag += std::fabs(inv[r][k] * ray.org[k]);
                dmag += std::fabs(inv[r][k] * ray.dir[k]);
                dobj += inv[r][k] * ray.dir[k];
            }
            err += (mag + dmag * t_at) * 5.0 * 0x1p-24 / (1.0 - 5.0 * 0x1p-24);
            dlen += dobj * dobj;
        }
        const float slack = float(err / (0.02 * std::sqrt(dlen)));
        accel::Hit h;
        bool hit = acc.intersect(ray, h, st) && h.t <= t_at * (1.0f + 1e-3f) + slack;
        if (!hit) {
            // That displacement can carry a ray aimed near the mesh's silhouette past it
            // (a target within rounding of a border the direction sees from behind):
            // then the exact mesh misses the very ray the backend tested, and so may
            // the backend. A leak is a miss of a ray the exact mesh hits in a triangle's
            // interior: the object-space ray (to_object_ray with the inverse the
            // backends use) against every triangle in double.
            const accel::Ray o = accel::to_object_ray(inverse, ray, ray.t_max);
            bool inside = false;
            for (uint32_t t = 0; t < unit.num_tris && !inside; ++t)
                if (!unit.degenerate[t]) {
                    const RefHit r = ref_intersect(Vec3d(o.org), Vec3d(o.dir), unit.v(t, 0), unit.v(t, 1), unit.v(t, 2));
                    inside = r.plane && r.margin > 1e-9 && r.t > 0 && r.t <= t_at * (1.0 + 1e-3) + slack;
                }
            hit = !inside;
        }
        ++c.leak_rays;
        c.vertex_rays += vertex;
        if (!hit) {
            ++c.leaks;
            c.vertex_leaks += vertex;
            if (std::getenv("EXTREMES_DEBUG")) {
                accel::Hit h2;
                const bool any = acc.intersect(ray, h2, st);
                double mind = 1e300, maxd = -1e300;
                for (const Vec3d& nn : normals) mind = std::min(mind, -accel::dot(nn, d)), maxd = std::max(maxd, -accel::dot(nn, d));
                std::fprintf(stderr, "instance leak %s vertex=%d hit=%d t=%.9g t_at=%g slack=%g cos=[%g, %g] prim=%u\n",
                             unit.name.c_str(), int(vertex), int(any), any ? h2.t : -1.0f, t_at, slack, mind, maxd,
                             any ? h2.prim_id : 0u);
            }
        }
    });
    Counts total;
    for (const Counts& c : local) total.add(c);
    return total;
}

/// Light leaking through a thin wall: a closed box wall of thickness `thickness` (x in
/// [0, thickness], |y| <= 0.9, z in [0, 0.9]) standing on a floor (z = 0, |x|, |y| <= 1),
/// placed like the meshes. Shadow segments run from floor points on the -x side (found
/// as a renderer finds them: barycentrics on a floor triangle, with their error bound;
/// distances to the wall log-uniform from 0.5 down to 5e-7) to point-light positions on
/// the +x side, which the wall hides. A segment the backend does not find occluded is a
/// leak. Leaks from points within reach of the wall's plane (error box plus offset,
/// detail::reach) are counted apart: there the floor point itself is within rounding of
/// the wall.
struct WallCounts {
    uint64_t rays[2] = {}, leaks[2] = {}, leaks_within[2] = {};  ///< per OffsetMode
    uint64_t dropped = 0;
};

inline World make_thin_wall(double thickness, const Placement& pl) {
    UnitMesh m;
    m.name = "thin-wall";
    m.pos = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
    m.idx = {0, 1, 2, 0, 2, 3};
    const double x0 = 0, x1 = thickness, y = 0.9, z = 0.9;
    const uint32_t b = 4;
    for (int k = 0; k < 8; ++k) m.pos.push_back(Vec3d(k & 1 ? x1 : x0, k & 2 ? y : -y, k & 4 ? z : 0.0));
    // Outward-wound faces of the box (corner k = x | 2y | 4z).
    const uint32_t f[12][3] = {{0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}, {0, 1, 5}, {0, 5, 4},
                               {2, 6, 7}, {2, 7, 3}, {0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}};
    for (const auto& t : f) m.idx.insert(m.idx.end(), {b + t[0], b + t[1], b + t[2]});
    return place_mesh(m, pl);
}

inline WallCounts measure_thin_wall(const World& w, double thickness, const accel::Accelerator& acc, uint64_t n,
                                    uint64_t seed) {
    using namespace detail;
    tbb::enumerable_thread_specific<WallCounts> local;
    const float scene_scale = float(2.0 * w.radius);
    const double s = w.place.scale;
    const Vec3d off = offset_dir() * w.place.offset;
    for_each_ray(local, n, seed, 0x3A1100000ull, [&](auto& c, accel::TraceStats& st, renderer::Rng& rng, uint64_t) {
        // Floor point at distance dx from the wall's face x = 0, as barycentrics of
        // the floor triangle that holds it.
        const double dx = 0.5 * std::pow(10.0, -6.0 * rnd(rng));
        const Vec3d local(-dx, rnd(rng) - 0.5, 0.0);
        const uint32_t tri = local.y > local.x ? 1 : 0;  // diagonal (-1,-1)-(1,1)
        const Vec3d a(w.v(tri, 0)), b(w.v(tri, 1)), cc(w.v(tri, 2));
        const Vec3d x = local * s + off;
        // Solve x = a + u (b - a) + v (c - a) in the floor plane (z is constant).
        const double det = (b.x - a.x) * (cc.y - a.y) - (b.y - a.y) * (cc.x - a.x);
        if (det == 0) return;
        const double u = ((x.x - a.x) * (cc.y - a.y) - (x.y - a.y) * (cc.x - a.x)) / det;
        const double v = ((b.x - a.x) * (x.y - a.y) - (b.y - a.y) * (x.x - a.x)) / det;
        const Endpoint ep = make_endpoint(w, tri, float(u), float(v));
        const Vec3f light(Vec3d(thickness + 0.05 + 0.45 * rnd(rng), rnd(rng) - 0.5, 0.1 + 0.4 * rnd(rng)) * s + off);
        // Within rounding: the exact floor point is within reach of the wall's face.
        const bool within = std::abs(ep.exact.x - off.x) <= reach(ep);
        for (int m = 0; m < 2; ++m) {
            const accel::Ray sg = renderer::spawn_segment(ep.p, ep.err, Vec3f(0, 0, 1), light, Vec3f(0.0f),
                                                          scene_scale, kModes[m]);
            ++c.rays[m];
            if (!acc.occluded(sg, st)) {
                if (m == 0 && std::getenv("EXTREMES_DEBUG"))
                    std::fprintf(stderr, "wall-leak %s dx=%g within=%d p=(%.9g %.9g %.9g) exact.x-off=%g org=(%.9g %.9g %.9g) tmin=%g tmax=%g light=(%.9g %.9g %.9g)\n",
                                 g_debug_label.c_str(), dx * s, int(within), ep.p.x, ep.p.y, ep.p.z, ep.exact.x - off.x, sg.org.x, sg.org.y, sg.org.z, sg.t_min, sg.t_max, light.x, light.y, light.z);
                ++c.leaks[m];
                c.leaks_within[m] += within;
            }
        }
    });
    WallCounts total;
    for (const WallCounts& c : local)
        for (int m = 0; m < 2; ++m) {
            total.rays[m] += c.rays[m];
            total.leaks[m] += c.leaks[m];
            total.leaks_within[m] += c.leaks_within[m];
        }
    total.dropped = acc.info().dropped;
    return total;
}

}  // namespace extremes
