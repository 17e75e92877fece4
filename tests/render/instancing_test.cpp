// The renderer traces instances (scenes::Scene::prototypes/instances) as it renders their
// flattened copies (scenes::flatten_instances): surface quantities at a hit, light
// sampling of instanced emitters, alpha masks and blending through instances, and the
// flat path left exactly as it was.
//
// Every test runs on each backend of accel::available_backends() (every one traces
// instances). Renders are compared by region means within their standard errors, never
// pixel by pixel.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>

#include "accel/accelerator.h"
#include "renderer/interaction.h"
#include "renderer/scene_geometry.h"
#include "tests/render/render_world.h"

using namespace renderer;
using accel::Affine3f;

namespace {

constexpr float kPi = 3.14159265f;

/// Object to world: rotation by `deg` about `axis` (Rodrigues), after a scale, then a
/// translation: p' = R S p + t.
Affine3f placement(Vec3f axis, float deg, Vec3f scale, Vec3f t) {
    axis = accel::normalize(axis);
    const float a = deg * kPi / 180.0f, c = std::cos(a), s = std::sin(a), k = 1.0f - c;
    const float x = axis.x, y = axis.y, z = axis.z;
    const float r[3][3] = {{c + x * x * k, x * y * k - z * s, x * z * k + y * s},
                           {y * x * k + z * s, c + y * y * k, y * z * k - x * s},
                           {z * x * k - y * s, z * y * k + x * s, c + z * z * k}};
    Affine3f m;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) m.m[i][j] = r[i][j] * scale[j];
        m.m[i][3] = t[i];
    }
    return m;
}

/// An icosphere of radius 1 (the icosahedron subdivided once, 80 triangles) with smooth
/// shading normals (the unit positions) and spherical uvs: curved shading that a wrong
/// normal transform would show.
scenes::Mesh icosphere(uint32_t material) {
    const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
    std::vector<Vec3f> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                            {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
    std::vector<uint32_t> f = {0, 11, 5, 0, 5,  1, 0, 1, 7, 0, 7,  10, 0, 10, 11, 1, 5, 9, 5, 11,
                               4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3,
                               6, 8,  3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1};
    for (Vec3f& p : v) p = accel::normalize(p);
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
        const auto key = std::minmax(a, b);
        auto it = mid.find(key);
        if (it != mid.end()) return it->second;
        v.push_back(accel::normalize(v[a] + v[b]));
        return mid[key] = uint32_t(v.size() - 1);
    };
    scenes::Mesh m;
    for (size_t i = 0; i < f.size(); i += 3) {
        const uint32_t a = f[i], b = f[i + 1], c = f[i + 2];
        const uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
        m.indices.insert(m.indices.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    m.positions = v;
    m.normals = v;
    for (const Vec3f& p : v) m.uvs.push_back({0.5f + std::atan2(p.z, p.x) / (2 * kPi), 0.5f + std::asin(std::clamp(p.y, -1.0f, 1.0f)) / kPi});
    m.pad_positions();
    m.material = material;
    return m;
}

/// The box every render test shares: floor (material 0), ceiling and back wall (0), a
/// red left (1) and a green right wall (2), over [-2, 2] x [0, 3] x [-2, 2], open at
/// +z where the camera stands.
void add_box(scenes::Scene& s) {
    scenes::Material white, red, green;
    white.albedo = Vec3f(0.7f);
    red.albedo = {0.7f, 0.15f, 0.1f};
    green.albedo = {0.15f, 0.6f, 0.1f};
    s.materials = {white, red, green};
    s.meshes.push_back(quad({-2, 0, 2}, {2, 0, 2}, {2, 0, -2}, {-2, 0, -2}, 0));    // floor, up
    s.meshes.push_back(quad({-2, 3, -2}, {2, 3, -2}, {2, 3, 2}, {-2, 3, 2}, 0));    // ceiling, down
    s.meshes.push_back(quad({-2, 0, -2}, {2, 0, -2}, {2, 3, -2}, {-2, 3, -2}, 0));  // back, +z
    s.meshes.push_back(quad({-2, 0, 2}, {-2, 0, -2}, {-2, 3, -2}, {-2, 3, 2}, 1));  // left, +x
    s.meshes.push_back(quad({2, 0, -2}, {2, 0, 2}, {2, 3, 2}, {2, 3, -2}, 2));      // right, -x
}

Camera box_camera() { return Camera({0, 1.5f, 5.2f}, {0, 1.3f, 0}, {0, 1, 0}, 52.0f, 52.0f); }

RenderResult render_box(World& w, int size, int spp) {
    RenderSettings rs;
    rs.width = rs.height = size;
    rs.spp = spp;
    rs.threads = 2;
    rs.progress = false;
    return render(box_camera(), *w.integrator, *w.accel, rs);
}

/// Appends `m` as a one-mesh prototype and places it by each of `xf`.
void add_prototype(scenes::Scene& s, scenes::Mesh m, const std::vector<Affine3f>& xf) {
    const uint32_t p = uint32_t(s.prototypes.size());
    s.prototypes.push_back({m.name.empty() ? "proto" : m.name, uint32_t(s.meshes.size()), 1});
    s.meshes.push_back(std::move(m));
    for (const Affine3f& x : xf) s.instances.push_back({p, x});
}

/// Three placements: rotated and scaled non-uniformly, twice, and once mirrored.
std::vector<Affine3f> three_placements() {
    return {placement({1, 1, 0}, 30.0f, {0.55f, 0.3f, 0.4f}, {-1.0f, 0.7f, 0.2f}),
            placement({0, 1, 0.3f}, 70.0f, {0.3f, 0.65f, 0.35f}, {0.9f, 0.75f, -0.6f}),
            placement({0, 0, 1}, -25.0f, {-0.45f, 0.35f, 0.3f}, {0.2f, 1.9f, 0.4f})};
}

std::string param_name(const ::testing::TestParamInfo<std::string>& info) { return info.param; }

class Instancing : public ::testing::TestWithParam<std::string> {};

}  // namespace

// The surface at a hit inside an instance is the surface of the flattened copy at the
// same ray: the point within both error bounds (and the bound no smaller than the gap),
// the geometric normal with the same orientation (mirrored placement included: the copy's
// winding was swapped), the shading normal, uv and dp/du. Rays from all around at the
// three placements.
TEST_P(Instancing, HitSurfaceIsTheFlattenedCopys) {
    scenes::Scene inst;
    add_box(inst);
    inst.materials[0].albedo_texture = 0;  // textured: make_interaction computes dp/du
    inst.textures.push_back(scenes::Texture::make("t", 2, 2, scenes::TexelFormat::U8, "RGB"));
    add_prototype(inst, icosphere(0), three_placements());
    scenes::Scene flat = inst;
    scenes::flatten_instances(flat);
    const SceneGeometry gi(inst), gf(flat);
    auto ai = accel::create_accelerator(GetParam(), gi.views(), {}, gi.instances());
    auto af = accel::create_accelerator(GetParam(), gf.views(), {});
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    accel::TraceStats st;
    int compared = 0, mirrored = 0;
    const std::vector<Affine3f> xf = three_placements();
    for (int k = 0; k < 3000; ++k) {
        const Affine3f& target = xf[size_t(k % 3)];
        const Vec3f centre(target.m[0][3], target.m[1][3], target.m[2][3]);
        const Vec3f org = centre + accel::normalize(Vec3f(u(rng), u(rng), u(rng))) * 1.5f;
        const Vec3f aim = centre + Vec3f(u(rng), u(rng), u(rng)) * 0.3f;
        const accel::Ray ray{org, accel::normalize(aim - org)};
        accel::Hit hi, hf;
        const bool bi = ai->intersect(ray, hi, st), bf = af->intersect(ray, hf, st);
        ASSERT_EQ(bi, bf);
        if (!bi || hi.inst_id == accel::kInvalidId) continue;
        // Rays at an edge may find the neighbour triangle in one of the two.
        if (std::min({hi.u, hi.v, 1.0f - hi.u - hi.v}) < 1e-3f) continue;
        ASSERT_EQ(hf.inst_id, accel::kInvalidId);
        ASSERT_EQ(gf.source(hf.geom_id).mesh, 5 + hi.inst_id) << "the copy of the same placement";
        ASSERT_EQ(hi.prim_id, hf.prim_id);
        const Interaction a = make_interaction(inst, gi, ray, hi), b = make_interaction(flat, gf, ray, hf);
        EXPECT_NEAR(a.t, b.t, 1e-4f * b.t);
        // Both points are within their bounds of the surface (not of the ray's exact
        // point: the barycentrics carry the intersection's own error along the surface),
        // so off the surface they are apart by at most the two bounds projected on the
        // normal, plus the rounding of the copy's stored vertices (gamma(3) of the
        // coordinates' magnitudes, below 1e-6 here); along it, by little.
        const Vec3f d = a.p - b.p;
        EXPECT_LE(std::abs(accel::dot(d, a.ng)), accel::dot(accel::vabs(a.ng), a.p_error + b.p_error) + 1e-6f);
        EXPECT_LE(accel::length(d), 1e-4f);
        // A bound, and not a vacuous one: a few ulps of the coordinates at most.
        for (int c = 0; c < 3; ++c) EXPECT_LE(a.p_error[c], 1e-5f) << "axis " << c;
        EXPECT_GT(accel::dot(a.ng, b.ng), 0.9999f) << "instance " << hi.inst_id;
        EXPECT_GT(accel::dot(a.ns, b.ns), 0.9999f) << "instance " << hi.inst_id;
        EXPECT_NEAR(a.uv.x, b.uv.x, 1e-5f);
        EXPECT_NEAR(a.uv.y, b.uv.y, 1e-5f);
        EXPECT_LE(accel::length(a.dpdu - b.dpdu), 1e-3f * accel::length(b.dpdu));
        EXPECT_LE(accel::length(a.dpdv - b.dpdv), 1e-3f * accel::length(b.dpdv));
        EXPECT_EQ(a.material, b.material);
        ++compared;
        mirrored += hi.inst_id == 2;
    }
    EXPECT_GT(compared, 1500);
    EXPECT_GT(mirrored, 400);
}

// An icosphere with shading normals, placed three times (rotated, scaled non-uniformly,
// one placement mirrored), in a box lit by a ceiling panel: the render's region means are
// those of the flattened copy.
TEST_P(Instancing, MeshRendersAsItsFlattenedCopy) {
    World inst, flat;
    add_box(inst.scene);
    scenes::Material light;
    light.emission = Vec3f(6.0f);
    inst.scene.materials.push_back(light);
    inst.scene.meshes.push_back(quad({-0.6f, 2.99f, -0.6f}, {0.6f, 2.99f, -0.6f}, {0.6f, 2.99f, 0.6f},
                                     {-0.6f, 2.99f, 0.6f}, 3));
    scenes::Material blue;
    blue.albedo = {0.2f, 0.3f, 0.8f};
    inst.scene.materials.push_back(blue);
    add_prototype(inst.scene, icosphere(4), three_placements());
    flat.scene = inst.scene;
    scenes::flatten_instances(flat.scene);
    IntegratorSettings is;
    is.max_depth = 3;
    inst.build(is, GetParam());
    flat.build(is, GetParam());
    ASSERT_EQ(inst.accel->info().instances, 3u);
    const RenderResult ri = render_box(inst, 48, 48), rf = render_box(flat, 48, 48);
    expect_same_regions(ri.image, rf.image, 6, 4.0, GetParam() + " instanced vs flattened");
}

// An emissive quad placed three times at different scales (one mirrored, one tilted)
// under the ceiling is one light of three placements, not three copies; it lights the box
// (light sampling at the diffuse walls, MIS of light and BSDF samples at a glossy
// floor, which finds the light of a placement a BSDF ray hits) and is seen by the camera
// as its flattened copies are. One-sided emission: a mirrored placement emits down as its
// copy does.
TEST_P(Instancing, EmissiveInstancesLightAsFlattenedCopies) {
    World inst, flat;
    add_box(inst.scene);
    scenes::Material glossy;  // the floor: a rough conductor (3)
    glossy.bsdf = scenes::BsdfKind::Microfacet;
    glossy.alpha = 0.25f;
    inst.scene.materials.push_back(glossy);
    inst.scene.meshes[0].material = 3;
    scenes::Material light;
    light.emission = Vec3f(5.0f);
    light.double_sided = false;
    inst.scene.materials.push_back(light);  // 4
    // A unit quad facing down (-y) in object space.
    add_prototype(inst.scene,
                  quad({-0.5f, 0, 0.5f}, {0.5f, 0, 0.5f}, {0.5f, 0, -0.5f}, {-0.5f, 0, -0.5f}, 4),
                  {placement({0, 1, 0}, 0.0f, {0.8f, 1.0f, 0.5f}, {-1.1f, 2.97f, 0.0f}),
                   placement({0, 1, 0}, 20.0f, {-0.4f, 1.0f, 0.9f}, {0.9f, 2.97f, -0.6f}),
                   placement({1, 0, 0}, 15.0f, {0.3f, 1.0f, 0.3f}, {0.6f, 2.6f, 1.0f})});
    flat.scene = inst.scene;
    scenes::flatten_instances(flat.scene);
    IntegratorSettings is;
    is.max_depth = 2;
    inst.build(is, GetParam());
    flat.build(is, GetParam());
    EXPECT_EQ(inst.lights->size(), 1u) << "one light for the three placements";
    EXPECT_EQ(flat.lights->size(), 3u);
    EXPECT_GE(inst.lights->light_of_mesh(5, 1), 0);
    EXPECT_LT(inst.lights->light_of_mesh(5), 0) << "the prototype mesh is no world-space light";
    const RenderResult ri = render_box(inst, 48, 64), rf = render_box(flat, 48, 64);
    // Light sampling of one light of three placements against three lights: different
    // estimators of one image, glossy MIS included (heavier tails: 2 % of the mean).
    expect_same_regions(ri.image, rf.image, 6, 4.0, GetParam() + " instanced vs flattened", 0.02);
}

// Light sampling of an instanced emitter: the density sample() reports is the one pdf()
// gives for the placement and triangle the point lies on, near (solid angle) and far
// (area); the placement a sample lands on is picked by world-space area.
TEST(InstancedLights, SampleAndPdfAgree) {
    scenes::Scene s;
    scenes::Material light;
    light.emission = Vec3f(1.0f);
    s.materials = {light};
    scenes::Mesh q = quad({-0.5f, 0, 0.5f}, {0.5f, 0, 0.5f}, {0.5f, 0, -0.5f}, {-0.2f, 0, -0.5f}, 0);
    const std::vector<Affine3f> xf = {placement({0, 1, 0}, 0.0f, {1.0f, 1.0f, 1.0f}, {0, 1, 0}),
                                      placement({1, 0, 0}, 30.0f, {-2.0f, 1.0f, 0.5f}, {2, 1, 0}),
                                      placement({0, 0, 1}, 60.0f, {0.5f, 3.0f, 3.0f}, {-2, 1, 1})};
    add_prototype(s, q, xf);
    std::vector<std::string> notes;
    const LightSet lights(s, LightModel::Mesh, notes);
    ASSERT_EQ(lights.size(), 1u);
    const scenes::Mesh& m = s.meshes[0];
    // World areas of the placements, and how often each is drawn.
    std::vector<double> area(xf.size(), 0.0), drawn(xf.size(), 0.0);
    for (uint32_t i = 0; i < xf.size(); ++i)
        for (uint32_t t = 0; t < m.num_triangles(); ++t) {
            Vec3f v[3];
            for (int c = 0; c < 3; ++c) v[c] = xf[i].point(m.positions[m.indices[3 * t + c]]);
            area[i] += 0.5 * accel::length(accel::cross(v[1] - v[0], v[2] - v[0]));
        }
    Rng rng(5, 0);
    int total = 0;
    for (const Vec3f p : {Vec3f(0.1f, 0.9f, 0.05f), Vec3f(2.0f, 0.8f, 0.1f), Vec3f(0, -5, 0), Vec3f(-1.5f, 0.7f, 1)}) {
        const Vec3f n = accel::normalize(Vec3f(0.1f, 1.0f, 0.0f));
        for (int k = 0; k < 600; ++k) {
            LightSample ls;
            if (!lights.sample(0, p, n, rng, ls)) continue;
            // Which placement and triangle the point lies on.
            int found_i = -1;
            uint32_t found_t = 0;
            for (uint32_t i = 0; i < xf.size(); ++i)
                for (uint32_t t = 0; t < m.num_triangles(); ++t) {
                    Vec3f v[3];
                    for (int c = 0; c < 3; ++c) v[c] = xf[i].point(m.positions[m.indices[3 * t + c]]);
                    const float full = accel::length(accel::cross(v[1] - v[0], v[2] - v[0]));
                    const float parts = accel::length(accel::cross(v[1] - ls.target, v[2] - ls.target)) +
                                        accel::length(accel::cross(v[2] - ls.target, v[0] - ls.target)) +
                                        accel::length(accel::cross(v[0] - ls.target, v[1] - ls.target));
                    if (parts <= full * (1 + 1e-4f)) found_i = int(i), found_t = t;
                }
            ASSERT_GE(found_i, 0) << "the sample lies on a placed triangle";
            drawn[size_t(found_i)] += 1;
            ++total;
            const float pdf = lights.pdf(0, p, n, ls.wi, ls.distance, ls.normal, found_t, uint32_t(found_i));
            EXPECT_NEAR(pdf, ls.pdf, 2e-3f * ls.pdf) << "point " << p.x << " " << p.y << " " << p.z;
            EXPECT_EQ(lights.pdf(0, p, n, ls.wi, ls.distance, ls.normal, found_t, 7u), 0.0f)
                << "no such placement";
        }
    }
    EXPECT_GT(total, 2000);
    // The draw frequencies follow the world areas (within 5 standard errors).
    const double sum = area[0] + area[1] + area[2];
    for (size_t i = 0; i < xf.size(); ++i) {
        const double pi = area[i] / sum, se = std::sqrt(pi * (1 - pi) / total);
        EXPECT_NEAR(drawn[i] / total, pi, 5 * se + 1e-3) << "placement " << i;
    }
}

// A quad with a checkerboard alpha mask, placed by an instance (mirrored in x, scaled up)
// above a floor under a straight-down sun, casts the checkered shadow its flattened copy
// casts: every floor region is either black or fully lit, and as the copy's.
TEST_P(Instancing, CheckeredAlphaShadowThroughAnInstance) {
    constexpr int kTexels = 4;
    World inst, flat;
    scenes::Scene& s = inst.scene;
    scenes::Material floor;
    floor.albedo = Vec3f(0.5f);
    scenes::Material leaf;
    leaf.albedo = Vec3f(0.7f);
    leaf.alpha_mode = scenes::AlphaMode::Mask;
    leaf.albedo_texture = 0;
    s.materials = {floor, leaf};
    scenes::Texture t = scenes::Texture::make("checker", kTexels, kTexels, scenes::TexelFormat::U8, "RGBA");
    for (int y = 0; y < kTexels; ++y)
        for (int x = 0; x < kTexels; ++x) {
            uint8_t* p = t.data.data() + (size_t(y) * kTexels + x) * 4;
            p[0] = p[1] = p[2] = 200;
            p[3] = (x + y) % 2 ? 255 : 0;
        }
    s.textures.push_back(t);
    s.meshes.push_back(quad({-3, 0, 3}, {3, 0, 3}, {3, 0, -3}, {-3, 0, -3}, 0));
    scenes::Mesh q = quad({-0.5f, 0, -0.5f}, {0.5f, 0, -0.5f}, {0.5f, 0, 0.5f}, {-0.5f, 0, 0.5f}, 1);
    q.uvs = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
    // Mirrored in x and twice as large: covers [-1, 1]^2 at height 1, the checker flipped.
    add_prototype(s, q, {placement({0, 1, 0}, 0.0f, {-2.0f, 1.0f, 2.0f}, {0, 1, 0})});
    scenes::Light sun;
    sun.type = scenes::LightType::Directional;
    sun.direction = {0, -1, 0};
    s.lights.push_back(sun);
    flat.scene = s;
    scenes::flatten_instances(flat.scene);
    IntegratorSettings is;
    is.max_depth = 1;
    is.texture_filter = TextureFilter::Bilinear;
    inst.build(is, GetParam());
    flat.build(is, GetParam());
    ASSERT_TRUE(inst.geometry->views()[1].masked());
    // A camera between quad and floor, seeing the floor's [-1, 1]^2 (as alpha_test.cpp).
    const float fov = 2.0f * std::atan(2.0f) * 180.0f / kPi;
    const Camera cam({0, 0.5f, 0}, {0, 0, 0}, {0, 0, -1}, fov, fov);
    RenderSettings rs;
    rs.width = rs.height = 32;
    rs.spp = 8;
    rs.threads = 2;
    rs.progress = false;
    const RenderResult ri = render(cam, *inst.integrator, *inst.accel, rs);
    const RenderResult rf = render(cam, *flat.integrator, *flat.accel, rs);
    const auto a = region_means(ri.image, kTexels), b = region_means(rf.image, kTexels);
    const double lit = 0.5 / kPi;
    int dark = 0;
    for (size_t k = 0; k < a.size(); ++k) {
        EXPECT_NEAR(a[k].mean, b[k].mean, 1e-4) << GetParam() << " region " << k;
        EXPECT_TRUE(a[k].mean < 1e-6 || std::abs(a[k].mean - lit) < 0.01 * lit)
            << GetParam() << " region " << k << ": " << a[k].mean;
        dark += a[k].mean < 1e-6;
    }
    EXPECT_EQ(dark, kTexels * kTexels / 2) << "a checker";
}

// Two placements of one BLEND leaf (alpha 0.5) on one shadow ray decide independently:
// 3/4 of the rays are stopped, not the 1/2 that one shared decision would give (the
// instance is hashed into blend_uniform).
TEST_P(Instancing, BlendedPlacementsDecideApart) {
    scenes::Scene s;
    scenes::Material leaf;
    leaf.alpha_mode = scenes::AlphaMode::Blend;
    leaf.base_alpha = 0.5f;
    s.materials = {leaf};
    add_prototype(s, quad({-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}, 0),
                  {placement({0, 1, 0}, 0.0f, {1, 1, 1}, {0, 1, 0}), placement({0, 1, 0}, 0.0f, {1, 1, 1}, {0, 2, 0})});
    const SceneGeometry g(s);
    ASSERT_TRUE(g.views()[0].masked());
    auto acc = accel::create_accelerator(GetParam(), g.views(), {}, g.instances());
    constexpr int kRays = 20000;
    const double se = std::sqrt(0.75 * 0.25 / kRays);
    EXPECT_NEAR(fraction_blocked_upward(*acc, kRays), 0.75, 5 * se) << GetParam();
}

// The flat path is untouched: the Cornell box renders bit-identically whether the scene
// also holds a prototype that nothing places (so a non-empty InstanceSet reaches the
// backend, and the light set and geometry see a prototype) or not, and through
// build_accelerator as through create_accelerator without an InstanceSet (the call
// before instancing).
TEST_P(Instancing, FlatSceneRendersBitIdentically) {
    const std::string backend = GetParam();
    IntegratorSettings is;
    is.max_depth = 3;
    auto render_cornell = [&](World& w) {
        CameraOverrides ov;
        ov.hfov_deg = make_camera(w.scene, CameraMode::Auto, 480, 360).camera.hfov_deg();
        const Camera cam = make_camera(w.scene, CameraMode::Auto, 40, 30, ov).camera;
        RenderSettings rs;
        rs.width = 40;
        rs.height = 30;
        rs.spp = 4;
        rs.threads = 2;
        rs.seed = 3;
        rs.progress = false;
        return render(cam, *w.integrator, *w.accel, rs);
    };
    const std::string path = std::string(PT_SOURCE_DIR) + "/scenes/cornell.dae";
    World plain, direct, unplaced;
    plain.scene = direct.scene = unplaced.scene = scenes::load_scene(path);
    ASSERT_TRUE(plain.scene.instances.empty());
    plain.build(is, backend);
    // The call as it was before instancing: views only.
    direct.geometry = std::make_unique<SceneGeometry>(direct.scene);
    direct.accel = accel::create_accelerator(backend, direct.geometry->views(), {});
    direct.lights = std::make_unique<LightSet>(direct.scene, direct.model, direct.notes);
    direct.integrator = std::make_unique<PathIntegrator>(direct.scene, *direct.geometry, *direct.lights, is);
    const RenderResult a = render_cornell(plain), b = render_cornell(direct);
    auto same = [](const Image& x, const Image& y) {
        if (x.pixels.size() != y.pixels.size()) return false;
        for (size_t i = 0; i < x.pixels.size(); i += x.nchannels())
            for (int c : {kR, kG, kB, kVariance})
                if (std::memcmp(&x.pixels[i + c], &y.pixels[i + c], sizeof(float)) != 0) return false;
        return true;
    };
    EXPECT_TRUE(same(a.image, b.image)) << backend;
    // A prototype placed nowhere (an emissive one, which must not become a light).
    scenes::Mesh extra = icosphere(0);
    scenes::Material glow;
    glow.emission = Vec3f(10.0f);
    unplaced.scene.materials.push_back(glow);
    extra.material = uint32_t(unplaced.scene.materials.size() - 1);
    add_prototype(unplaced.scene, extra, {});
    unplaced.build(is, backend);
    EXPECT_EQ(unplaced.lights->size(), plain.lights->size());
    const RenderResult c = render_cornell(unplaced);
    EXPECT_TRUE(same(a.image, c.image)) << backend;
}

INSTANTIATE_TEST_SUITE_P(Backends, Instancing, ::testing::ValuesIn(accel::available_backends()), param_name);
