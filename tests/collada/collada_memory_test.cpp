// Hand-written in-memory documents: the dialect features one at a time, then one test
// per class of bad input (SceneError naming the file and the element or line).

#include <gtest/gtest.h>

#include <random>

#include <fmt/format.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <string>

#include "scenes/collada/collada.h"

namespace collada_test {

/// A complete document: `libraries` go after <asset>, `nodes` into the visual scene.
inline std::string dae(const std::string& libraries, const std::string& nodes,
                       const std::string& up = "Z_UP") {
    std::string asset = up.empty() ? "<asset/>" : "<asset><up_axis>" + up + "</up_axis></asset>";
    return R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
)" + asset + "\n" + libraries + R"(
<library_visual_scenes><visual_scene id="S">
)" + nodes + R"(
</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#S"/></scene>
</COLLADA>
)";
}

/// A <source> of 3-component float vectors.
inline std::string source3(const std::string& id, const std::string& floats, int count) {
    return "<source id=\"" + id + "\"><float_array id=\"" + id + "-array\" count=\"" +
           std::to_string(count * 3) + "\">" + floats +
           "</float_array><technique_common><accessor source=\"#" + id +
           "-array\" count=\"" + std::to_string(count) +
           "\" stride=\"3\"><param name=\"X\" type=\"float\"/><param name=\"Y\" "
           "type=\"float\"/><param name=\"Z\" type=\"float\"/></accessor></technique_common>"
           "</source>\n";
}

/// A <geometry id=id> whose mesh has positions `id-pos` (and normals `id-nrm` when
/// `normals` is non-empty), vertices `id-vtx`, and the given primitives.
inline std::string geometry(const std::string& id, const std::string& positions, int npos,
                            const std::string& primitives, const std::string& normals = "",
                            int nnrm = 0) {
    std::string s = "<geometry id=\"" + id + "\" name=\"" + id + "\"><mesh>\n" +
                    source3(id + "-pos", positions, npos);
    if (!normals.empty()) s += source3(id + "-nrm", normals, nnrm);
    s += "<vertices id=\"" + id + "-vtx\"><input semantic=\"POSITION\" source=\"#" + id +
         "-pos\"/></vertices>\n" + primitives + "\n</mesh></geometry>\n";
    return s;
}

/// VERTEX input at offset 0 of geometry `id` (and NORMAL at offset 1 when `normals`).
inline std::string inputs(const std::string& id, bool normals = false) {
    std::string s = "<input semantic=\"VERTEX\" source=\"#" + id + "-vtx\" offset=\"0\"/>";
    if (normals) s += "<input semantic=\"NORMAL\" source=\"#" + id + "-nrm\" offset=\"1\"/>";
    return s;
}

/// One triangle (0,0,0) (1,0,0) (0,1,0) as geometry "tri".
inline std::string tri_geometry(const std::string& material = "") {
    std::string mat = material.empty() ? "" : " material=\"" + material + "\"";
    return geometry("tri", "0 0 0 1 0 0 0 1 0", 3,
                    "<triangles count=\"1\"" + mat + ">" + inputs("tri") + "<p>0 1 2</p></triangles>");
}

inline std::string geometries(const std::string& g) {
    return "<library_geometries>\n" + g + "</library_geometries>\n";
}

/// A node instancing `url` with optional transform elements and bind_material body.
inline std::string node(const std::string& id, const std::string& transforms, const std::string& url,
                        const std::string& binds = "") {
    std::string b = binds.empty() ? "" : "<bind_material><technique_common>" + binds +
                                             "</technique_common></bind_material>";
    return "<node id=\"" + id + "\" name=\"" + id + "\">" + transforms +
           "<instance_geometry url=\"#" + url + "\">" + b + "</instance_geometry></node>\n";
}

inline std::string bind(const std::string& symbol, const std::string& target) {
    return "<instance_material symbol=\"" + symbol + "\" target=\"#" + target + "\"/>";
}

/// A material `id` whose effect `id-fx` has the given diffuse colour and optional CGL body.
inline std::string material(const std::string& id, const std::string& diffuse,
                            const std::string& cgl = "") {
    std::string fx = "<effect id=\"" + id + "-fx\"><profile_COMMON><technique sid=\"common\"><lambert>";
    if (!diffuse.empty()) fx += "<diffuse><color>" + diffuse + "</color></diffuse>";
    fx += "</lambert></technique></profile_COMMON>";
    if (!cgl.empty()) fx += "<extra><technique profile=\"CGL\">" + cgl + "</technique></extra>";
    fx += "</effect>";
    return "<library_effects>" + fx + "</library_effects><library_materials><material id=\"" + id +
           "\" name=\"" + id + "\"><instance_effect url=\"#" + id +
           "-fx\"/></material></library_materials>\n";
}

inline scenes::Scene load(const std::string& doc, const std::string& name = "test.dae") {
    return scenes::load_collada_memory(doc.data(), doc.size(), name);
}

}  // namespace collada_test

namespace {

using namespace collada_test;
using scenes::LightType;
using scenes::Scene;
using scenes::SceneError;
using scenes::Vec3f;

void expect_near(const Vec3f& a, const Vec3f& b, float tol = 1e-5f) {
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

bool has_note(const Scene& s, const std::string& needle) {
    for (const auto& n : s.notes)
        if (n.find(needle) != std::string::npos) return true;
    return false;
}

// ---------------------------------------------------------------------------------------
// Transforms

TEST(ColladaTransforms, MatrixIsRowMajorWithTranslationInColumn4) {
    const Scene s = load(dae(geometries(tri_geometry()),
                             node("n", "<matrix>1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1</matrix>", "tri")));
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[0], {5, 6, 7});
    expect_near(s.meshes[0].positions[1], {6, 6, 7});
}

TEST(ColladaTransforms, ElementsComposeInDocumentOrder) {
    // M = T * R * S: the scale acts first on the vertex, the translation last.
    const Scene a = load(dae(geometries(tri_geometry()),
                             node("n",
                                  "<translate>1 0 0</translate><rotate>0 0 1 90</rotate>"
                                  "<scale>2 2 2</scale>",
                                  "tri")));
    expect_near(a.meshes[0].positions[1], {1, 2, 0});  // (1,0,0) -> (2,0,0) -> (0,2,0) -> (1,2,0)
    // The reverse order gives a different answer: translate happens first.
    const Scene b = load(dae(geometries(tri_geometry()),
                             node("n",
                                  "<scale>2 2 2</scale><rotate>0 0 1 90</rotate>"
                                  "<translate>1 0 0</translate>",
                                  "tri")));
    expect_near(b.meshes[0].positions[1], {0, 4, 0});  // (1,0,0) -> (2,0,0) -> (0,2,0) -> (0,4,0)
}

TEST(ColladaTransforms, ChildComposesAfterParent) {
    const std::string nodes =
        "<node id=\"parent\"><translate>10 0 0</translate><rotate>0 0 1 90</rotate>" +
        node("child", "<translate>1 0 0</translate>", "tri") + "</node>";
    const Scene s = load(dae(geometries(tri_geometry()), nodes));
    ASSERT_EQ(s.meshes.size(), 1u);
    // child: (0,0,0) -> (1,0,0); parent rotates to (0,1,0) then moves to (10,1,0).
    expect_near(s.meshes[0].positions[0], {10, 1, 0});
    expect_near(s.meshes[0].positions[1], {10, 2, 0});
}

TEST(ColladaTransforms, InstanceNodeIsFollowedWithTheCallersTransform) {
    const std::string lib = geometries(tri_geometry()) +
                            "<library_nodes>" + node("shared", "<translate>0 0 1</translate>", "tri") +
                            "</library_nodes>";
    const std::string nodes =
        "<node id=\"a\"><translate>5 0 0</translate><instance_node url=\"#shared\"/></node>"
        "<node id=\"b\"><translate>-5 0 0</translate><instance_node url=\"#shared\"/></node>";
    Scene s = load(dae(lib, nodes));
    // Used twice: one prototype, two instances (collada_memory_test's instancing section).
    ASSERT_EQ(s.prototypes.size(), 1u);
    ASSERT_EQ(s.instances.size(), 2u);
    scenes::flatten_instances(s);
    ASSERT_EQ(s.meshes.size(), 2u);
    expect_near(s.meshes[0].positions[0], {5, 0, 1});
    expect_near(s.meshes[1].positions[0], {-5, 0, 1});
}

// ---------------------------------------------------------------------------------------
// Instancing: a geometry placed more than once under one material binding is a prototype

namespace {
// Two materials in one library of each kind (material() writes a library per material).
std::string two_materials() {
    return "<library_effects><effect id=\"red-fx\"><profile_COMMON><technique sid=\"c\"><lambert><diffuse>"
           "<color>1 0 0 1</color></diffuse></lambert></technique></profile_COMMON></effect>"
           "<effect id=\"blue-fx\"><profile_COMMON><technique sid=\"c\"><lambert><diffuse>"
           "<color>0 0 1 1</color></diffuse></lambert></technique></profile_COMMON></effect></library_effects>"
           "<library_materials><material id=\"red\" name=\"red\"><instance_effect url=\"#red-fx\"/></material>"
           "<material id=\"blue\" name=\"blue\"><instance_effect url=\"#blue-fx\"/></material></library_materials>";
}
}  // namespace

TEST(ColladaInstancing, ReusedGeometryIsOnePrototypeWithComposedTransforms) {
    const std::string nodes = "<node id=\"p\"><rotate>0 0 1 90</rotate><scale>2 1 3</scale>" +
                              node("a", "<translate>1 0 0</translate>", "tri", bind("m", "red")) +
                              node("b", "<scale>1 -1 1</scale>", "tri", bind("m", "red")) + "</node>";
    Scene s = load(dae(geometries(tri_geometry("m")) + two_materials(), nodes));
    ASSERT_EQ(s.prototypes.size(), 1u);
    ASSERT_EQ(s.instances.size(), 2u);
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.prototypes[0].name, "tri");
    EXPECT_EQ(s.materials[s.meshes[0].material].name, "red");
    expect_near(s.meshes[0].positions[1], {1, 0, 0});  // object space
    // p = R_z(90) S(2,1,3); a = p T(1,0,0): (0,0,0) -> (0,2,0); b mirrors y.
    expect_near(s.instances[0].object_to_world.point({0, 0, 0}), {0, 2, 0});
    expect_near(s.instances[0].object_to_world.point({1, 0, 0}), {0, 4, 0});
    expect_near(s.instances[1].object_to_world.point({0, 1, 0}), {1, 0, 0});
    EXPECT_LT(s.instances[1].object_to_world.det(), 0.0) << "a mirror is kept as an instance";
    EXPECT_TRUE(has_note(s, "instancing: 2 instances of 1 geometries"));
    EXPECT_EQ(s.num_triangles(), 1u);
    EXPECT_EQ(s.instanced_triangles(), 2u);
    scenes::flatten_instances(s);
    ASSERT_EQ(s.meshes.size(), 2u);
    expect_near(s.meshes[0].positions[1], {0, 4, 0});
    EXPECT_EQ(s.meshes[1].indices, (std::vector<uint32_t>{0, 2, 1})) << "mirrored copy: winding swapped";
}

TEST(ColladaInstancing, FlattenedInstancesMatchThePlacedOnceLoad) {
    // The same placements through an <instance_node> used three times, and through three
    // geometries placed once each (loaded as before instancing).
    const std::string shared = "<library_nodes><node id=\"k\"><translate>0 0 1</translate>"
                               "<instance_geometry url=\"#tri\"/></node></library_nodes>";
    const std::string placements[3] = {"<translate>5 0 0</translate><rotate>1 1 0 30</rotate>",
                                       "<scale>1 2 -1</scale>", "<matrix>1 0.5 0 1 0 2 0 2 0 0 1 3 0 0 0 1</matrix>"};
    std::string used, once, geoms;
    for (int i = 0; i < 3; ++i) {
        const std::string id = std::to_string(i);
        used += "<node id=\"u" + id + "\">" + placements[i] + "<instance_node url=\"#k\"/></node>";
        once += "<node id=\"o" + id + "\">" + placements[i] + "<node id=\"k" + id +
                "\"><translate>0 0 1</translate><instance_geometry url=\"#t" + id + "\"/></node></node>";
        geoms += geometry("t" + id, "0 0 0 1 0 0 0 1 0", 3,
                          "<triangles count=\"1\">" + inputs("t" + id) + "<p>0 1 2</p></triangles>");
    }
    Scene inst = load(dae(geometries(tri_geometry()) + shared, used));
    const Scene before = load(dae(geometries(geoms), once));
    ASSERT_EQ(inst.prototypes.size(), 1u);
    ASSERT_EQ(inst.instances.size(), 3u);
    ASSERT_TRUE(before.prototypes.empty());
    scenes::flatten_instances(inst);
    ASSERT_EQ(inst.meshes.size(), 3u);
    ASSERT_EQ(before.meshes.size(), 3u);
    for (size_t i = 0; i < 3; ++i) {
        // The mirrored placement (1) is the one difference: flatten_instances swaps its
        // winding (scene.h), the COLLADA loader's own world-space copies never have.
        EXPECT_EQ(before.meshes[i].indices, (std::vector<uint32_t>{0, 1, 2})) << i;
        EXPECT_EQ(inst.meshes[i].indices, (i == 1 ? std::vector<uint32_t>{0, 2, 1} : std::vector<uint32_t>{0, 1, 2})) << i;
        for (uint32_t v = 0; v < 3; ++v) {
            EXPECT_EQ(inst.meshes[i].positions[v].x, before.meshes[i].positions[v].x) << i;
            EXPECT_EQ(inst.meshes[i].positions[v].y, before.meshes[i].positions[v].y) << i;
            EXPECT_EQ(inst.meshes[i].positions[v].z, before.meshes[i].positions[v].z) << i;
        }
    }
}

TEST(ColladaInstancing, PlacedOnceOrBoundDifferentlyStaysFlattened) {
    // One placement each, or the same geometry under two bindings (a Prototype's meshes
    // carry their materials): world space, as before.
    const Scene one = load(dae(geometries(tri_geometry()), node("n", "<translate>1 0 0</translate>", "tri")));
    EXPECT_TRUE(one.prototypes.empty());
    EXPECT_TRUE(one.instances.empty());
    expect_near(one.meshes[0].positions[0], {1, 0, 0});
    const Scene two = load(dae(geometries(tri_geometry("m")) + two_materials(),
                               node("a", "", "tri", bind("m", "red")) + node("b", "", "tri", bind("m", "blue"))));
    EXPECT_TRUE(two.prototypes.empty());
    EXPECT_EQ(two.meshes.size(), 2u);
    EXPECT_NE(two.meshes[0].material, two.meshes[1].material);
}

TEST(ColladaInstancing, SpheresAndLightsUnderReuseAreCopied) {
    const std::string sphere =
        "<geometry id=\"ball\" name=\"ball\"><extra><technique profile=\"CGL\"><sphere><radius>1</radius>"
        "</sphere></technique></extra></geometry>";
    const std::string light = "<library_lights><light id=\"pt\"><technique_common><point><color>1 1 1</color>"
                              "</point></technique_common></light></library_lights>";
    const std::string lib = "<library_nodes><node id=\"k\">" + node("s", "", "ball") + node("t", "", "tri") +
                            "<node id=\"l\"><instance_light url=\"#pt\"/></node></node></library_nodes>";
    const std::string nodes = "<node id=\"a\"><translate>5 0 0</translate><instance_node url=\"#k\"/></node>"
                              "<node id=\"b\"><translate>-5 0 0</translate><instance_node url=\"#k\"/></node>";
    const Scene s = load(dae(geometries(tri_geometry() + sphere) + light + lib, nodes));
    EXPECT_EQ(s.prototypes.size(), 1u) << "the triangle";
    EXPECT_EQ(s.instances.size(), 2u);
    ASSERT_EQ(s.spheres.size(), 2u);
    expect_near(s.spheres[0].center, {5, 0, 0});
    expect_near(s.spheres[1].center, {-5, 0, 0});
    ASSERT_EQ(s.lights.size(), 2u);
    EXPECT_TRUE(has_note(s, "2 placements of reused sphere geometries copied"));
    EXPECT_TRUE(has_note(s, "2 lights under <instance_node> copied"));
}

TEST(ColladaInstancing, SingularPlacementIsDroppedAndTheLimitIsItsOwn) {
    const std::string nodes = node("a", "", "tri") + node("flat", "<scale>1 0 1</scale>", "tri") +
                              node("c", "<translate>0 0 2</translate>", "tri");
    const Scene s = load(dae(geometries(tri_geometry()), nodes));
    EXPECT_EQ(s.instances.size(), 2u);
    EXPECT_TRUE(has_note(s, "node 'flat': singular or non-finite transform; its instance of geometry 'tri' dropped"));
    // Instances have their own limit, and unique triangles count once.
    scenes::ColladaLimits limits;
    limits.max_triangles = 1;
    const std::string doc = dae(geometries(tri_geometry()), nodes);
    EXPECT_EQ(scenes::load_collada_memory(doc.data(), doc.size(), "t.dae", limits).instances.size(), 2u);
    limits.max_instances = 1;
    try {
        scenes::load_collada_memory(doc.data(), doc.size(), "t.dae", limits);
        FAIL() << "a second instance accepted past a limit of 1";
    } catch (const SceneError& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("<instance_geometry> in <node id=\"c\">"), std::string::npos) << m;
        EXPECT_NE(m.find("more than 1 instances"), std::string::npos) << m;
    }
}

TEST(ColladaTransforms, NormalsUseTheInverseTransposeAndAreUnit) {
    const std::string g = geometry("g", "0 0 0 1 0 0 0 1 0", 3,
                                   "<triangles count=\"1\">" + inputs("g", true) +
                                       "<p>0 0 1 0 2 0</p></triangles>",
                                   "1 1 0", 1);
    const Scene s = load(dae(geometries(g), node("n", "<scale>2 1 1</scale>", "g")));
    ASSERT_EQ(s.meshes.size(), 1u);
    ASSERT_EQ(s.meshes[0].normals.size(), 3u);
    // Stretching x by 2 tilts a (1,1,0) normal towards y: (0.5, 1, 0) normalised.
    const Vec3f expected = accel::normalize(Vec3f(0.5f, 1.0f, 0.0f));
    for (const auto& n : s.meshes[0].normals) expect_near(n, expected);
}

TEST(ColladaTransforms, NoNormalsInTheFileMeansNoNormalsStored) {
    const Scene s = load(dae(geometries(tri_geometry()), node("n", "", "tri")));
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_TRUE(s.meshes[0].normals.empty());
    EXPECT_TRUE(s.meshes[0].uvs.empty());
    EXPECT_EQ(s.meshes[0].positions.size(), 4u) << "3 vertices + the padding element";
}

// ---------------------------------------------------------------------------------------
// Primitives

TEST(ColladaPrimitives, PolylistFanTriangulatesQuadAndPentagon) {
    // A quad (0..3) and a pentagon (4..8), and a degenerate 2-corner polygon in between.
    const std::string g = geometry(
        "g", "0 0 0 1 0 0 1 1 0 0 1 0  5 0 0 6 0 0 7 1 0 6 2 0 5 1 0", 9,
        "<polylist count=\"3\">" + inputs("g") +
            "<vcount>4 2 5</vcount><p>0 1 2 3  0 1  4 5 6 7 8</p></polylist>");
    const Scene s = load(dae(geometries(g), node("n", "", "g")));
    ASSERT_EQ(s.meshes.size(), 1u);
    const auto& m = s.meshes[0];
    ASSERT_EQ(m.num_triangles(), 2u + 3u);
    // Fans from each polygon's first corner, in order.
    const std::vector<uint32_t> expected = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 4, 7, 8};
    EXPECT_EQ(m.indices, expected);
    expect_near(m.positions[8], {5, 1, 0});
    EXPECT_TRUE(has_note(s, "fewer than 3 corners")) << "the 2-corner polygon is reported";
}

namespace {

/// A polygon of corners (x, y) in the plane z = 0, as one <polylist> of geometry "g",
/// placed under `transforms`.
Scene polygon_scene(const std::vector<std::pair<float, float>>& xy, const std::string& transforms = "",
                    const std::string& tag = "polylist") {
    std::string pos, p;
    for (size_t k = 0; k < xy.size(); ++k) {
        pos += fmt::format("{} {} 0 ", xy[k].first, xy[k].second);
        p += std::to_string(k) + " ";
    }
    const std::string prim =
        tag == "polylist" ? "<polylist count=\"1\">" + inputs("g") + "<vcount>" + std::to_string(xy.size()) +
                                "</vcount><p>" + p + "</p></polylist>"
                          : "<" + tag + " count=\"1\">" + inputs("g") + "<p>" + p + "</p></" + tag + ">";
    return load(dae(geometries(geometry("g", pos, int(xy.size()), prim)), node("n", transforms, "g")));
}

/// Twice the signed area of each triangle about `normal`, summed, and the least of them.
std::pair<double, double> signed_areas(const scenes::Mesh& m, const Vec3f& normal) {
    double sum = 0, least = 1e30;
    for (size_t t = 0; t < m.indices.size(); t += 3) {
        const Vec3f a = m.positions[m.indices[t]], b = m.positions[m.indices[t + 1]], c = m.positions[m.indices[t + 2]];
        const double s = accel::dot(accel::cross(b - a, c - a), normal);
        sum += s;
        least = std::min(least, s);
    }
    return {sum, least};
}

/// Is (x, y) inside the L of [0, 2] x [0, 1] and [0, 1] x [0, 2]?
bool in_l(float x, float y) { return x >= -1e-5f && y >= -1e-5f && (x <= 1 + 1e-5f ? y <= 2 + 1e-5f : x <= 2 + 1e-5f && y <= 1 + 1e-5f); }

}  // namespace

// A concave n-gon, as exporters write them, is cut by ear clipping: its triangles tile it
// (their areas add up to its own, each turns its way, none covers its notch), where a fan
// from its first corner would cover the notch. Convex polygons keep the fan (above), and
// <trifans> stay fans whatever their shape.
TEST(ColladaPrimitives, ConcavePolygonsAreCutByEarClipping) {
    // An L (area 3) starting at a corner that does not see the whole L.
    const std::vector<std::pair<float, float>> l = {{2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}, {0, 0}};
    for (const std::string& tag : {std::string("polylist"), std::string("polygons")}) {
        const Scene s = polygon_scene(l, "", tag);
        const scenes::Mesh& m = s.meshes[0];
        ASSERT_EQ(m.num_triangles(), 4u) << tag;
        const auto [sum, least] = signed_areas(m, Vec3f(0, 0, 1));
        EXPECT_NEAR(sum, 6.0, 1e-5) << tag;
        EXPECT_GT(least, 0.0) << tag << ": every triangle turns the polygon's way";
        for (size_t t = 0; t < m.indices.size(); t += 3) {
            const Vec3f c = (m.positions[m.indices[t]] + m.positions[m.indices[t + 1]] + m.positions[m.indices[t + 2]]) / 3.0f;
            EXPECT_TRUE(in_l(c.x, c.y)) << tag << ": a triangle covers the notch, centroid " << c.x << " " << c.y;
        }
        EXPECT_FALSE(has_note(s, "concave polygon")) << tag;
    }
    // Turned into another plane, mirrored by the winding: the same tiling.
    const Scene turned = polygon_scene(l, "<rotate>1 2 3 50</rotate>");
    const Vec3f n = accel::normalize(turned.meshes[0].normals.empty()
                                         ? accel::cross(turned.meshes[0].positions[1] - turned.meshes[0].positions[0],
                                                        turned.meshes[0].positions[2] - turned.meshes[0].positions[0])
                                         : Vec3f(0.0f));
    const auto [tsum, tleast] = signed_areas(turned.meshes[0], n);
    EXPECT_NEAR(tsum, 6.0, 1e-4);
    EXPECT_GT(tleast, 0.0);
    const Scene reversed = polygon_scene({l.rbegin(), l.rend()});
    EXPECT_NEAR(signed_areas(reversed.meshes[0], Vec3f(0, 0, -1)).first, 6.0, 1e-5) << "clockwise: faces -z";
    EXPECT_GT(signed_areas(reversed.meshes[0], Vec3f(0, 0, -1)).second, 0.0);
    // A comb of 100 teeth, 1 x 4 each, on a 200 x 1 back (402 corners, area 600): tiled.
    std::vector<std::pair<float, float>> comb = {{0, 0}, {200, 0}};
    for (int t = 99; t >= 0; --t) {
        comb.push_back({2.0f * float(t) + 2.0f, 5.0f});
        comb.push_back({2.0f * float(t) + 1.0f, 5.0f});
        comb.push_back({2.0f * float(t) + 1.0f, 1.0f});
        comb.push_back({2.0f * float(t), 1.0f});
    }
    const Scene cs = polygon_scene(comb);
    EXPECT_LE(cs.meshes[0].num_triangles(), comb.size() - 2);
    const auto [csum, cleast] = signed_areas(cs.meshes[0], Vec3f(0, 0, 1));
    EXPECT_NEAR(csum, 2.0 * 600.0, 1e-2);
    EXPECT_GT(cleast, 0.0);
    // A <trifans> fan is the file's own triangulation.
    const Scene fan = polygon_scene(l, "", "trifans");
    const std::vector<uint32_t> fanned = {0, 1, 2, 0, 2, 3, 0, 3, 4, 0, 4, 5};
    EXPECT_EQ(fan.meshes[0].indices, fanned);
    // A self-intersecting polygon still loads, as triangles over its corners.
    const Scene bow = polygon_scene({{0, 0}, {2, 2}, {2, 0}, {1, 3}, {0, 2}});
    EXPECT_GE(bow.meshes[0].num_triangles(), 1u);
    EXPECT_LE(bow.meshes[0].num_triangles(), 3u);
}

// Random star-shaped polygons (simple, mostly concave, 5 to 60 corners): every one is
// tiled by ear clipping, never fanned for want of an ear.
TEST(ColladaPrimitives, RandomStarPolygonsAreTiled) {
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> radius(0.2f, 1.0f);
    for (int trial = 0; trial < 300; ++trial) {
        const int n = 5 + trial % 56;
        std::vector<std::pair<float, float>> star;
        double area2 = 0;
        for (int k = 0; k < n; ++k) {
            const float a = 2.0f * 3.14159265f * float(k) / float(n), r = radius(rng);
            star.push_back({std::round(r * std::cos(a) * 1024.0f) / 1024.0f, std::round(r * std::sin(a) * 1024.0f) / 1024.0f});
        }
        for (int k = 0; k < n; ++k)
            area2 += double(star[k].first) * star[(k + 1) % n].second - double(star[(k + 1) % n].first) * star[k].second;
        const Scene s = polygon_scene(star);
        ASSERT_FALSE(has_note(s, "concave polygon")) << "trial " << trial;
        const auto [sum, least] = signed_areas(s.meshes[0], Vec3f(0, 0, 1));
        ASSERT_NEAR(sum, area2, 1e-4) << "trial " << trial;
        ASSERT_GT(least, 0.0) << "trial " << trial;
    }
}

TEST(ColladaPrimitives, PolygonsElementIsTriangulatedToo) {
    const std::string g = geometry("g", "0 0 0 1 0 0 1 1 0 0 1 0", 4,
                                   "<polygons count=\"1\">" + inputs("g") +
                                       "<p>0 1 2 3</p></polygons>");
    const Scene s = load(dae(geometries(g), node("n", "", "g")));
    ASSERT_EQ(s.num_triangles(), 2u);
}

// <trifans> and <tristrips>: one <p> per fan or strip. A fan is the polygon's fan; a
// strip alternates its triangles' corner order so that all face the same way, and a
// triangle repeating a position (a strip's restart) is dropped.
TEST(ColladaPrimitives, FansAndStripsTriangulate) {
    const std::string pos = "0 0 0 1 0 0 1 1 0 0 1 0  2 0 0 3 0 0 2 1 0 3 1 0 4 0 0";
    const std::string fans = geometry("g", pos, 9, "<trifans count=\"1\">" + inputs("g") + "<p>0 1 2 3</p></trifans>");
    const Scene f = load(dae(geometries(fans), node("n", "", "g")));
    ASSERT_EQ(f.meshes.size(), 1u);
    EXPECT_EQ(f.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3}));
    // Strip 4 5 6 7 8 with a restart (7 repeated) in its middle.
    const std::string strips = geometry("g", pos, 9,
                                        "<tristrips count=\"2\">" + inputs("g") +
                                            "<p>4 5 6 7</p><p>5 8 7 7 6</p></tristrips>");
    const Scene s = load(dae(geometries(strips), node("n", "", "g")));
    ASSERT_EQ(s.meshes.size(), 1u);
    const auto& m = s.meshes[0];
    ASSERT_EQ(m.num_triangles(), 3u) << "2 from the first strip, 1 from the second (two repeat corner 7)";
    // Every triangle faces +z, as the first of each strip does.
    for (uint32_t t = 0; t < m.num_triangles(); ++t) {
        const Vec3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                    c = m.positions[m.indices[3 * t + 2]];
        EXPECT_GT(accel::cross(b - a, c - a).z, 0.0f) << "triangle " << t;
    }
    EXPECT_FALSE(has_note(s, "not supported"));
    const Scene lines = load(dae(geometries(geometry("g", pos, 9,
                                                     "<lines count=\"1\">" + inputs("g") + "<p>0 1</p></lines>"
                                                     "<triangles count=\"1\">" + inputs("g") + "<p>0 1 2</p></triangles>")),
                                 node("n", "", "g")));
    EXPECT_TRUE(has_note(lines, "<lines> skipped"));
}

TEST(ColladaPrimitives, CornersSharingPositionAndNormalAreWelded) {
    // Two triangles over a quad, sharing the 0-2 edge, one normal: 4 vertices, shared edge.
    const std::string same = geometry("g", "0 0 0 1 0 0 1 1 0 0 1 0", 4,
                                      "<triangles count=\"2\">" + inputs("g", true) +
                                          "<p>0 0 1 0 2 0  0 0 2 0 3 0</p></triangles>",
                                      "0 0 1", 1);
    const Scene a = load(dae(geometries(same), node("n", "", "g")));
    ASSERT_EQ(a.meshes.size(), 1u);
    EXPECT_EQ(a.meshes[0].num_vertices(), 4u);
    EXPECT_EQ(a.meshes[0].indices[0], a.meshes[0].indices[3]);
    EXPECT_EQ(a.meshes[0].indices[2], a.meshes[0].indices[4]);

    // Same positions but a different normal per triangle (a crease): the shared corners
    // must stay separate vertices, or one face would get the other's normal.
    const std::string crease = geometry("g", "0 0 0 1 0 0 1 1 0 0 1 0", 4,
                                        "<triangles count=\"2\">" + inputs("g", true) +
                                            "<p>0 0 1 0 2 0  0 1 2 1 3 1</p></triangles>",
                                        "0 0 1 0 1 1", 2);
    const Scene b = load(dae(geometries(crease), node("n", "", "g")));
    EXPECT_EQ(b.meshes[0].num_vertices(), 6u);
}

TEST(ColladaPrimitives, AccessorStrideAndUnusedInputsAreRespected) {
    // Positions with stride 4 (a 4th component to skip) and a TEXCOORD input at offset 1.
    const std::string g =
        "<geometry id=\"g\"><mesh>"
        "<source id=\"pos\"><float_array id=\"pa\" count=\"12\">0 0 0 9 1 0 0 9 0 1 0 9</float_array>"
        "<technique_common><accessor source=\"#pa\" count=\"3\" stride=\"4\"/></technique_common></source>"
        "<source id=\"uv\"><float_array id=\"ua\" count=\"2\">0 0</float_array>"
        "<technique_common><accessor source=\"#ua\" count=\"1\" stride=\"2\"/></technique_common></source>"
        "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#pos\"/></vertices>"
        "<triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
        "<input semantic=\"TEXCOORD\" source=\"#uv\" offset=\"1\" set=\"0\"/>"
        "<p>0 0 1 0 2 0</p></triangles></mesh></geometry>";
    const Scene s = load(dae(geometries(g), node("n", "", "g")));
    ASSERT_EQ(s.meshes.size(), 1u);
    expect_near(s.meshes[0].positions[1], {1, 0, 0});
    expect_near(s.meshes[0].positions[2], {0, 1, 0});
    EXPECT_TRUE(s.meshes[0].uvs.empty());
}

// ---------------------------------------------------------------------------------------
// Materials

TEST(ColladaMaterials, OneMeshPerMaterialSymbolWithBoundAlbedo) {
    const std::string g = geometry("g", "0 0 0 1 0 0 0 1 0 0 0 1", 4,
                                   "<triangles count=\"1\" material=\"A\">" + inputs("g") +
                                       "<p>0 1 2</p></triangles>"
                                       "<triangles count=\"1\" material=\"B\">" +
                                       inputs("g") + "<p>0 1 3</p></triangles>"
                                       "<triangles count=\"1\" material=\"A\">" +
                                       inputs("g") + "<p>0 2 3</p></triangles>");
    const std::string libs = geometries(g) + material("red", "0.9 0.1 0.1 1") +
                             material("blue", "0.1 0.1 0.9 1");
    const Scene s = load(dae(libs, node("n", "", "g", bind("A", "red") + bind("B", "blue"))));
    ASSERT_EQ(s.meshes.size(), 2u);
    EXPECT_EQ(s.meshes[0].num_triangles(), 2u) << "both A primitives go to one mesh";
    EXPECT_EQ(s.meshes[1].num_triangles(), 1u);
    EXPECT_EQ(s.materials[s.meshes[0].material].albedo, Vec3f(0.9f, 0.1f, 0.1f));
    EXPECT_EQ(s.materials[s.meshes[1].material].albedo, Vec3f(0.1f, 0.1f, 0.9f));
    EXPECT_EQ(s.materials.size(), 2u);
}

TEST(ColladaMaterials, UnboundGeometryGetsDefaultGrey) {
    const Scene s = load(dae(geometries(tri_geometry("M")), node("n", "", "tri")));
    ASSERT_EQ(s.meshes.size(), 1u);
    ASSERT_EQ(s.materials.size(), 1u);
    EXPECT_EQ(s.materials[0].albedo, Vec3f(0.8f));
    EXPECT_FALSE(s.materials[0].is_emissive());
    EXPECT_TRUE(has_note(s, "not bound"));
}

TEST(ColladaMaterials, CglEmissionEmitsAndDoesNotReflect) {
    const std::string libs =
        geometries(tri_geometry("L")) +
        material("light", "0.8 0.8 0.8 1", "<emission><radiance>7 8 9</radiance></emission>");
    const Scene s = load(dae(libs, node("n", "", "tri", bind("L", "light"))));
    const auto& m = s.materials.at(s.meshes.at(0).material);
    EXPECT_EQ(m.emission, Vec3f(7, 8, 9));
    EXPECT_TRUE(m.is_emissive());
    EXPECT_EQ(m.albedo, Vec3f(0.0f));
    EXPECT_TRUE(m.replaced.empty());
    EXPECT_TRUE(s.notes.empty());
}

TEST(ColladaMaterials, CglMirrorIsAMirror) {
    const std::string libs =
        geometries(tri_geometry("M")) +
        material("chrome", "0.3 0.4 0.5 1", "<mirror><reflectance>1 0.8 0.4</reflectance></mirror>");
    const Scene s = load(dae(libs, node("n", "", "tri", bind("M", "chrome"))));
    const auto& m = s.materials.at(s.meshes.at(0).material);
    EXPECT_EQ(m.bsdf, scenes::BsdfKind::Mirror);
    EXPECT_EQ(m.reflectance, Vec3f(1.0f, 0.8f, 0.4f));
    EXPECT_TRUE(m.replaced.empty());
    EXPECT_FALSE(m.is_emissive());
    EXPECT_FALSE(has_note(s, "diffuse"));
}

TEST(ColladaMaterials, CglGlassAndRefractionReadTheirFields) {
    const auto one = [](const std::string& name, const std::string& cgl) {
        const Scene s = load(dae(geometries(tri_geometry("M")) + material(name, "", cgl),
                                 node("n", "", "tri", collada_test::bind("M", name))));
        return s.materials.at(s.meshes.at(0).material);
    };
    const auto m = one("gem", "<glass><reflectance>1 0.5 0.25</reflectance><transmittance>0.5 1 1</transmittance>"
                              "<roughness>0</roughness><ior>1.45</ior></glass>");
    EXPECT_EQ(m.bsdf, scenes::BsdfKind::Glass);
    EXPECT_EQ(m.reflectance, Vec3f(1.0f, 0.5f, 0.25f));
    EXPECT_EQ(m.transmittance, Vec3f(0.5f, 1.0f, 1.0f));
    EXPECT_FLOAT_EQ(m.ior, 1.45f);
    const auto w = one("water", "<refraction><transmittance>1 1 1</transmittance><ior>1.33</ior></refraction>");
    EXPECT_EQ(w.bsdf, scenes::BsdfKind::Glass);
    EXPECT_EQ(w.reflectance, Vec3f(0.0f)) << "the course's refraction BSDF only transmits";
    EXPECT_FLOAT_EQ(w.ior, 1.33f);
}

TEST(ColladaMaterials, CglMicrofacetReadsAlphaEtaK) {
    const std::string libs =
        geometries(tri_geometry("M")) +
        material("gold", "", "<microfacet><alpha>0.25</alpha><eta>0.2 0.4 1.3</eta><k>3.2 2.5 1.9</k></microfacet>");
    const Scene s = load(dae(libs, node("n", "", "tri", bind("M", "gold"))));
    const auto& m = s.materials.at(s.meshes.at(0).material);
    EXPECT_EQ(m.bsdf, scenes::BsdfKind::Microfacet);
    EXPECT_FLOAT_EQ(m.alpha, 0.25f);
    EXPECT_EQ(m.eta, Vec3f(0.2f, 0.4f, 1.3f));
    EXPECT_EQ(m.k, Vec3f(3.2f, 2.5f, 1.9f));
}

TEST(ColladaMaterials, CglSpectrumMayBeOneNumber) {
    const std::string libs =
        geometries(tri_geometry("M")) + material("al", "", "<microfacet><alpha>0.1</alpha><eta>1.2</eta><k>7</k></microfacet>");
    const Scene s = load(dae(libs, node("n", "", "tri", bind("M", "al"))));
    const auto& m = s.materials.at(s.meshes.at(0).material);
    EXPECT_EQ(m.eta, Vec3f(1.2f));
    EXPECT_EQ(m.k, Vec3f(7.0f));
}

TEST(ColladaMaterials, BadBsdfParametersNameTheElement) {
    const std::string libs = geometries(tri_geometry("M")) +
                             material("bad", "", "<glass><ior>-1</ior></glass>");
    try {
        load(dae(libs, node("n", "", "tri", bind("M", "bad"))));
        FAIL() << "negative ior accepted";
    } catch (const scenes::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("ior"), std::string::npos) << e.what();
    }
}

TEST(ColladaMaterials, UnknownCglBsdfIsReplacedByDiffuseAndNoted) {
    const std::string libs =
        geometries(tri_geometry("M")) + material("odd", "", "<velvet><reflectance>1 0.5 0.25</reflectance></velvet>");
    const Scene s = load(dae(libs, node("n", "", "tri", bind("M", "odd"))));
    const auto& m = s.materials.at(s.meshes.at(0).material);
    EXPECT_EQ(m.replaced, "velvet");
    EXPECT_EQ(m.albedo, Vec3f(1.0f, 0.5f, 0.25f));
    EXPECT_TRUE(has_note(s, "velvet"));
}

TEST(ColladaMaterials, CglDiffuseSetsTheAlbedo) {
    const std::string libs =
        geometries(tri_geometry("M")) +
        material("d", "0.5 0.5 0.5 1", "<diffuse><reflectance>0.2 0.3 0.4</reflectance></diffuse>");
    const Scene s = load(dae(libs, node("n", "", "tri", bind("M", "d"))));
    const auto& m = s.materials.at(s.meshes.at(0).material);
    EXPECT_EQ(m.albedo, Vec3f(0.2f, 0.3f, 0.4f));
    EXPECT_TRUE(m.replaced.empty());
}

// ---------------------------------------------------------------------------------------
// Scene-level facts

TEST(ColladaScene, UpAxis) {
    const std::string libs = geometries(tri_geometry());
    const std::string n = node("n", "", "tri");
    EXPECT_EQ(load(dae(libs, n, "Z_UP")).up, Vec3f(0, 0, 1));
    EXPECT_EQ(load(dae(libs, n, "Y_UP")).up, Vec3f(0, 1, 0));
    EXPECT_EQ(load(dae(libs, n, "X_UP")).up, Vec3f(1, 0, 0));
    EXPECT_EQ(load(dae(libs, n, "")).up, Vec3f(0, 1, 0)) << "COLLADA's default is Y_UP";
    // The geometry is not rotated to a common up axis.
    expect_near(load(dae(libs, n, "Z_UP")).meshes[0].positions[2], {0, 1, 0});
}

TEST(ColladaScene, SphereRadiusFollowsTheNodeScale) {
    const std::string libs = geometries(
        "<geometry id=\"ball\"><extra><technique profile=\"CGL\"><sphere><radius>0.5</radius>"
        "</sphere></technique></extra></geometry>");
    const Scene s = load(dae(libs, node("a", "<translate>1 2 3</translate><scale>3 3 3</scale>", "ball") +
                                       node("b", "<scale>1 2 4</scale>", "ball")));
    ASSERT_EQ(s.spheres.size(), 2u);
    expect_near(s.spheres[0].center, {1, 2, 3});
    EXPECT_NEAR(s.spheres[0].radius, 1.5f, 1e-5f);
    // Non-uniform: the volume-preserving scale cbrt(1*2*4) = 2, and a note says so.
    EXPECT_NEAR(s.spheres[1].radius, 1.0f, 1e-5f);
    EXPECT_TRUE(has_note(s, "non-uniform"));
    EXPECT_EQ(s.materials[s.spheres[0].material].albedo, Vec3f(0.8f));
}

TEST(ColladaScene, LightsCglFirstThenTechniqueCommon) {
    const std::string libs = geometries(tri_geometry()) + R"(
<library_lights>
  <light id="area"><technique_common><point><color>1 1 1</color></point></technique_common>
    <extra><technique profile="CGL"><area><color>4 5 6</color></area></technique></extra></light>
  <light id="pt"><technique_common><point><color>2 2 2</color></point></technique_common></light>
  <light id="sun"><technique_common><directional><color>3 3 3</color></directional></technique_common></light>
  <light id="sky"><technique_common><ambient><color>0.1 0.2 0.3</color></ambient></technique_common></light>
  <light id="spot"><technique_common><spot><color>1 1 1</color><falloff_angle>60</falloff_angle></spot></technique_common></light>
</library_lights>)";
    const std::string nodes = node("n", "", "tri") +
                              "<node id=\"A\"><matrix>0.6 0 0 0 0 0.8 0 0 0 0 1 1.49 0 0 0 1</matrix>"
                              "<instance_light url=\"#area\"/></node>"
                              "<node id=\"P\"><translate>1 2 3</translate>"
                              "<instance_light url=\"#pt\"/><instance_light url=\"#sun\"/></node>"
                              "<node id=\"E\"><instance_light url=\"#sky\"/></node>"
                              "<node id=\"Sp\"><translate>0 0 5</translate><instance_light url=\"#spot\"/></node>";
    const Scene s = load(dae(libs, nodes));
    ASSERT_EQ(s.lights.size(), 5u);
    const auto& a = s.lights[0];
    EXPECT_EQ(a.type, LightType::Area);
    EXPECT_EQ(a.radiance, Vec3f(4, 5, 6));
    expect_near(a.position, {0, 0, 1.49f});
    expect_near(a.direction, {0, 0, -1});
    expect_near(a.edge_v, {0, 0.8f, 0});
    expect_near(a.edge_u, {-0.6f, 0, 0});
    EXPECT_EQ(s.lights[1].type, LightType::Point);
    expect_near(s.lights[1].position, {1, 2, 3});
    EXPECT_EQ(s.lights[1].radiance, Vec3f(2, 2, 2));
    EXPECT_EQ(s.lights[2].type, LightType::Directional) << "two instance_light in one node";
    expect_near(s.lights[2].direction, {0, 0, -1});
    EXPECT_EQ(s.lights[3].type, LightType::Environment);
    EXPECT_EQ(s.lights[3].radiance, Vec3f(0.1f, 0.2f, 0.3f));
    EXPECT_EQ(s.lights[4].type, LightType::Spot);
    EXPECT_NEAR(s.lights[4].spot_cos_outer, std::cos(30.0 * M_PI / 180.0), 1e-5);
    EXPECT_GT(s.lights[4].spot_cos_inner, s.lights[4].spot_cos_outer);
}

TEST(ColladaScene, CameraFromNodeAndPerspective) {
    const std::string libs = geometries(tri_geometry()) + R"(
<library_cameras><camera id="cam"><optics><technique_common><perspective>
  <yfov>30</yfov><aspect_ratio>2</aspect_ratio><znear>0.5</znear><zfar>50</zfar>
</perspective></technique_common></optics></camera></library_cameras>)";
    const Scene s = load(dae(libs, node("n", "", "tri") +
                                       "<node id=\"C\"><translate>0 0 9</translate>"
                                       "<instance_camera url=\"#cam\"/></node>"));
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_EQ(s.camera->yfov_deg, 30.0f);
    EXPECT_EQ(s.camera->aspect, 2.0f);
    // xfov derived from yfov and aspect: 2 atan(tan(15 deg) * 2).
    EXPECT_NEAR(s.camera->xfov_deg, 2.0 * std::atan(std::tan(15.0 * M_PI / 180.0) * 2.0) * 180.0 / M_PI,
                1e-3);
    EXPECT_EQ(s.camera->znear, 0.5f);
    EXPECT_EQ(s.camera->zfar, 50.0f);
    expect_near(s.camera->camera_to_world.transform_point({0, 0, 0}), {0, 0, 9});
}

TEST(ColladaScene, TheReferencedVisualSceneIsUsedNotTheFirst) {
    std::string doc = dae(geometries(tri_geometry()), node("n", "", "tri"));
    // Put an empty visual scene first; <scene> still points at "S".
    doc.replace(doc.find("<library_visual_scenes>"), std::string("<library_visual_scenes>").size(),
                "<library_visual_scenes><visual_scene id=\"other\"/>");
    const Scene s = load(doc);
    EXPECT_EQ(s.meshes.size(), 1u);
}

// ---------------------------------------------------------------------------------------
// Bad input: one test per class. Every message starts with the file name and names the
// offending element (tag and id) or line.

std::string error_of(const std::string& doc, const std::string& name = "bad.dae") {
    try {
        scenes::load_collada_memory(doc.data(), doc.size(), name);
    } catch (const SceneError& e) {
        return e.what();
    }
    ADD_FAILURE() << "expected a SceneError";
    return {};
}

#define EXPECT_ERROR(doc, ...)                                                          \
    do {                                                                                \
        const std::string msg_ = error_of(doc);                                         \
        EXPECT_EQ(msg_.rfind("bad.dae", 0), 0u) << msg_;                                \
        for (const char* needle_ : std::initializer_list<const char*>{__VA_ARGS__})     \
            EXPECT_NE(msg_.find(needle_), std::string::npos) << "'" << needle_ << "' not in: " << msg_; \
    } while (0)

// <orthographic>: any two of xmag, ymag (half extents) and aspect_ratio; a zero one, or
// neither magnification, is refused naming the element.
TEST(ColladaScene, OrthographicCameraKeepsItsExtents) {
    const auto with = [](const std::string& optics) {
        return dae(geometries(tri_geometry()) + "<library_cameras><camera id=\"cam\"><optics><technique_common>"
                   "<orthographic>" + optics + "</orthographic></technique_common></optics></camera></library_cameras>",
                   node("n", "", "tri") + "<node id=\"C\"><translate>0 0 9</translate><instance_camera url=\"#cam\"/></node>");
    };
    const Scene s = load(with("<xmag>4</xmag><aspect_ratio>2</aspect_ratio><znear>0.1</znear><zfar>100</zfar>"));
    ASSERT_TRUE(s.camera.has_value());
    EXPECT_TRUE(s.camera->orthographic);
    EXPECT_EQ(s.camera->xmag, 4.0f);
    EXPECT_EQ(s.camera->ymag, 2.0f);
    expect_near(s.camera->camera_to_world.transform_point({0, 0, 0}), {0, 0, 9});
    const Scene y = load(with("<ymag>3</ymag>"));
    EXPECT_EQ(y.camera->ymag, 3.0f);
    EXPECT_EQ(y.camera->xmag, 0.0f) << "the renderer derives it from the image";
    EXPECT_ERROR(with("<xmag>0</xmag>"), "<xmag>", "must not be zero");
    EXPECT_ERROR(with("<aspect_ratio>2</aspect_ratio>"), "<orthographic>", "neither <xmag> nor <ymag>");
}

TEST(ColladaErrors, MalformedXmlNamesTheLine) {
    EXPECT_ERROR("<?xml version=\"1.0\"?>\n<COLLADA>\n<asset>\n</COLLADA>\n", "bad.dae:4:", "malformed XML");
    EXPECT_ERROR(std::string(), "malformed XML");
    EXPECT_ERROR(std::string("<COLLADA>\0</COLLADA>", 20), "malformed XML");
}

TEST(ColladaErrors, NotACollada) {
    EXPECT_ERROR("<?xml version=\"1.0\"?>\n<svg/>", "<svg>", "not a COLLADA");
}

TEST(ColladaErrors, MissingOrUnreadableFile) {
    const std::string missing = std::string(PT_BINARY_DIR) + "/no/such/file.dae";
    try {
        scenes::load_collada(missing);
        ADD_FAILURE() << "expected a SceneError";
    } catch (const SceneError& e) {
        EXPECT_EQ(std::string(e.what()).rfind(missing, 0), 0u) << e.what();
    }
    try {
        scenes::load_collada(PT_BINARY_DIR);
        ADD_FAILURE() << "expected a SceneError";
    } catch (const SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("directory"), std::string::npos) << e.what();
    }
}

TEST(ColladaErrors, FileErrorsCarryThePathAndLine) {
    const std::string path = std::string(PT_BINARY_DIR) + "/collada_memory_test_bad.dae";
    {
        std::ofstream out(path);
        out << dae(geometries(tri_geometry()), node("n", "<matrix>1 0 0 x 0 1 0 0 0 0 1 0 0 0 0 1</matrix>", "tri"));
    }
    try {
        scenes::load_collada(path);
        ADD_FAILURE() << "expected a SceneError";
    } catch (const SceneError& e) {
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind(path + ":", 0), 0u) << msg;
        EXPECT_NE(msg.find("<matrix>"), std::string::npos) << msg;
        EXPECT_NE(msg.find("'x' is not a number"), std::string::npos) << msg;
    }
    std::filesystem::remove(path);
}

TEST(ColladaErrors, DanglingReferences) {
    const std::string n = node("n", "", "tri");
    // <input source> to a missing <vertices>.
    std::string g = tri_geometry();
    g.replace(g.find("#tri-vtx"), 8, "#nowhere");
    EXPECT_ERROR(dae(geometries(g), n), "<input>", "tri", "#nowhere");
    // <vertices> POSITION to a missing <source>.
    g = tri_geometry();
    g.replace(g.find("source=\"#tri-pos\""), 17, "source=\"#nosrc\"");
    EXPECT_ERROR(dae(geometries(g), n), "<input>", "id=\"tri-vtx\"", "#nosrc");
    // <accessor source> to a missing <float_array>.
    g = tri_geometry();
    g.replace(g.find("#tri-pos-array"), 14, "#noarray");
    EXPECT_ERROR(dae(geometries(g), n), "<accessor>", "tri-pos", "#noarray");
    // instance_geometry url.
    EXPECT_ERROR(dae(geometries(tri_geometry()), node("n", "", "ghost")), "<instance_geometry>",
                 "id=\"n\"", "#ghost");
    // instance_material target.
    EXPECT_ERROR(dae(geometries(tri_geometry("M")), node("n", "", "tri", bind("M", "nomat"))),
                 "<instance_material>", "#nomat");
    // instance_effect url.
    std::string mat = material("m", "1 1 1");
    mat.replace(mat.find("#m-fx"), 5, "#nofx");
    EXPECT_ERROR(dae(geometries(tri_geometry("M")) + mat, node("n", "", "tri", bind("M", "m"))),
                 "<instance_effect>", "id=\"m\"", "#nofx");
    // instance_node url.
    EXPECT_ERROR(dae(geometries(tri_geometry()), n + "<node id=\"k\"><instance_node url=\"#nonode\"/></node>"),
                 "<instance_node>", "id=\"k\"", "#nonode");
    // A url that exists but names the wrong kind of element.
    EXPECT_ERROR(dae(geometries(tri_geometry()) + material("m", "1 1 1"), node("n", "", "m")),
                 "<instance_geometry>", "refers to a <material>", "expected a <geometry>");
    // instance_light / instance_camera.
    EXPECT_ERROR(dae(geometries(tri_geometry()), n + "<node id=\"L\"><instance_light url=\"#nolight\"/></node>"),
                 "<instance_light>", "#nolight");
    EXPECT_ERROR(dae(geometries(tri_geometry()), n + "<node id=\"C\"><instance_camera url=\"#nocam\"/></node>"),
                 "<instance_camera>", "#nocam");
}

TEST(ColladaErrors, IndexOutOfRange) {
    const std::string g = geometry("g", "0 0 0 1 0 0 0 1 0", 3,
                                   "<triangles count=\"1\">" + inputs("g") + "<p>0 1 7</p></triangles>");
    EXPECT_ERROR(dae(geometries(g), node("n", "", "g")), "<triangles>", "id=\"g\"", "index 7 out of range");
    const std::string gn = geometry("g", "0 0 0 1 0 0 0 1 0", 3,
                                    "<triangles count=\"1\">" + inputs("g", true) +
                                        "<p>0 0 1 0 2 5</p></triangles>",
                                    "0 0 1", 1);
    EXPECT_ERROR(dae(geometries(gn), node("n", "", "g")), "normal index 5 out of range");
}

TEST(ColladaErrors, AccessorCountLargerThanTheArray) {
    std::string g = tri_geometry();
    g.replace(g.find("count=\"3\" stride"), 9, "count=\"4\"");
    EXPECT_ERROR(dae(geometries(g), node("n", "", "tri")), "<accessor>", "tri-pos", "holds 9");
    // A huge claimed count must fail on the check, not on an allocation.
    g = tri_geometry();
    g.replace(g.find("count=\"3\" stride"), 9, "count=\"4000000000\"");
    EXPECT_ERROR(dae(geometries(g), node("n", "", "tri")), "<accessor>", "4000000000");
}

TEST(ColladaErrors, FloatArrayCountDisagreesWithItsContent) {
    std::string g = tri_geometry();
    g.replace(g.find("count=\"9\""), 9, "count=\"4000000000\"");
    EXPECT_ERROR(dae(geometries(g), node("n", "", "tri")), "<float_array id=\"tri-pos-array\">",
                 "holds 9 numbers");
}

TEST(ColladaErrors, NonNumericOrNonFiniteNumbers) {
    const std::string n = node("n", "", "tri");
    for (const char* bad : {"abc", "nan", "inf", "-inf", "1e999", "0x10", "1.0.0", "--1"}) {
        SCOPED_TRACE(bad);
        std::string g = tri_geometry();
        g.replace(g.find("0 0 0 1 0 0"), 1, bad);
        EXPECT_ERROR(dae(geometries(g), n), "<float_array id=\"tri-pos-array\">", bad);
        EXPECT_ERROR(dae(geometries(tri_geometry()),
                         node("m", std::string("<matrix>1 0 0 ") + bad + " 0 1 0 0 0 0 1 0 0 0 0 1</matrix>", "tri")),
                     "<matrix> in <node id=\"m\">", bad);
    }
    EXPECT_ERROR(dae(geometries(tri_geometry()), node("m", "<translate>1 2</translate>", "tri")),
                 "<translate> in <node id=\"m\">", "needs 3 numbers, has 2");
    EXPECT_ERROR(dae(geometries(tri_geometry()),
                     node("m", "<matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 5</matrix>", "tri")),
                 "<matrix>", "needs 16 numbers, has 17");
    // Short matrices are only tolerated on camera-only nodes (see CBgems.dae).
    EXPECT_ERROR(dae(geometries(tri_geometry()),
                     node("m", "<matrix>1 0 0 0 0 1 0 0 0 0 1 0 0 0 0</matrix>", "tri")),
                 "<matrix>", "needs 16 numbers, has 15");
    // Indices are unsigned integers.
    std::string g = tri_geometry();
    g.replace(g.find("<p>0 1 2"), 8, "<p>0 -1 2");
    EXPECT_ERROR(dae(geometries(g), n), "<p>", "'-1' is not a valid index");
}

TEST(ColladaErrors, IndexListLengthMismatch) {
    const auto poly = [](const std::string& vcount, const std::string& p, const std::string& count) {
        return dae(geometries(geometry("g", "0 0 0 1 0 0 1 1 0 0 1 0", 4,
                                       "<polylist count=\"" + count + "\">" + inputs("g") +
                                           "<vcount>" + vcount + "</vcount><p>" + p + "</p></polylist>")),
                   node("n", "", "g"));
    };
    EXPECT_ERROR(poly("4", "0 1 2", "1"), "<polylist>", "id=\"g\"", "<vcount> sums to 4");
    EXPECT_ERROR(poly("3 3", "0 1 2", "2"), "<polylist>", "holds 3");
    EXPECT_ERROR(poly("3", "0 1 2", "2"), "<polylist>", "count=\"2\"", "lists 1");
    EXPECT_ERROR(poly("3", "0 1 2", "4000000000"), "<polylist>", "4000000000");
    EXPECT_ERROR(poly("4000000000", "0 1 2", "1"), "<polylist>", "sums to 4000000000");
    const std::string t = geometry("g", "0 0 0 1 0 0 0 1 0", 3,
                                   "<triangles count=\"2\">" + inputs("g") + "<p>0 1 2</p></triangles>");
    EXPECT_ERROR(dae(geometries(t), node("n", "", "g")), "<triangles>", "count=\"2\" needs 6");
    const std::string t2 = geometry("g", "0 0 0 1 0 0 0 1 0", 3,
                                    "<triangles>" + inputs("g", false) + "<p>0 1 2 0</p></triangles>");
    EXPECT_ERROR(dae(geometries(t2), node("n", "", "g")), "<triangles>", "not a multiple of 3");
}

TEST(ColladaErrors, AbsurdValues) {
    for (const char* r : {"-1", "0"}) {
        const std::string libs = geometries(
            std::string("<geometry id=\"ball\"><extra><technique profile=\"CGL\"><sphere><radius>") + r +
            "</radius></sphere></technique></extra></geometry>");
        EXPECT_ERROR(dae(libs, node("n", "", "ball")), "<radius> in <geometry id=\"ball\">", "must be positive");
    }
    const std::string ball = geometries(
        "<geometry id=\"ball\"><extra><technique profile=\"CGL\"><sphere><radius>1</radius>"
        "</sphere></technique></extra></geometry>");
    EXPECT_ERROR(dae(ball, node("flat", "<scale>1 1 0</scale>", "ball")), "<node id=\"flat\">", "singular");
    // Negative colour.
    EXPECT_ERROR(dae(geometries(tri_geometry("M")) + material("m", "1 -1 1"), node("n", "", "tri", bind("M", "m"))),
                 "<color>", "m-fx", "negative");
    // An input offset that would make a gigantic stride.
    std::string g = tri_geometry();
    g.replace(g.find("offset=\"0\""), 10, "offset=\"4000000000\"");
    EXPECT_ERROR(dae(geometries(g), node("n", "", "tri")), "<input>", "absurd");
    // Camera fov outside (0, 180).
    const std::string cam = R"(<library_cameras><camera id="cam"><optics><technique_common><perspective>
  <xfov>270</xfov></perspective></technique_common></optics></camera></library_cameras>)";
    EXPECT_ERROR(dae(geometries(tri_geometry()) + cam,
                     node("n", "", "tri") + "<node id=\"C\"><instance_camera url=\"#cam\"/></node>"),
                 "<xfov>", "cam", "270");
}

TEST(ColladaErrors, InstanceNodeCycleAndExplosionAreBounded) {
    const std::string lib = geometries(tri_geometry()) +
                            "<library_nodes><node id=\"loop\"><instance_node url=\"#loop\"/></node></library_nodes>";
    EXPECT_ERROR(dae(lib, "<node id=\"root\"><instance_node url=\"#loop\"/></node>" + node("n", "", "tri")),
                 "<node id=\"loop\">", "deeper than");
    // 2^40 instances through 40 levels of doubling: must stop on the visit budget.
    std::string nodes = "<library_nodes>" + node("l0", "", "tri");
    for (int i = 1; i <= 40; ++i)
        nodes += "<node id=\"l" + std::to_string(i) + "\"><instance_node url=\"#l" + std::to_string(i - 1) +
                 "\"/><instance_node url=\"#l" + std::to_string(i - 1) + "\"/></node>";
    nodes += "</library_nodes>";
    EXPECT_ERROR(dae(geometries(tri_geometry()) + nodes, "<node id=\"r\"><instance_node url=\"#l40\"/></node>"),
                 "more than");
}

TEST(ColladaErrors, EmptyScene) {
    EXPECT_ERROR(dae(geometries(tri_geometry()), ""), "empty scene", "id=\"S\"");
    EXPECT_ERROR(dae("", "<node id=\"n\"/>"), "empty scene");
    EXPECT_ERROR("<COLLADA/>", "empty scene", "no <visual_scene>");
}

TEST(ColladaErrors, MissingRequiredParts) {
    // A primitive with no VERTEX input, a vertices element with no POSITION.
    const std::string noverts = geometry("g", "0 0 0 1 0 0 0 1 0", 3,
                                         "<triangles count=\"1\"><input semantic=\"NORMAL\" source=\"#g-pos\" "
                                         "offset=\"0\"/><p>0 1 2</p></triangles>");
    EXPECT_ERROR(dae(geometries(noverts), node("n", "", "g")), "<triangles>", "id=\"g\"", "no VERTEX input");
    std::string g = tri_geometry();
    g.replace(g.find("POSITION"), 8, "FOO");
    EXPECT_ERROR(dae(geometries(g), node("n", "", "tri")), "<vertices id=\"tri-vtx\">", "no POSITION");
}

}  // namespace
