#include "renderer/raysets.h"

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>

#include <fmt/format.h>

#include "renderer/rng.h"
#include "renderer/sampling.h"

namespace renderer {

const char* ray_kind_name(RayKind k) {
    switch (k) {
        case RayKind::Camera: return "camera";
        case RayKind::Random: return "random";
        case RayKind::EdgeVertex: return "edge-vertex";
        case RayKind::Grazing: return "grazing";
        case RayKind::Shadow: return "shadow";
        case RayKind::Diffuse: return "diffuse";
        case RayKind::RenderClosest: return "render-closest";
        case RayKind::RenderShadow: return "render-shadow";
    }
    return "?";
}

bool parse_ray_kind(const std::string& name, RayKind& kind) {
    for (const auto& kinds : {std::span<const RayKind>(kAllRayKinds), std::span<const RayKind>(kRecordedRayKinds)})
        for (RayKind k : kinds)
            if (name == ray_kind_name(k)) {
                kind = k;
                return true;
            }
    return false;
}

namespace {

/// A random triangle of the scene, chosen uniformly by index over the triangles it
/// places: world-space meshes, then each instance's prototype meshes (in world space
/// through its transform; prototype meshes themselves are in object space and never
/// picked as they are). A flat scene's slots are its meshes in order, as before instances.
struct TrianglePicker {
    const scenes::Scene& scene;
    struct Slot {
        uint32_t mesh, inst;  ///< inst: accel::kInvalidId for a world-space mesh
    };
    std::vector<Slot> slots;
    std::vector<uint64_t> offsets;  // prefix sums of triangle counts, one per slot
    explicit TrianglePicker(const scenes::Scene& s) : scene(s) {
        uint64_t n = 0;
        auto add = [&](uint32_t mesh, uint32_t inst) {
            slots.push_back({mesh, inst});
            offsets.push_back(n);
            n += s.meshes[mesh].num_triangles();
        };
        const std::vector<int32_t> owner = s.mesh_prototypes();
        for (uint32_t m = 0; m < s.meshes.size(); ++m)
            if (owner[m] < 0) add(m, accel::kInvalidId);
        for (uint32_t i = 0; i < s.instances.size(); ++i) {
            const scenes::Prototype& p = s.prototypes[s.instances[i].prototype];
            for (uint32_t k = 0; k < p.num_meshes; ++k) add(p.first_mesh + k, i);
        }
        offsets.push_back(n);
    }
    uint64_t total() const { return offsets.back(); }
    void pick(Rng& rng, Vec3f v[3]) const {
        uint64_t i = uint64_t(double(rng.next_u32()) / 4294967296.0 * double(total()));
        size_t m = size_t(std::upper_bound(offsets.begin(), offsets.end(), i) - offsets.begin()) - 1;
        const scenes::Mesh& mesh = scene.meshes[slots[m].mesh];
        const uint32_t* idx = &mesh.indices[3 * (i - offsets[m])];
        for (int k = 0; k < 3; ++k) v[k] = mesh.positions[idx[k]];
        if (slots[m].inst != accel::kInvalidId)
            for (int k = 0; k < 3; ++k) v[k] = scene.instances[slots[m].inst].object_to_world.point(v[k]);
    }
};

/// Surface points seen by random rays, for shadow and bounce rays.
struct SurfacePoint {
    Vec3f p, n;
};

float scene_scale(const accel::Bounds3f& b) {
    return b.empty() ? 1.0f : std::max(1e-30f, accel::max_component(b.diagonal()));
}

SurfacePoint find_surface(const accel::Accelerator& ref, const accel::Bounds3f& b, Rng& rng,
                          accel::TraceStats& st) {
    const Vec3f c = b.center();
    const float radius = 0.5f * accel::length(b.diagonal()) + 1e-30f;
    for (int attempt = 0; attempt < 64; ++attempt) {
        accel::Ray r;
        r.org = c + uniform_sphere(rng.next_float(), rng.next_float()) * (2.0f * radius);
        Vec3f target = b.lo + b.diagonal() * Vec3f(rng.next_float(), rng.next_float(), rng.next_float());
        r.dir = accel::normalize(target - r.org);
        accel::Hit h;
        if (ref.intersect(r, h, st)) {
            Vec3f n = accel::normalize(h.ng);
            if (accel::dot(n, r.dir) > 0) n = -n;  // the side the ray came from
            return {r.org + r.dir * h.t, n};
        }
    }
    return {c, Vec3f(0, 0, 1)};
}

}  // namespace

RaySet make_ray_set(RayKind kind, const scenes::Scene& scene, const accel::Accelerator& reference,
                    const RaySetOptions& o) {
    RaySet set;
    set.kind = kind;
    if (kind == RayKind::RenderClosest || kind == RayKind::RenderShadow) {
        if (!o.record)
            throw std::invalid_argument(fmt::format("{} rays come from a ray record (pathtracer --record-rays)",
                                                    ray_kind_name(kind)));
        const std::vector<accel::Ray>& rays = kind == RayKind::RenderClosest ? o.record->closest : o.record->any_hit;
        set.rays.assign(rays.begin(), rays.begin() + std::ptrdiff_t(std::min(o.count, rays.size())));
        return set;
    }
    Rng rng(o.seed, 0x5EED0000ull + uint64_t(kind));
    const accel::Bounds3f b = reference.bounds();
    const float scale = scene_scale(b);
    const float eps = 1e-4f * scale;
    const Vec3f center = b.empty() ? Vec3f(0.0f) : b.center();
    const float radius = b.empty() ? 1.0f : 0.5f * accel::length(b.diagonal());
    accel::TraceStats st;
    TrianglePicker tris(scene);
    set.rays.reserve(o.count);

    auto push = [&](Vec3f org, Vec3f dir, float tmin = 0.0f, float tmax = accel::kInfinity) {
        accel::Ray r;
        r.org = org;
        r.dir = dir;
        r.t_min = tmin;
        r.t_max = tmax;
        set.rays.push_back(r);
    };

    switch (kind) {
        case RayKind::Camera: {
            int h = std::max(1, int(std::lround(std::sqrt(double(o.count) * 3.0 / 4.0))));
            int w = std::max(1, int(o.count / size_t(h)));
            CameraSetup cam = make_camera(scene, CameraMode::Auto, w, h);
            for (int y = 0; y < h; ++y)
                for (int x = 0; x < w; ++x) {
                    accel::Ray r = cam.camera.generate_ray((x + 0.5f) / w, (y + 0.5f) / h);
                    set.rays.push_back(r);
                }
            break;
        }
        case RayKind::Random:
            // Origins anywhere in (slightly grown) bounds, directions uniform.
            for (size_t i = 0; i < o.count; ++i) {
                Vec3f org = b.lo - b.diagonal() * 0.05f +
                            b.diagonal() * 1.1f * Vec3f(rng.next_float(), rng.next_float(), rng.next_float());
                push(org, uniform_sphere(rng.next_float(), rng.next_float()));
            }
            break;
        case RayKind::EdgeVertex:
            // Aimed exactly at a vertex or at a point of an edge of a random triangle,
            // from outside the bounds: where rays slip between triangles.
            if (tris.total() == 0) break;
            for (size_t i = 0; i < o.count; ++i) {
                Vec3f v[3];
                tris.pick(rng, v);
                int e = int(rng.next_u32() % 3);
                Vec3f target = (rng.next_u32() & 1)
                                   ? v[e]
                                   : v[e] + (v[(e + 1) % 3] - v[e]) * rng.next_float();
                Vec3f org = center + uniform_sphere(rng.next_float(), rng.next_float()) * (1.5f * radius);
                push(org, target - org);  // unnormalised: t = 1 at the target
            }
            break;
        case RayKind::Grazing:
            // Nearly parallel to a random triangle's plane, passing through its interior.
            if (tris.total() == 0) break;
            for (size_t i = 0; i < o.count; ++i) {
                Vec3f v[3];
                tris.pick(rng, v);
                Vec3f n = accel::cross(v[1] - v[0], v[2] - v[0]);
                float ln = accel::length(n);
                if (!(ln > 0)) continue;
                n = n / ln;
                float a = rng.next_float(), c = rng.next_float();
                if (a + c > 1) { a = 1 - a; c = 1 - c; }
                Vec3f p = v[0] + (v[1] - v[0]) * a + (v[2] - v[0]) * c;
                Vec3f t, bt;
                onb(n, t, bt);
                float phi = 2.0f * accel::kPi * rng.next_float();
                float tilt = std::pow(10.0f, -1.0f - 5.0f * rng.next_float());  // 1e-1 .. 1e-6
                Vec3f dir = accel::normalize(t * std::cos(phi) + bt * std::sin(phi) +
                                             n * (tilt * ((rng.next_u32() & 1) ? 1.0f : -1.0f)));
                push(p - dir * (1.2f * radius), dir);
            }
            break;
        case RayKind::Shadow:
            // Segments between two surface points, stopping short of both ends.
            for (size_t i = 0; i < o.count; ++i) {
                SurfacePoint p = find_surface(reference, b, rng, st), q = find_surface(reference, b, rng, st);
                Vec3f org = p.p + p.n * eps;
                Vec3f dir = (q.p + q.n * eps) - org;
                push(org, dir, 0.0f, 1.0f - 1e-4f);
            }
            break;
        case RayKind::Diffuse:
            // Cosine-distributed bounces leaving surface points.
            for (size_t i = 0; i < o.count; ++i) {
                SurfacePoint p = find_surface(reference, b, rng, st);
                Vec3f d = to_world(cosine_hemisphere(rng.next_float(), rng.next_float()), p.n);
                push(p.p + p.n * eps, d);
            }
            break;
        case RayKind::RenderClosest:
        case RayKind::RenderShadow: break;  // read from the record above
    }
    return set;
}

}  // namespace renderer
