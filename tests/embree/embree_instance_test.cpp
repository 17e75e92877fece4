// The Embree backend's instances (RTC_GEOMETRY_TYPE_INSTANCE over one child scene per
// prototype) must answer every query as (a) naive tracing the same instances and (b) naive
// tracing a flattened copy (every instance's triangles transformed into world space) do:
// same hit or miss, same instance / geometry / primitive, t within the rounding the
// transform explains, normals parallel with the same sign, same occlusion. Checked in
// normal mode (Embree's triangle test), robust normal mode against watertight naive, and
// counting mode (our intersector on Embree's object-space ray) with both triangle tests;
// masked prototypes must see the caller's world ray and the instance; a flat scene must
// build and trace as before.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "accel/accelerator.h"
#include "accel/embree/embree.h"
#include "tests/embree/test_meshes.h"

using namespace accel;
using test_meshes::TestMesh;
using test_meshes::random_in_box;

namespace {

constexpr float kEps = std::numeric_limits<float>::epsilon();

/// Closed UV sphere around the origin (test_meshes.h).
TestMesh tessellated_sphere(uint32_t stacks, uint32_t slices, float r) {
    return test_meshes::tessellated_sphere(stacks, slices, Vec3f(0.0f), r);
}

/// Closed box [-h, h]^3, outward winding, 12 triangles.
TestMesh box(float h) {
    TestMesh m;
    for (int i = 0; i < 8; ++i) m.positions.push_back(Vec3f(i & 1 ? h : -h, i & 2 ? h : -h, i & 4 ? h : -h));
    m.indices = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                 2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    m.finish();
    return m;
}

/// A unit quad in z = 0.6 (two triangles), beside the box in the same prototype.
TestMesh quad() {
    TestMesh m;
    m.positions = {{-0.5f, -0.5f, 0.6f}, {0.5f, -0.5f, 0.6f}, {0.5f, 0.5f, 0.6f}, {-0.5f, 0.5f, 0.6f}};
    m.indices = {0, 1, 2, 0, 2, 3};
    m.finish();
    return m;
}

/// Height field over [-s, s]^2 at y ~ y0: every interior edge shared by two triangles.
TestMesh grid(uint32_t n, float s, float y0) {
    TestMesh m;
    for (uint32_t i = 0; i <= n; ++i)
        for (uint32_t j = 0; j <= n; ++j) {
            float x = -s + 2.0f * s * float(i) / float(n), z = -s + 2.0f * s * float(j) / float(n);
            m.positions.push_back({x, y0 + 0.05f * s * std::sin(3.0f * x / s) * std::cos(2.0f * z / s), z});
        }
    for (uint32_t i = 0; i < n; ++i)
        for (uint32_t j = 0; j < n; ++j) {
            uint32_t a = i * (n + 1) + j, b = a + 1, c = a + n + 1, d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
    m.finish();
    return m;
}

TestMesh triangle_soup(uint32_t n, uint32_t seed, const Vec3f& lo, const Vec3f& hi) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> edge(-0.3f, 0.3f);
    TestMesh m;
    for (uint32_t i = 0; i < n; ++i) {
        Vec3f c = random_in_box(rng, lo, hi);
        for (int k = 0; k < 3; ++k) {
            m.positions.push_back(c + Vec3f(edge(rng), edge(rng), edge(rng)));
            m.indices.push_back(3 * i + k);
        }
    }
    m.finish();
    return m;
}

// ---- transforms ----

Affine3f translate(const Vec3f& t) {
    Affine3f a;
    a.m[0][3] = t.x, a.m[1][3] = t.y, a.m[2][3] = t.z;
    return a;
}
Affine3f scale(const Vec3f& s) {
    Affine3f a;
    a.m[0][0] = s.x, a.m[1][1] = s.y, a.m[2][2] = s.z;
    return a;
}
/// Rotation by `angle` about `axis` (Rodrigues).
Affine3f rotate(Vec3f axis, float angle) {
    axis = normalize(axis);
    const float c = std::cos(angle), s = std::sin(angle), C = 1.0f - c;
    const float x = axis.x, y = axis.y, z = axis.z;
    Affine3f a;
    a.m[0][0] = c + x * x * C, a.m[0][1] = x * y * C - z * s, a.m[0][2] = x * z * C + y * s;
    a.m[1][0] = y * x * C + z * s, a.m[1][1] = c + y * y * C, a.m[1][2] = y * z * C - x * s;
    a.m[2][0] = z * x * C - y * s, a.m[2][1] = z * y * C + x * s, a.m[2][2] = c + z * z * C;
    return a;
}
Affine3f shear(float xy, float yz) {
    Affine3f a;
    a.m[0][1] = xy, a.m[1][2] = yz;
    return a;
}
Affine3f random_transform(std::mt19937& rng, const Vec3f& lo, const Vec3f& hi, bool mirror) {
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    Vec3f s(0.3f + 1.7f * u(rng), 0.3f + 1.7f * u(rng), 0.3f + 1.7f * u(rng));
    if (mirror) s.y = -s.y;
    const Vec3f axis(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f + 1e-3f);
    return translate(random_in_box(rng, lo, hi)) * rotate(axis, 6.0f * u(rng)) * scale(s);
}

/// Max row sum of |L| (the infinity norm of the linear part).
double norm_inf(const Affine3f& a) {
    double n = 0;
    for (const auto& row : a.m) n = std::max(n, double(std::abs(row[0])) + std::abs(row[1]) + std::abs(row[2]));
    return n;
}
double translation_norm(const Affine3f& a) {
    return std::sqrt(double(a.m[0][3]) * a.m[0][3] + double(a.m[1][3]) * a.m[1][3] + double(a.m[2][3]) * a.m[2][3]);
}

// ---- masked geometry: a filter that records what it was given ----

/// What every filter call must satisfy, and what it saw. The test traces one ray at a
/// time (single-threaded) and points `current` at it first.
struct FilterLog {
    const Ray* current = nullptr;
    uint64_t calls = 0, ray_not_bitwise_world = 0;
    std::set<std::pair<uint32_t, uint32_t>> geom_inst;  // (geom, inst) pairs seen
};

/// Drops hits by a pure function of (prim, inst) only, so that two placements of one
/// triangle decide apart and every backend sees the same surface.
bool keep(uint32_t prim, uint32_t inst) {
    uint32_t h = prim * 0x9E3779B1u ^ (inst + 0x7F4A7C15u) * 0x85EBCA77u;
    h ^= h >> 15;
    return h % 3 != 0;
}

bool same_bits(const Ray& a, const Ray& b) {
    return std::memcmp(&a.org, &b.org, sizeof(Vec3f)) == 0 && std::memcmp(&a.dir, &b.dir, sizeof(Vec3f)) == 0 &&
           std::memcmp(&a.t_min, &b.t_min, sizeof(float)) == 0 && std::memcmp(&a.t_max, &b.t_max, sizeof(float)) == 0;
}

bool recording_filter(const void* user, uint32_t geom, uint32_t prim, uint32_t inst, float, float, const Ray& ray) {
    auto* log = const_cast<FilterLog*>(static_cast<const FilterLog*>(user));
    ++log->calls;
    if (!log->current || !same_bits(ray, *log->current)) ++log->ray_not_bitwise_world;
    log->geom_inst.insert({geom, inst});
    return keep(prim, inst);
}

/// The flattened copy's filter: one per copied view, naming the original geometry and
/// the instance the copy stands for, so the reference decides as the instances do.
struct FlatFilterUser {
    FilterLog* log;
    uint32_t geom, inst;
};
bool flat_filter(const void* user, uint32_t, uint32_t prim, uint32_t, float u, float v, const Ray& ray) {
    const auto* f = static_cast<const FlatFilterUser*>(user);
    return recording_filter(f->log, f->geom, prim, f->inst, u, v, ray);
}

// ---- scenes: views, prototypes, instances, and their flattened copy ----

struct InstancedScene {
    std::vector<TestMesh> meshes;  // the views' memory (view g = meshes[g])
    std::vector<GeometryView> views;
    std::vector<PrototypeView> protos;
    std::vector<InstanceView> insts;
    std::vector<float> proto_radius;  // max |v| over the prototype's vertices
    std::vector<int32_t> owner;       // prototype of each view, -1 = world space
    FilterLog log;

    // The flattened copy: world-space views only; flat_map names what each stands for.
    std::vector<TestMesh> flat_meshes;
    std::vector<FlatFilterUser> flat_users;
    std::vector<GeometryView> flat_views;
    std::vector<std::pair<uint32_t, uint32_t>> flat_map;  // flat view -> (inst, geom)
    std::vector<uint32_t> flat_of_world;                  // world view -> flat view
    std::vector<uint32_t> flat_of_inst;                   // instance -> its first flat view

    // Ray generation: a box holding the scene, points inside instances.
    Vec3f lo, hi;
    std::vector<Vec3f> inside_points;

    InstanceSet set() const { return {protos, insts}; }

    uint32_t add_mesh(TestMesh m, bool masked = false) {
        meshes.push_back(std::move(m));
        masked_.push_back(masked);
        return uint32_t(meshes.size() - 1);
    }
    void add_prototype(std::initializer_list<uint32_t> geoms) {
        // Prototype geometries are consecutive views by construction here.
        protos.push_back({*geoms.begin(), uint32_t(geoms.size())});
    }
    void place(uint32_t proto, const Affine3f& xf, bool inside_point = true) {
        insts.push_back({proto, xf});
        if (inside_point) inside_points.push_back(xf.point(Vec3f(0.0f)));
    }

    /// Views, owners, radii, and the flattened copy; call once all is added.
    void finish() {
        views.clear();
        for (size_t g = 0; g < meshes.size(); ++g) {
            GeometryView v = meshes[g].view();
            if (masked_[g]) {
                v.filter = recording_filter;
                v.filter_user = &log;
            }
            views.push_back(v);
        }
        owner.assign(views.size(), -1);
        proto_radius.assign(protos.size(), 0.0f);
        for (uint32_t p = 0; p < protos.size(); ++p)
            for (uint32_t g = protos[p].first_geom; g < protos[p].first_geom + protos[p].num_geoms; ++g) {
                owner[g] = int32_t(p);
                for (uint32_t k = 0; k < meshes[g].num_vertices; ++k)
                    proto_radius[p] = std::max(proto_radius[p], length(meshes[g].positions[k]));
            }
        // Flattened copy: world views as they are, then every instance's views with their
        // vertices carried to world space (rounded once per coordinate by point()).
        size_t copies = 0;
        for (const InstanceView& iv : insts) copies += protos[iv.prototype].num_geoms;
        flat_meshes.clear();
        flat_meshes.reserve(copies);
        flat_users.clear();
        flat_users.reserve(copies);
        flat_views.clear();
        flat_map.clear();
        flat_of_world.assign(views.size(), kInvalidId);
        for (uint32_t g = 0; g < views.size(); ++g)
            if (owner[g] < 0) {
                flat_of_world[g] = uint32_t(flat_views.size());
                flat_views.push_back(views[g]);
                flat_map.push_back({kInvalidId, g});
            }
        flat_of_inst.clear();
        for (uint32_t i = 0; i < insts.size(); ++i) {
            const PrototypeView& pv = protos[insts[i].prototype];
            flat_of_inst.push_back(uint32_t(flat_views.size()));
            for (uint32_t g = pv.first_geom; g < pv.first_geom + pv.num_geoms; ++g) {
                TestMesh m;
                for (uint32_t k = 0; k < meshes[g].num_vertices; ++k)
                    m.positions.push_back(insts[i].object_to_world.point(meshes[g].positions[k]));
                m.indices = meshes[g].indices;
                m.finish();
                flat_meshes.push_back(std::move(m));
                GeometryView v = flat_meshes.back().view();
                if (masked_[g]) {
                    flat_users.push_back({&log, g, i});
                    v.filter = flat_filter;
                    v.filter_user = &flat_users.back();
                }
                flat_views.push_back(v);
                flat_map.push_back({i, g});
            }
        }
    }

    /// The world-space triangle a hit names (from the flattened copy).
    void world_triangle(uint32_t inst, uint32_t geom, uint32_t prim, Vec3f& v0, Vec3f& v1, Vec3f& v2) const {
        const uint32_t f = inst == kInvalidId ? flat_of_world[geom]
                                              : flat_of_inst[inst] + (geom - protos[insts[inst].prototype].first_geom);
        const GeometryView& g = flat_views[f];
        const uint32_t* idx = g.indices + 3 * size_t(prim);
        v0 = g.positions[idx[0]], v1 = g.positions[idx[1]], v2 = g.positions[idx[2]];
    }

private:
    std::vector<bool> masked_;
};

/// Prototype 0: a sphere (view 1); prototype 1: a box and a quad (views 2, 3); world
/// space: a floor grid (view 0) before them and a triangle soup (view 4) after them, so
/// geometry IDs of both kinds leave holes on either side of the prototypes'. Instances:
/// translations, rotations, non-uniform scales, shears, mirrors (one and three negative
/// axes) and random placements with and without a mirror. `masked` adds prototype 2, a
/// masked grid (view 5), placed three times, and makes the world grid masked as well.
void build_main(InstancedScene& s, bool masked) {
    s.add_mesh(grid(12, 7.0f, -5.5f), masked);       // 0: world
    s.add_mesh(tessellated_sphere(8, 16, 1.0f));      // 1: prototype 0
    s.add_mesh(box(0.5f));                            // 2: prototype 1
    s.add_mesh(quad());                               // 3: prototype 1
    s.add_mesh(triangle_soup(60, 5, Vec3f(-5.0f), Vec3f(5.0f)));  // 4: world
    s.add_prototype({1});
    s.add_prototype({2, 3});
    if (masked) {
        s.add_mesh(grid(6, 1.0f, 0.0f), true);  // 5: prototype 2
        s.add_prototype({5});
    }
    const float half_pi = 0.5f * kPi;
    s.place(0, translate({-3.0f, 0.0f, 0.0f}));
    s.place(0, translate({3.0f, 1.0f, -1.0f}) * scale({1.5f, 0.5f, 1.0f}) * rotate({1, 1, 0}, 0.7f));
    s.place(0, translate({0.0f, 3.0f, 2.0f}) * scale({-1.0f, 1.0f, 1.0f}) * rotate({0, 0, 1}, 0.3f));
    s.place(0, translate({0.0f, -3.0f, -2.0f}) * scale({1.0f, -0.8f, 1.2f}));
    s.place(0, translate({0.5f, 0.2f, 0.1f}) * scale(Vec3f(0.2f)));
    s.place(1, translate({2.0f, -2.0f, 2.0f}));
    s.place(1, translate({-2.0f, 2.0f, -2.0f}) * rotate({0, 1, 1}, half_pi) * scale({0.3f, 2.0f, 1.0f}));
    s.place(1, translate({-3.0f, -3.0f, 3.0f}) * scale(Vec3f(-1.0f)));
    s.place(1, translate({3.0f, -1.0f, 3.5f}) * shear(0.5f, 0.3f));
    std::mt19937 rng(1234);
    for (int k = 0; k < 6; ++k) s.place(uint32_t(k % 2), random_transform(rng, Vec3f(-4.5f), Vec3f(4.5f), k % 3 == 0));
    if (masked) {
        s.place(2, translate({0.0f, 0.0f, -4.0f}) * rotate({1, 0, 0}, half_pi) * scale(Vec3f(2.0f)));
        s.place(2, translate({0.0f, 0.0f, 4.0f}) * rotate({1, 0, 0}, -half_pi) * scale({2.0f, 1.0f, -2.0f}));
        s.place(2, translate({4.5f, 0.0f, 0.0f}) * rotate({0, 0, 1}, half_pi) * scale(Vec3f(1.5f)));
    }
    s.lo = Vec3f(-6.0f), s.hi = Vec3f(6.0f);
    s.finish();
}

/// Far from the origin: a cluster of instances translated by ~1e5 (where a float's ulp
/// is 2^-7), rotated and scaled, with no world geometry near them.
void build_far(InstancedScene& s) {
    s.add_mesh(tessellated_sphere(8, 16, 1.0f));  // 0
    s.add_mesh(box(0.5f));                        // 1
    s.add_mesh(quad());                           // 2
    s.add_prototype({0});
    s.add_prototype({1, 2});
    const Vec3f c(1.0e5f, -1.0e5f, 5.0e4f);
    std::mt19937 rng(77);
    for (int k = 0; k < 12; ++k) {
        Affine3f xf = random_transform(rng, Vec3f(-8.0f), Vec3f(8.0f), k % 4 == 1);
        s.place(uint32_t(k % 2), translate(c) * scale(Vec3f(2.0f)) * xf);
    }
    s.lo = c - Vec3f(20.0f), s.hi = c + Vec3f(20.0f);
    s.finish();
}

/// Millimetre scale: instances scaled by 1e-3 (one non-uniformly, one mirrored), a few
/// millimetres apart, next to a world-space soup of the same size.
void build_tiny(InstancedScene& s) {
    s.add_mesh(tessellated_sphere(8, 16, 1.0f));  // 0
    s.add_mesh(box(0.5f));                        // 1
    s.add_mesh(quad());                           // 2
    TestMesh soup = triangle_soup(20, 3, Vec3f(-4.0f), Vec3f(4.0f));
    for (uint32_t k = 0; k < soup.num_vertices; ++k) soup.positions[k] = soup.positions[k] * 1e-3f;
    s.add_mesh(std::move(soup));                  // 3: world
    s.add_prototype({0});
    s.add_prototype({1, 2});
    s.place(0, translate({-2e-3f, 0.0f, 0.0f}) * scale(Vec3f(1e-3f)));
    s.place(0, translate({2e-3f, 1e-3f, 0.0f}) * scale({1e-3f, 2e-3f, 0.5e-3f}) * rotate({1, 2, 3}, 1.0f));
    s.place(1, translate({0.0f, -2.5e-3f, 1e-3f}) * scale({-1e-3f, 1e-3f, 1e-3f}));
    s.place(1, translate({0.0f, 2.5e-3f, -1e-3f}) * rotate({0, 1, 0}, 0.4f) * scale(Vec3f(1.5e-3f)));
    s.lo = Vec3f(-5e-3f), s.hi = Vec3f(5e-3f);
    s.finish();
}

/// Camera-like rays from outside the scene's box toward points in it, rays from inside
/// instances (their centres), shadow segments between two points of the box (t in
/// [1e-4, 1], as a light sample), and windows [t_min, t_max] that clip hits.
std::vector<Ray> random_rays(const InstancedScene& s, uint32_t n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const Vec3f c = (s.lo + s.hi) * 0.5f, d = s.hi - s.lo;
    std::vector<Ray> rays;
    rays.reserve(n);
    for (uint32_t i = 0; i < n; ++i) {
        Ray r;
        const Vec3f target = random_in_box(rng, s.lo, s.hi);
        switch (i % 4) {
            case 0:  // camera: from a box three times the scene's, outside the scene
                do r.org = random_in_box(rng, c - d * 1.5f, c + d * 1.5f);
                while (r.org.x > s.lo.x && r.org.x < s.hi.x && r.org.y > s.lo.y && r.org.y < s.hi.y &&
                       r.org.z > s.lo.z && r.org.z < s.hi.z);
                r.dir = target - r.org;
                break;
            case 1: {  // from inside an instance
                const Vec3f p = s.inside_points[i / 4 % s.inside_points.size()];
                r.org = p + (random_in_box(rng, Vec3f(-1.0f), Vec3f(1.0f)) * (0.01f * length(d)));
                r.dir = target - r.org;
                break;
            }
            case 2:  // shadow segment
                r.org = random_in_box(rng, s.lo, s.hi);
                r.dir = target - r.org;
                r.t_min = 1e-4f;
                r.t_max = 1.0f;
                break;
            default:  // a window
                r.org = random_in_box(rng, s.lo, s.hi);
                r.dir = target - r.org;
                r.t_min = 0.3f * u(rng);
                r.t_max = r.t_min + 1.5f * u(rng);
                break;
        }
        if (!(length(r.dir) > 0.0f)) r.dir = Vec3f(0.0f, 0.0f, 1.0f);
        rays.push_back(r);
    }
    return rays;
}

// ---- tracing and comparing ----

struct Result {
    bool hit = false, occluded = false;
    Hit h;
};

/// Every ray through `a`, intersect and occluded; `flat` maps the flattened copy's
/// geometry back to (instance, view).
std::vector<Result> trace_all(const Accelerator& a, InstancedScene& s, const std::vector<Ray>& rays, bool flat) {
    std::vector<Result> out(rays.size());
    TraceStats st;
    for (size_t i = 0; i < rays.size(); ++i) {
        s.log.current = &rays[i];
        out[i].hit = a.intersect(rays[i], out[i].h, st);
        out[i].occluded = a.occluded(rays[i], st);
        if (flat && out[i].hit) {
            const auto [inst, geom] = s.flat_map[out[i].h.geom_id];
            EXPECT_EQ(out[i].h.inst_id, kInvalidId) << "flattened copy has no instances";
            out[i].h.inst_id = inst;
            out[i].h.geom_id = geom;
        }
    }
    s.log.current = nullptr;
    return out;
}

struct Report {
    uint64_t rays = 0, hits = 0, inst_hits = 0, ties = 0, near_edge = 0;
    double max_t_ratio = 0.0;  // largest |dt| / (transform part of the bound)
};

/// How far (world units) the two tested rays, or the two copies of a triangle, can sit
/// apart by rounding for a hit of instance `inst`. The instance path carries the ray into
/// object space: o' = W o + w, d' = W d, with W = L^-1 computed by Embree in float
/// (naive: in double, rounded once), so L W differs from I by a few ulps times
/// kappa = |L||W| (the condition number); the three products and two sums of each
/// component add a few ulps of |W||o| + |w| and of |W||d| (Higham 2002, section 3.1).
/// Carried back to world space by L, both come to within c eps kappa (|o| + |T| + t|d|),
/// |T| the translation (|w| <= |W||T|), |o| and t|d| the ray's origin and length to the
/// hit. The flattened copy instead rounds each vertex once, within eps (|L| R + |T|), R
/// the prototype's radius. With c = 16 (about four roundings of an ulp each, and the
/// infinity norms' factor up to 3 against the 2-norm's) the sum bounds both; world-space
/// hits get the same with L = I, T = 0. compare() prints the largest observed fraction.
double displacement(const InstancedScene& s, const Ray& ray, uint32_t inst, double t) {
    double kappa = 1.0, T = 0.0, LR = 0.0;
    if (inst != kInvalidId) {
        const Affine3f& xf = s.insts[inst].object_to_world;
        kappa = norm_inf(xf) * norm_inf(xf.inverse());
        T = translation_norm(xf);
        LR = norm_inf(xf) * s.proto_radius[s.insts[inst].prototype];
    }
    const double o = length(ray.org), d = length(ray.dir);
    return 16.0 * kEps * (kappa * (o + T + t * d) + LR + T);
}

/// Whether a hit at (u, v) of the given world triangle lies within `dist` of the
/// triangle's boundary (distance to the edge opposite vertex k = barycentric_k * its
/// altitude): a ray that near an edge may pass on either side under rounding.
bool near_edge(const Vec3f& v0, const Vec3f& v1, const Vec3f& v2, float u, float v, double dist) {
    const double area2 = length(cross(v1 - v0, v2 - v0));
    const double b[3] = {1.0 - u - v, u, v};
    const double e[3] = {length(v2 - v1), length(v2 - v0), length(v1 - v0)};
    for (int k = 0; k < 3; ++k)
        if (e[k] > 0.0 && b[k] * area2 / e[k] <= dist) return true;
    return false;
}

/// Compares `test` with `ref` (both in (instance, view) terms). `t_rel`: the two
/// triangle tests' own disagreement on one ray (Embree's vs ours: 1e-5 relative as in
/// embree_agreement_test; 0 where both run ours). Every disagreement must be a near-tie:
/// the hit the other side lacks lies within the rounding displacement of an edge.
/// `tie_fraction`: how many rays may be ties or near-ties, which takes a ray within the
/// displacement of an edge: rare (1e-3) where the displacement is small against the
/// triangles.
Report compare(const InstancedScene& s, const std::vector<Ray>& rays, const std::vector<Result>& test,
               const std::vector<Result>& ref, const std::string& what, float t_rel, double tie_fraction) {
    Report rep;
    int failures = 0;
    for (size_t i = 0; i < rays.size() && failures < 10; ++i) {
        const Ray& ray = rays[i];
        const Result &a = test[i], &b = ref[i];
        ++rep.rays;
        auto fail = [&](const std::string& why) {
            ADD_FAILURE() << what << ": ray " << i << ": " << why << " (test t=" << a.h.t << " inst " << a.h.inst_id
                          << " geom " << a.h.geom_id << " prim " << a.h.prim_id << "; ref t=" << b.h.t << " inst "
                          << b.h.inst_id << " geom " << b.h.geom_id << " prim " << b.h.prim_id << ")";
            ++failures;
        };
        // A hit that the other side does not report: legitimate only near an edge.
        auto is_near_tie = [&](const Result& r) {
            Vec3f v0, v1, v2;
            s.world_triangle(r.h.inst_id, r.h.geom_id, r.h.prim_id, v0, v1, v2);
            const Vec3f n = cross(v1 - v0, v2 - v0);
            const double cos_abs = std::abs(dot(normalize(n), normalize(ray.dir)));
            return near_edge(v0, v1, v2, r.h.u, r.h.v, displacement(s, ray, r.h.inst_id, r.h.t) / std::max(cos_abs, 1e-3));
        };
        // Ids in range and consistent: a view of a prototype only through one of its instances.
        if (a.hit && (a.h.geom_id >= s.views.size() ||
                      (a.h.inst_id == kInvalidId ? s.owner[a.h.geom_id] != -1
                                                 : a.h.inst_id >= s.insts.size() ||
                                                       s.owner[a.h.geom_id] != int32_t(s.insts[a.h.inst_id].prototype)) ||
                      a.h.prim_id >= s.views[a.h.geom_id].num_prims)) {
            fail("ids out of range or inconsistent");
            continue;
        }
        if (a.occluded != a.hit) { fail("occluded disagrees with intersect (test)"); continue; }
        if (b.occluded != b.hit) { fail("occluded disagrees with intersect (ref)"); continue; }
        if (a.hit != b.hit) {
            if (is_near_tie(a.hit ? a : b)) ++rep.near_edge;
            else fail("hit/miss differs");
            continue;
        }
        if (!a.hit) continue;
        ++rep.hits;
        rep.inst_hits += a.h.inst_id != kInvalidId;
        if (!(a.h.t >= ray.t_min && a.h.t <= ray.t_max)) { fail("t outside [t_min, t_max]"); continue; }
        // t: the triangle tests' own part (grazing-scaled as in embree_agreement_test)
        // plus the displacement over the ray's speed across the plane, |d| |cos|.
        Vec3f v0, v1, v2;
        s.world_triangle(b.h.inst_id, b.h.geom_id, b.h.prim_id, v0, v1, v2);
        const Vec3f n_world = cross(v1 - v0, v2 - v0);
        const double cos_abs = std::abs(dot(normalize(n_world), normalize(ray.dir)));
        const double moved = displacement(s, ray, b.h.inst_id, b.h.t) / (length(ray.dir) * std::max(cos_abs, 1e-3));
        const double own = t_rel * std::max(b.h.t, 0.01f) * std::max(1.0, 0.1 / std::max(cos_abs, 1e-4));
        const double dt = std::abs(double(a.h.t) - double(b.h.t));
        if (!(dt <= own + moved)) {
            // One side passed a triangle the other hit: a near-tie if the nearer hit is at an edge.
            if (is_near_tie(a.h.t < b.h.t ? a : b)) { ++rep.near_edge; continue; }
            fail("t differs by " + std::to_string(dt) + " (bound " + std::to_string(own + moved) + ")");
            continue;
        }
        rep.max_t_ratio = std::max(rep.max_t_ratio, dt > own ? (dt - own) / moved : 0.0);
        if (a.h.inst_id != b.h.inst_id || a.h.geom_id != b.h.geom_id || a.h.prim_id != b.h.prim_id) {
            // Same t (checked above), another triangle: a shared edge or vertex, which the
            // ray must pass within the rounding displacement of.
            if (is_near_tie(a) || is_near_tie(b)) ++rep.ties;
            else fail("another triangle at the same t, away from any edge");
            continue;
        }
        // Normals: parallel, same sign. The flattened copy's triangle is tilted by its
        // vertices' rounding: up to ~2 * displacement / (its smallest altitude).
        const Vec3f na = normalize(a.h.ng), nb = normalize(b.h.ng);
        const double altitude = length(n_world) / std::max({length(v1 - v0), length(v2 - v0), length(v2 - v1)});
        const double n_tol = 1e-3 + 2.0 * displacement(s, ray, b.h.inst_id, 0.0) / altitude;
        if (!(dot(a.h.ng, b.h.ng) > 0.0f) || !(length(cross(na, nb)) <= n_tol)) {
            fail("normal not parallel with the same sign");
            continue;
        }
    }
    EXPECT_EQ(failures, 0) << what;
    EXPECT_LE(double(rep.near_edge + rep.ties), tie_fraction * double(std::max<uint64_t>(rep.rays, 1000)))
        << what << ": too many ties and near-ties";
    std::printf("[%s] %llu rays, %llu hits (%llu in instances), %llu ties, %llu near-edge, max dt / transform bound %.3g\n",
                what.c_str(), (unsigned long long)rep.rays, (unsigned long long)rep.hits,
                (unsigned long long)rep.inst_hits, (unsigned long long)rep.ties, (unsigned long long)rep.near_edge,
                rep.max_t_ratio);
    return rep;
}

struct Mode {
    const char* name;
    bool count;
    bool robust;
    TriangleTest test;  // naive's, and the counting mode's
    float t_rel;        // see compare()
};
const Mode kModes[] = {
    {"normal", false, false, TriangleTest::Fast, 1e-5f},
    {"robust", false, true, TriangleTest::Watertight, 1e-5f},
    {"count-fast", true, false, TriangleTest::Fast, 0.0f},
    {"count-watertight", true, false, TriangleTest::Watertight, 0.0f},
};

AccelOptions options_of(const Mode& m) {
    AccelOptions o;
    o.embree_count = m.count;
    o.embree_robust = m.robust;
    o.triangle = m.test;
    return o;
}

/// Embree in every mode against (a) naive instanced and (b) naive flattened.
void check_scene(InstancedScene& s, const std::string& label, uint32_t n_rays, uint32_t seed,
                 double tie_fraction = 1e-3) {
    const auto rays = random_rays(s, n_rays, seed);
    for (TriangleTest tt : {TriangleTest::Fast, TriangleTest::Watertight}) {
        AccelOptions no;
        no.triangle = tt;
        auto naive_inst = create_accelerator("naive", s.views, no, s.set());
        auto naive_flat = create_accelerator("naive", s.flat_views, no);
        const auto ref_inst = trace_all(*naive_inst, s, rays, false);
        const auto ref_flat = trace_all(*naive_flat, s, rays, true);
        for (const Mode& m : kModes) {
            if (m.test != tt) continue;
            const AccelOptions o = options_of(m);
            auto e = create_accelerator("embree", s.views, o, s.set());
            const BuildInfo& info = e->info();
            EXPECT_EQ(info.instances, naive_inst->info().instances);
            EXPECT_EQ(info.instances, s.insts.size());
            EXPECT_EQ(info.instanced_primitives, naive_inst->info().instanced_primitives);
            EXPECT_EQ(info.primitives, naive_inst->info().primitives);
            EXPECT_EQ(info.dropped, naive_inst->info().dropped);
            EXPECT_NE(info.backend.find("instances"), std::string::npos) << info.backend;
            EXPECT_GT(info.bytes, 0u);
            EXPECT_GT(info.build_seconds, 0.0);
            EXPECT_TRUE(e->bounds().contains(naive_inst->bounds())) << label << "/" << m.name;
            const auto got = trace_all(*e, s, rays, false);
            const std::string what = label + "/" + m.name;
            const Report ra = compare(s, rays, got, ref_inst, what + " vs naive instanced", m.t_rel, tie_fraction);
            compare(s, rays, got, ref_flat, what + " vs naive flattened", m.t_rel, tie_fraction);
            EXPECT_GT(ra.inst_hits, ra.rays / 10) << what << ": rays should mostly hit instances";
            if (m.count) {
                // Counting mode tests our intersector on every candidate, instanced ones too.
                TraceStats st;
                Hit h;
                for (size_t i = 0; i < 1000; ++i) e->intersect(rays[i], h, st);
                EXPECT_GT(st.prim_tests, 0u);
                EXPECT_TRUE(info.counts_prims);
            }
        }
    }
}

}  // namespace

TEST(EmbreeInstances, MainSceneAgreesWithNaiveInstancedAndFlattened) {
    InstancedScene s;
    build_main(s, false);
    check_scene(s, "main", 60000, 11);
}

TEST(EmbreeInstances, FarTranslationAgrees) {
    InstancedScene s;
    build_far(s);
    // At 1.5e5 a float's ulp is 2^-6: the object-space origin (and the flattened copy's
    // vertices) carry a few hundredths of a world unit, against triangles ~1 unit across
    // (scale 2 of the unit sphere's 16 slices): a few percent of the hits lie that near
    // an edge and may name the neighbour, in every backend alike. Each must still be
    // explained (near an edge); their number is bounded at 5%.
    check_scene(s, "far", 20000, 12, 0.05);
}

TEST(EmbreeInstances, TinyScaleAgrees) {
    InstancedScene s;
    build_tiny(s);
    check_scene(s, "tiny", 20000, 13);
}

// Masked geometry inside instances (and beside them in world space): every filter call
// gets the caller's world ray bit for bit and names the instance, in intersect and
// occluded, normal and counting mode; dropping by (prim, inst) gives the surface naive
// sees, instanced or flattened.
TEST(EmbreeInstances, MaskedPrototypesSeeWorldRayAndInstance) {
    InstancedScene s;
    build_main(s, true);
    check_scene(s, "masked", 20000, 14);
    const uint32_t masked_proto = 2, masked_geom = 5;
    for (bool count : {false, true}) {
        AccelOptions o;
        o.embree_count = count;
        auto e = create_accelerator("embree", s.views, o, s.set());
        s.log = FilterLog{};
        const auto rays = random_rays(s, 20000, 15);
        trace_all(*e, s, rays, false);
        EXPECT_GT(s.log.calls, 1000u);
        EXPECT_EQ(s.log.ray_not_bitwise_world, 0u) << "filters must get the caller's world ray";
        std::set<uint32_t> insts_seen;
        for (const auto& [geom, inst] : s.log.geom_inst) {
            if (geom == masked_geom) {
                ASSERT_LT(inst, s.insts.size());
                EXPECT_EQ(s.insts[inst].prototype, masked_proto);
                insts_seen.insert(inst);
            } else {
                EXPECT_EQ(geom, 0u) << "only views 0 and 5 are masked";
                EXPECT_EQ(inst, kInvalidId) << "world-space geometry has no instance";
            }
        }
        EXPECT_EQ(insts_seen.size(), 3u) << "every placement of the masked prototype was asked";
        // Occlusion alone goes through the occlusion filter: it too gets the world ray.
        s.log = FilterLog{};
        TraceStats st;
        for (const Ray& r : rays) {
            s.log.current = &r;
            e->occluded(r, st);
        }
        EXPECT_GT(s.log.calls, 100u);
        EXPECT_EQ(s.log.ray_not_bitwise_world, 0u);
    }
}

// Hand-made checks of the mapping and the normal convention under a mirror.
TEST(EmbreeInstances, IdsAndMirroredNormal) {
    TestMesh world_quad = quad(), proto_quad = quad();
    TestMesh proto_box = box(0.5f);
    std::vector<GeometryView> views{world_quad.view(), proto_box.view(), proto_quad.view()};
    std::vector<PrototypeView> protos{{1, 2}};
    // Instance 0: the prototype moved to x = 10; instance 1: mirrored in x at x = 20.
    std::vector<InstanceView> insts{{0, translate({10, 0, 0})}, {0, translate({20, 0, 0}) * scale({-1, 1, 1})}};
    for (bool count : {false, true}) {
        SCOPED_TRACE(count ? "counting" : "normal");
        AccelOptions o;
        o.embree_count = count;
        auto e = create_accelerator("embree", views, o, InstanceSet{protos, insts});
        TraceStats st;
        Hit h;
        // The world quad at z = 0.6, from -z: its normal (0, 0, 1) faces away from the ray.
        ASSERT_TRUE(e->intersect(Ray{{0, 0, -5}, {0, 0, 1}}, h, st));
        EXPECT_EQ(h.inst_id, kInvalidId);
        EXPECT_EQ(h.geom_id, 0u);
        EXPECT_NEAR(h.t, 5.6f, 1e-5f);
        // Instance 0: the box's -z face first (outward normal -z).
        ASSERT_TRUE(e->intersect(Ray{{10.1f, 0.1f, -5}, {0, 0, 1}}, h, st));
        EXPECT_EQ(h.inst_id, 0u);
        EXPECT_EQ(h.geom_id, 1u);
        EXPECT_NEAR(h.t, 4.5f, 1e-5f);
        EXPECT_LT(h.ng.z, 0.0f);
        // Just past the box's +z face: the quad (view 2), normal +z.
        Ray past{{10.1f, 0.1f, 0.55f}, {0, 0, 1}};
        ASSERT_TRUE(e->intersect(past, h, st));
        EXPECT_EQ(h.geom_id, 2u);
        EXPECT_EQ(h.inst_id, 0u);
        EXPECT_NEAR(h.t, 0.05f, 1e-5f);
        EXPECT_GT(h.ng.z, 0.0f);
        // Instance 1 mirrors x: the mirrored winding turns every normal (the cross product
        // of the transformed edges, not flipped back): the box's -z face now reports +z,
        // the quad -z, exactly as a flattened copy's triangles would.
        ASSERT_TRUE(e->intersect(Ray{{20.1f, 0.1f, -5}, {0, 0, 1}}, h, st));
        EXPECT_EQ(h.inst_id, 1u);
        EXPECT_EQ(h.geom_id, 1u);
        EXPECT_NEAR(h.t, 4.5f, 1e-5f);
        EXPECT_GT(h.ng.z, 0.0f);
        ASSERT_TRUE(e->intersect(Ray{{20.1f, 0.1f, 0.55f}, {0, 0, 1}}, h, st));
        EXPECT_EQ(h.inst_id, 1u);
        EXPECT_EQ(h.geom_id, 2u);
        EXPECT_EQ(h.prim_id, 1u) << "x mirrored: (20.1, 0.1) is (-0.1, 0.1) in object space";
        EXPECT_NEAR(h.t, 0.05f, 1e-5f);
        EXPECT_NEAR(h.ng.z, -1.0f, 1e-5f);
        EXPECT_TRUE(e->occluded(Ray{{20.1f, 0.1f, -5}, {0, 0, 1}, 0.0f, 4.6f}, st));
        EXPECT_FALSE(e->occluded(Ray{{20.1f, 0.1f, -5}, {0, 0, 1}, 0.0f, 4.4f}, st));
        // Prototype geometry is not in world space by itself: this segment would meet
        // the box at the origin (t = 4.5), and stops before the world quad (z = 0.6).
        EXPECT_FALSE(e->intersect(Ray{{0.1f, 0.1f, -5}, {0, 0, 1}, 0.0f, 5.0f}, h, st));
        EXPECT_FALSE(e->occluded(Ray{{0.1f, 0.1f, -5}, {0, 0, 1}, 0.0f, 5.0f}, st));
        EXPECT_EQ(e->info().instances, 2u);
        EXPECT_EQ(e->info().instanced_primitives, 2u * 14u);
        EXPECT_EQ(e->info().primitives, 2u + 14u);
    }
}

// An empty InstanceSet builds the flat scene as before: the same label, the same answers
// bit for bit as the call without one, and no instance named.
TEST(EmbreeInstances, FlatSceneUnchangedWithEmptyInstanceSet) {
    TestMesh a = tessellated_sphere(16, 32, 1.5f), b = grid(16, 4.0f, -2.0f);
    std::vector<GeometryView> views{a.view(), b.view()};
    InstancedScene dummy;  // for random_rays' box only
    dummy.lo = Vec3f(-4.0f), dummy.hi = Vec3f(4.0f);
    dummy.inside_points = {Vec3f(0.0f)};
    const auto rays = random_rays(dummy, 20000, 16);
    for (bool count : {false, true}) {
        AccelOptions o;
        o.embree_count = count;
        auto plain = make_embree(views, o);
        auto empty = make_embree(views, o, InstanceSet{});
        EXPECT_EQ(plain->info().backend, empty->info().backend);
        EXPECT_EQ(empty->info().backend, count ? "embree(count, high, fast)" : "embree(high)");
        EXPECT_EQ(empty->info().instances, 0u);
        EXPECT_EQ(empty->info().instanced_primitives, 0u);
        EXPECT_EQ(plain->info().primitives, empty->info().primitives);
        TraceStats sp, se;
        int mismatches = 0;
        uint64_t hits = 0;
        for (const Ray& r : rays) {
            Hit hp, he;
            const bool bp = plain->intersect(r, hp, sp), be = empty->intersect(r, he, se);
            hits += be;
            mismatches += bp != be || plain->occluded(r, sp) != empty->occluded(r, se) ||
                          std::memcmp(&hp, &he, sizeof(Hit)) != 0 || he.inst_id != kInvalidId;
        }
        EXPECT_EQ(mismatches, 0);
        EXPECT_GT(hits, rays.size() / 4);
        EXPECT_EQ(sp.prim_tests, se.prim_tests);
    }
}

// BuildInfo.bytes counts the instances: Embree's memory monitor sees their BVH, the heap
// growth while creating them their geometry objects (which the monitor does not see).
TEST(EmbreeInstances, BytesGrowWithInstances) {
    TestMesh proto = box(0.5f);
    std::vector<GeometryView> views{proto.view()};
    std::vector<PrototypeView> protos{{0, 1}};
    auto placed = [&](uint32_t n) {
        std::vector<InstanceView> insts;
        for (uint32_t i = 0; i < n; ++i) insts.push_back({0, translate({2.0f * float(i % 100), 2.0f * float(i / 100), 0})});
        return insts;
    };
    const auto few = placed(10), many = placed(20000);
    auto a = make_embree(views, AccelOptions{}, InstanceSet{protos, few});
    auto b = make_embree(views, AccelOptions{}, InstanceSet{protos, many});
    const double per_instance = double(b->info().bytes - a->info().bytes) / double(many.size() - few.size());
    std::printf("[bytes] %llu and %llu bytes for %zu and %zu instances: %.0f bytes per instance\n",
                (unsigned long long)a->info().bytes, (unsigned long long)b->info().bytes, few.size(), many.size(),
                per_instance);
    EXPECT_GT(b->info().bytes, a->info().bytes);
    EXPECT_GT(per_instance, 40.0) << "at least the instance BVH";
#if defined(__GLIBC__)
    EXPECT_GT(per_instance, 200.0) << "the instance objects (about 290 bytes each on Embree 3.13) are counted";
#endif
    EXPECT_EQ(b->info().instances, many.size());
    EXPECT_EQ(b->info().instanced_primitives, 12u * many.size());
}
