// The custom two-level BVH (accel/bvh/instanced.h) against the naive backend: the same
// instances traced by both must give the same hits bit for bit (both carry the ray into
// object space with the same operations and test triangles with the same arithmetic),
// and against naive on the flattened copy within the rounding of the transform.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "accel/accelerator.h"
#include "accel/bvh/bvh.h"
#include "accel/bvh/instanced.h"
#include "accel/primitive.h"

namespace {

using namespace accel;

/// A closed mesh: an octahedron subdivided `levels` times, pushed onto the unit sphere.
struct Mesh {
    std::vector<Vec3f> pos;  // padded by one
    std::vector<uint32_t> idx;
};
Mesh sphere_mesh(int levels) {
    Mesh m;
    m.pos = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
    m.idx = {0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5};
    for (int l = 0; l < levels; ++l) {
        std::vector<uint32_t> out;
        for (size_t t = 0; t < m.idx.size(); t += 3) {
            uint32_t a = m.idx[t], b = m.idx[t + 1], c = m.idx[t + 2];
            auto mid = [&](uint32_t i, uint32_t j) {
                m.pos.push_back(normalize((m.pos[i] + m.pos[j]) * 0.5f));
                return uint32_t(m.pos.size() - 1);
            };
            uint32_t ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
            out.insert(out.end(), {a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca});
        }
        m.idx = out;
    }
    m.pos.push_back({0, 0, 0});
    return m;
}
Mesh quad_mesh(float s) {
    Mesh m;
    m.pos = {{-s, 0, -s}, {s, 0, -s}, {s, 0, s}, {-s, 0, s}, {0, 0, 0}};
    m.idx = {0, 1, 2, 0, 2, 3};
    return m;
}

Affine3f random_transform(std::mt19937& rng, float spread, bool wild) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), s(0.3f, 2.0f);
    Mat4f r = Mat4f::rotate({u(rng), u(rng), u(rng) + 0.01f}, 180.0f * u(rng));
    Vec3f sc{s(rng), s(rng), s(rng)};
    if (wild && u(rng) < -0.5f) sc.x = -sc.x;  // a mirror
    Mat4f m = Mat4f::translate({spread * u(rng), spread * u(rng), spread * u(rng)}) * r * Mat4f::scale(sc);
    return Affine3f::from(m);
}

struct World {
    std::vector<Mesh> meshes;
    std::vector<GeometryView> views;
    std::vector<PrototypeView> protos;
    std::vector<InstanceView> inst;
    // Flattened copy: one view per (instance, prototype geometry), plus the world ones.
    std::vector<Mesh> flat_meshes;
    std::vector<GeometryView> flat_views;
    std::vector<std::pair<uint32_t, uint32_t>> flat_source;  // flat geom -> (inst, geom)
    InstanceSet set() const { return {protos, inst}; }

    void finalize() {
        for (const Mesh& m : meshes)
            views.push_back(GeometryView::triangles(m.pos.data(), uint32_t(m.pos.size() - 1), m.idx.data(),
                                                    uint32_t(m.idx.size() / 3)));
        std::vector<int> owner(meshes.size(), -1);
        for (size_t p = 0; p < protos.size(); ++p)
            for (uint32_t g = 0; g < protos[p].num_geoms; ++g) owner[protos[p].first_geom + g] = int(p);
        for (size_t g = 0; g < meshes.size(); ++g)
            if (owner[g] < 0) flat_meshes.push_back(meshes[g]), flat_source.push_back({kInvalidId, uint32_t(g)});
        for (uint32_t i = 0; i < inst.size(); ++i) {
            const PrototypeView& p = protos[inst[i].prototype];
            for (uint32_t g = p.first_geom; g < p.first_geom + p.num_geoms; ++g) {
                Mesh c = meshes[g];
                for (size_t v = 0; v + 1 < c.pos.size(); ++v) c.pos[v] = inst[i].object_to_world.point(c.pos[v]);
                flat_meshes.push_back(c);
                flat_source.push_back({i, g});
            }
        }
        for (const Mesh& m : flat_meshes)
            flat_views.push_back(GeometryView::triangles(m.pos.data(), uint32_t(m.pos.size() - 1), m.idx.data(),
                                                         uint32_t(m.idx.size() / 3)));
    }
};

/// Prototype 0: a sphere; prototype 1: a sphere and a quad; world: a big quad.
World make_world(int count, float spread, bool wild, uint32_t seed) {
    World w;
    w.meshes = {quad_mesh(50.0f), sphere_mesh(2), sphere_mesh(1), quad_mesh(1.0f)};
    w.protos = {{1, 1}, {2, 2}};
    std::mt19937 rng(seed);
    for (int i = 0; i < count; ++i) w.inst.push_back({uint32_t(i % 2), random_transform(rng, spread, wild)});
    w.finalize();
    return w;
}

std::vector<Ray> random_rays(std::mt19937& rng, int n, float spread) {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    std::vector<Ray> rays;
    for (int i = 0; i < n; ++i) {
        Ray r;
        r.org = {spread * 1.5f * u(rng), spread * 1.5f * u(rng), spread * 1.5f * u(rng)};
        // Half aim at a point of the scene, half anywhere.
        Vec3f target{spread * u(rng), spread * u(rng), spread * u(rng)};
        r.dir = i % 2 ? target - r.org : Vec3f{u(rng), u(rng), u(rng)};
        if (i % 7 == 0) r.t_max = 0.5f;
        rays.push_back(r);
    }
    return rays;
}

AccelOptions opts(TriangleTest t, Isa isa, NodeLayout layout) {
    AccelOptions o;
    o.triangle = t;
    o.isa = isa;
    o.nodes = layout;
    return o;
}

TEST(InstanceBvh, MatchesNaiveInstancedBitForBit) {
    const World w = make_world(300, 20.0f, true, 7);
    std::mt19937 rng(11);
    const std::vector<Ray> rays = random_rays(rng, 6000, 20.0f);
    for (TriangleTest t : {TriangleTest::Fast, TriangleTest::Watertight}) {
        auto naive = create_accelerator("naive", w.views, opts(t, Isa::Auto, NodeLayout::Auto), w.set());
        std::vector<Hit> ref(rays.size());
        std::vector<uint8_t> ref_hit(rays.size()), ref_occ(rays.size());
        TraceStats st;
        for (size_t i = 0; i < rays.size(); ++i) {
            ref_hit[i] = naive->intersect(rays[i], ref[i], st);
            ref_occ[i] = naive->occluded(rays[i], st);
        }
        for (Isa isa : supported_isas())
            for (NodeLayout layout : {NodeLayout::Float, NodeLayout::Quantized}) {
                auto bvh = create_accelerator("custom", w.views, opts(t, isa, layout), w.set());
                EXPECT_EQ(bvh->info().instances, 300u);
                EXPECT_NE(bvh->info().backend.find("two-level"), std::string::npos);
                int bad = 0, hits = 0;
                for (size_t i = 0; i < rays.size(); ++i) {
                    Hit h;
                    TraceStats s;
                    const bool hit = bvh->intersect(rays[i], h, s);
                    hits += hit;
                    const bool same = hit == bool(ref_hit[i]) &&
                                      (!hit || (h.t == ref[i].t && h.u == ref[i].u && h.v == ref[i].v &&
                                                h.geom_id == ref[i].geom_id && h.prim_id == ref[i].prim_id &&
                                                h.inst_id == ref[i].inst_id && h.ng.x == ref[i].ng.x &&
                                                h.ng.y == ref[i].ng.y && h.ng.z == ref[i].ng.z));
                    // Exact ties between two triangles at one t may resolve either way.
                    if (!same && !(hit && ref_hit[i] && h.t == ref[i].t)) ++bad;
                    if (bvh->occluded(rays[i], s) != bool(ref_occ[i])) ++bad;
                }
                EXPECT_GT(hits, 600);
                EXPECT_EQ(bad, 0) << isa_name(isa) << " " << layout_name(layout) << " "
                                  << (t == TriangleTest::Fast ? "fast" : "watertight");
            }
    }
}

TEST(InstanceBvh, AgreesWithFlattenedCopyWithinTransformRounding) {
    const World w = make_world(500, 30.0f, true, 3);
    std::mt19937 rng(5);
    const std::vector<Ray> rays = random_rays(rng, 20000, 30.0f);
    // The flat custom BVH stands in for naive on the copy (it agrees with naive bit for
    // bit: bvh_test), at a fraction of the time.
    auto flat = create_accelerator("custom", w.flat_views, AccelOptions{});
    auto bvh = create_accelerator("custom", w.views, AccelOptions{}, w.set());
    int disagree = 0, hits = 0;
    for (const Ray& r : rays) {
        Hit a, b;
        TraceStats s;
        const bool ha = bvh->intersect(r, a, s), hb = flat->intersect(r, b, s);
        hits += ha;
        if (ha != hb) {
            ++disagree;
            continue;
        }
        if (!ha) continue;
        // The object-space ray carries the transform's rounding (a few ulps of the
        // origin's and direction's magnitudes through |W|), so t agrees to a relative
        // 1e-4 here; an exact-ish tie between two surfaces may pick either.
        const auto [inst, geom] = w.flat_source[b.geom_id];
        const bool same_surface = a.inst_id == inst && a.geom_id == geom && a.prim_id == b.prim_id;
        if (std::fabs(a.t - b.t) > 1e-4f * std::max(1.0f, b.t)) {
            ++disagree;
            continue;
        }
        if (same_surface) {
            const Vec3f na = normalize(a.ng), nb = normalize(b.ng);
            EXPECT_GT(dot(na, nb), 0.999f);  // same direction, same orientation
        }
    }
    EXPECT_GT(hits, 2000);
    // Grazing rays along an edge of a transformed triangle may hit in one and miss in the
    // other: a handful in 20000.
    EXPECT_LE(disagree, 20);
}

TEST(InstanceBvh, MaskedPrototypeFilterSeesWorldRayAndInstance) {
    World w = make_world(50, 10.0f, false, 9);
    struct Log {
        const Ray* expect = nullptr;
        bool world_ray_ok = true;
    } log;
    // Drops every hit on odd instances: a pure function of (prim, inst).
    const HitFilter drop_odd = [](const void* user, uint32_t, uint32_t, uint32_t inst, float, float, const Ray& ray) {
        auto* l = const_cast<Log*>(static_cast<const Log*>(user));
        if (l->expect && std::memcmp(l->expect, &ray, sizeof(Ray)) != 0) l->world_ray_ok = false;
        return inst == kInvalidId || inst % 2 == 0;
    };
    for (uint32_t g : {1u, 2u, 3u}) w.views[g].filter = drop_odd, w.views[g].filter_user = &log;
    std::mt19937 rng(2);
    const std::vector<Ray> rays = random_rays(rng, 5000, 10.0f);
    auto naive = create_accelerator("naive", w.views, AccelOptions{}, w.set());
    auto bvh = create_accelerator("custom", w.views, AccelOptions{}, w.set());
    EXPECT_NE(bvh->info().backend.find("masked"), std::string::npos);
    int bad = 0, hits = 0;
    for (const Ray& r : rays) {
        log.expect = &r;
        Hit a, b;
        TraceStats s;
        const bool ha = bvh->intersect(r, a, s), hb = naive->intersect(r, b, s);
        hits += ha && a.inst_id != kInvalidId;
        if (ha != hb || (ha && (a.t != b.t || a.inst_id != b.inst_id))) ++bad;
        if (ha && a.inst_id != kInvalidId) {
            EXPECT_EQ(a.inst_id % 2, 0u);
        }
        if (bvh->occluded(r, s) != naive->occluded(r, s)) ++bad;
    }
    EXPECT_TRUE(log.world_ray_ok);
    EXPECT_GT(hits, 100);
    EXPECT_EQ(bad, 0);
}

TEST(InstanceBvh, CountsNodesOfBothLevels) {
    const World w = make_world(200, 20.0f, false, 1);
    auto bvh = create_accelerator("custom", w.views, AccelOptions{}, w.set());
    std::mt19937 rng(3);
    TraceStats s;
    s.counting = true;
    for (const Ray& r : random_rays(rng, 1000, 20.0f)) {
        Hit h;
        bvh->intersect(r, h, s);
    }
    EXPECT_EQ(s.rays, 1000u);
    // Every ray tests the top root, and rays that enter an instance its bottom root too.
    EXPECT_GT(s.nodes_visited, 1000u);
    EXPECT_GT(s.prim_tests, 0u);
    EXPECT_EQ(bvh->info().instanced_primitives, 100u * 128 + 100u * (32 + 2));
}

// Placement boxes come from the transformed parts of the bottom tree (instanced.cpp,
// Cover): each must still hold every vertex of its instance as object_to_world places
// it, and under rotation they must be tighter than the transformed prototype box.
TEST(InstanceBvh, PlacementBoxesHoldTheirInstanceAndFollowItsShape) {
    World w;
    w.meshes = {sphere_mesh(4)};  // 2048 triangles: a bottom tree several levels deep
    w.meshes[0].pos.pop_back();
    for (Vec3f& p : w.meshes[0].pos) p = p * Vec3f{4.0f, 0.5f, 1.0f};  // a flat, long ellipsoid
    w.meshes[0].pos.push_back({0, 0, 0});
    w.protos = {{0, 1}};
    std::mt19937 rng(5);
    for (int i = 0; i < 400; ++i) w.inst.push_back({0, random_transform(rng, i < 200 ? 30.0f : 1e5f, true)});
    w.finalize();
    for (NodeLayout layout : {NodeLayout::Float, NodeLayout::Quantized}) {
        auto acc = create_accelerator("custom", w.views, opts(TriangleTest::Fast, Isa::Auto, layout), w.set());
        const auto* b = dynamic_cast<const bvh::InstancedBase*>(acc.get());
        ASSERT_NE(b, nullptr);
        int leaves = 0, loose = 0;
        double tight_area = 0.0, whole_area = 0.0;
        const Bounds3f proto_box = [&] {
            Bounds3f r;
            for (size_t v = 0; v + 1 < w.meshes[0].pos.size(); ++v) r.extend(w.meshes[0].pos[v]);
            return r;
        }();
        const auto check = [&](const float (&lo)[3], const float (&hi)[3], uint32_t k) {
            const uint32_t inst = b->placements_[k].inst;
            ASSERT_LT(inst, w.inst.size());
            ++leaves;
            const Affine3f& m = w.inst[inst].object_to_world;
            for (size_t v = 0; v + 1 < w.meshes[0].pos.size(); ++v) {
                const Vec3f p = m.point(w.meshes[0].pos[v]);
                for (int a = 0; a < 3; ++a) loose += !(p[a] >= lo[a] && p[a] <= hi[a]);
            }
            Bounds3f t;
            for (int a = 0; a < 3; ++a) t.lo[a] = lo[a], t.hi[a] = hi[a];
            tight_area += t.surface_area();
            whole_area += m.bounds(proto_box).surface_area();
        };
        if (layout == NodeLayout::Float) {
            for (const bvh::WideNode& n : b->top_.nodes)
                for (int l = 0; l < bvh::kWidth; ++l)
                    if (n.child[l] != bvh::WideNode::kEmpty && (n.child[l] & bvh::WideNode::kLeaf))
                        check({n.b[0][l], n.b[1][l], n.b[2][l]}, {n.b[3][l], n.b[4][l], n.b[5][l]},
                              n.child[l] & ~bvh::WideNode::kLeaf);
        } else {
            for (const bvh::QuantNode& n : b->top_.qnodes)
                for (int l = 0; l < bvh::kWidth; ++l)
                    if ((n.valid >> l & 1) && (n.child[l] & bvh::WideNode::kLeaf)) {
                        float box[6];
                        bvh::dequantize(n, l, box);
                        check({box[0], box[1], box[2]}, {box[3], box[4], box[5]}, n.child[l] & ~bvh::WideNode::kLeaf);
                    }
        }
        EXPECT_EQ(leaves, 400) << layout_name(layout);
        EXPECT_EQ(loose, 0) << layout_name(layout);
        // Random turns of an 8:1 ellipsoid: the transformed whole box is far looser. (Under
        // Quantized the bottom trees are compressed too, so the cover is the whole box,
        // and the top grid rounds the leaf boxes outward: only containment holds there.)
        if (layout == NodeLayout::Float) {
            EXPECT_LT(tight_area, 0.85 * whole_area);
        }
    }
}

}  // namespace
