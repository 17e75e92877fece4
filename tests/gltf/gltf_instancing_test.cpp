// glTF instancing: a mesh the scene places more than once (several nodes referencing it,
// glTF 2.0 spec 3.5) loads as one object-space Prototype and one Instance per placement,
// whose transform is the composed node hierarchy; a mesh placed once is loaded in world
// space as before. Checked against a twin file whose nodes each reference their own copy
// of the mesh (same accessors): every mesh of the twin is placed once, so it loads exactly
// as the loader did before instancing, and flatten_instances of the instanced file must
// give the same triangles.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "scenes/gltf/gltf.h"

namespace {

using scenes::Scene;
using scenes::Vec3f;

std::string base64(const std::vector<uint8_t>& in) {
    static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < in.size(); i += 3) {
        const uint32_t n = (uint32_t(in[i]) << 16) | (i + 1 < in.size() ? uint32_t(in[i + 1]) << 8 : 0u) |
                           (i + 2 < in.size() ? uint32_t(in[i + 2]) : 0u);
        out += k[(n >> 18) & 63];
        out += k[(n >> 12) & 63];
        out += i + 1 < in.size() ? k[(n >> 6) & 63] : '=';
        out += i + 2 < in.size() ? k[n & 63] : '=';
    }
    return out;
}

/// A tetrahedron with (deliberately not unit) normals: accessors 0 (POSITION), 1 (NORMAL),
/// 2 (indices). `meshes` mesh entries all use them; `nodes` is the JSON of the node list,
/// and the scene's roots are `roots`.
std::string doc(const std::string& nodes, const std::string& roots, int meshes = 1) {
    const float pos[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
    const float nrm[] = {-1, -1, -1, 0, 0, -2, 0, -3, 0, 4, 4, 4};
    const uint16_t idx[] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    std::vector<uint8_t> bytes(sizeof pos + sizeof nrm + sizeof idx);
    std::memcpy(bytes.data(), pos, sizeof pos);
    std::memcpy(bytes.data() + sizeof pos, nrm, sizeof nrm);
    std::memcpy(bytes.data() + sizeof pos + sizeof nrm, idx, sizeof idx);
    std::string mesh_list;
    for (int i = 0; i < meshes; ++i)
        mesh_list += std::string(i ? "," : "") + R"({"name":"tet","primitives":[{"attributes":{"POSITION":0,"NORMAL":1},"indices":2}]})";
    return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[)" + roots + R"(]}],"nodes":[)" + nodes +
           R"(],"meshes":[)" + mesh_list +
           R"(],"accessors":[{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,1]},)"
           R"({"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"},)"
           R"({"bufferView":2,"componentType":5123,"count":12,"type":"SCALAR"}],)"
           R"("bufferViews":[{"buffer":0,"byteLength":48},{"buffer":0,"byteOffset":48,"byteLength":48},)"
           R"({"buffer":0,"byteOffset":96,"byteLength":24}],)"
           R"("buffers":[{"byteLength":120,"uri":"data:application/octet-stream;base64,)" +
           base64(bytes) + R"("}]})";
}

Scene load(const std::string& text, const scenes::GltfLimits& limits = {}) {
    return scenes::load_gltf_memory(text.data(), text.size(), "inst.gltf", "/nonexistent", false, limits);
}

bool has_note(const Scene& s, const std::string& a, const std::string& b = "") {
    for (const std::string& n : s.notes)
        if (n.find(a) != std::string::npos && n.find(b) != std::string::npos) return true;
    return false;
}

// ---- the expected transforms, in double, independently of the loader --------------

struct M {
    double m[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    M operator*(const M& o) const {
        M r;
        for (int i = 0; i < 4; ++i)
            for (int j = 0; j < 4; ++j) {
                r.m[i][j] = 0;
                for (int k = 0; k < 4; ++k) r.m[i][j] += m[i][k] * o.m[k][j];
            }
        return r;
    }
};

/// T * R * S of a glTF node (spec 3.5.3: TRS properties compose as T * R * S).
M trs(const double t[3], const double q[4], const double s[3]) {
    const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    const double x = q[0] / len, y = q[1] / len, z = q[2] / len, w = q[3] / len;
    M r;
    const double rot[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                              {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                              {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) r.m[i][j] = rot[i][j] * s[j];
        r.m[i][3] = t[i];
    }
    return r;
}

std::string list(const double* v, int n) {
    std::string o = "[";
    char buf[64];
    for (int k = 0; k < n; ++k) {
        std::snprintf(buf, sizeof buf, "%.17g", v[k]);
        if (k) o += ",";  // not "," + std::string: GCC 12's -Wrestrict misfires on it
        o += buf;
    }
    return o + "]";
}

/// Each row of `a` within 1e-6 of `e` relative to the largest entry of `e`'s row (an
/// entry near zero by cancellation has no meaningful relative error of its own).
void expect_transform(const scenes::Affine3f& a, const M& e, const std::string& what) {
    for (int i = 0; i < 3; ++i) {
        double scale = 0;
        for (int j = 0; j < 4; ++j) scale = std::max(scale, std::fabs(e.m[i][j]));
        for (int j = 0; j < 4; ++j)
            EXPECT_NEAR(a.m[i][j], e.m[i][j], 1e-6 * scale) << what << " entry " << i << "," << j;
    }
}

// A parent turned about a tilted axis and scaled non-uniformly, moved; under it three
// nodes place the mesh: one moved, one turned and mirrored (scale -1 on y), one by a
// sheared matrix. The twin gives each its own mesh entry.
const double kParentT[3] = {1, 2, 3}, kParentR[4] = {0.2, 0.4, 0.1, 0.9}, kParentS[3] = {2, 0.5, 3};
const double kT1[3] = {5, 0, 0}, kR1[4] = {0, 0, 0, 1}, kS1[3] = {1, 1, 1};
const double kT2[3] = {0, -4, 1}, kR2[4] = {0.7, 0, 0.7, 0.3}, kS2[3] = {1.5, -1, 0.25};
// Column-major (glTF): x' = x + 0.5 y, y' = 2 y, z' = z - 0.25 x, translated by (1, 1, -2).
const double kMatrix3[16] = {1, 0, -0.25, 0, 0.5, 2, 0, 0, 0, 0, 1, 0, 1, 1, -2, 1};

std::string three_nodes(bool twin, const std::string& extra_child = "") {
    const std::string m1 = twin ? "1" : "0", m2 = twin ? "2" : "0";
    return R"({"name":"parent","translation":)" + list(kParentT, 3) + R"(,"rotation":)" + list(kParentR, 4) +
           R"(,"scale":)" + list(kParentS, 3) + R"(,"children":[1,2,3)" + (extra_child.empty() ? "" : ",4") + "]}," +
           R"({"name":"a","mesh":0,"translation":)" + list(kT1, 3) + "}," +
           R"({"name":"b","mesh":)" + m1 + R"(,"translation":)" + list(kT2, 3) + R"(,"rotation":)" + list(kR2, 4) +
           R"(,"scale":)" + list(kS2, 3) + "}," +
           R"({"name":"c","mesh":)" + m2 + R"(,"matrix":)" + list(kMatrix3, 16) + "}" +
           (extra_child.empty() ? "" : "," + extra_child);
}

M column_major(const double* v) {
    M r;
    for (int c = 0; c < 4; ++c)
        for (int row = 0; row < 4; ++row) r.m[row][c] = v[c * 4 + row];
    return r;
}

TEST(GltfInstancing, OneMeshUnderThreeNodesIsOnePrototypeAndThreeInstances) {
    const Scene s = load(doc(three_nodes(false), "0"));
    ASSERT_EQ(s.prototypes.size(), 1u);
    ASSERT_EQ(s.instances.size(), 3u);
    ASSERT_EQ(s.meshes.size(), 1u) << "the mesh is stored once";
    EXPECT_EQ(s.prototypes[0].first_mesh, 0u);
    EXPECT_EQ(s.prototypes[0].num_meshes, 1u);
    EXPECT_EQ(s.prototypes[0].name, "tet");
    // Object space: positions as the file gives them, normals unit but not turned.
    const scenes::Mesh& m = s.meshes[0];
    ASSERT_EQ(m.num_vertices(), 4u);
    EXPECT_EQ(m.positions[3].z, 1.0f);
    EXPECT_EQ(m.positions[1].x, 1.0f);
    ASSERT_EQ(m.normals.size(), 4u);
    EXPECT_NEAR(m.normals[1].z, -1.0f, 1e-7f);
    EXPECT_NEAR(m.normals[3].x, 1.0f / std::sqrt(3.0f), 1e-7f);
    EXPECT_EQ(s.num_triangles(), 4u);
    EXPECT_EQ(s.instanced_triangles(), 12u);
    EXPECT_EQ(s.world_triangles(), 0u);

    const M parent = trs(kParentT, kParentR, kParentS);
    const M expected[3] = {parent * trs(kT1, kR1, kS1), parent * trs(kT2, kR2, kS2), parent * column_major(kMatrix3)};
    for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(s.instances[size_t(i)].prototype, 0u);
        expect_transform(s.instances[size_t(i)].object_to_world, expected[i], "instance " + std::to_string(i));
    }
    EXPECT_GT(s.instances[0].object_to_world.det(), 0.0);
    EXPECT_LT(s.instances[1].object_to_world.det(), 0.0) << "the mirrored placement is kept";
    EXPECT_TRUE(has_note(s, "instancing: 3 nodes place 3 instances of 1 mesh")) << s.notes.size();
}

TEST(GltfInstancing, FlattenedInstancesAreWhatTheLoaderMadeBeforeInstancing) {
    Scene inst = load(doc(three_nodes(false), "0"));
    const Scene twin = load(doc(three_nodes(true), "0", 3));
    ASSERT_TRUE(twin.prototypes.empty()) << "each twin mesh is placed once";
    ASSERT_EQ(twin.meshes.size(), 3u);
    scenes::flatten_instances(inst);
    ASSERT_TRUE(inst.prototypes.empty());
    ASSERT_TRUE(inst.instances.empty());
    ASSERT_EQ(inst.meshes.size(), 3u);
    EXPECT_EQ(inst.num_triangles(), twin.num_triangles());
    for (size_t i = 0; i < 3; ++i) {
        SCOPED_TRACE("placement " + std::to_string(i));
        const scenes::Mesh &a = inst.meshes[i], &b = twin.meshes[i];
        // Same winding (the mirror swaps it in both), bit-identical positions: Affine3f's
        // point() is Mat4f::transform_point's arithmetic on the same matrix.
        EXPECT_EQ(a.indices, b.indices);
        ASSERT_EQ(a.positions.size(), b.positions.size());
        for (uint32_t v = 0; v < a.num_vertices(); ++v) {
            EXPECT_EQ(a.positions[v].x, b.positions[v].x);
            EXPECT_EQ(a.positions[v].y, b.positions[v].y);
            EXPECT_EQ(a.positions[v].z, b.positions[v].z);
        }
        // Normals: the inverse transpose, from a double inverse here and a float one
        // there.
        ASSERT_EQ(a.normals.size(), b.normals.size());
        for (size_t v = 0; v < a.normals.size(); ++v) {
            EXPECT_NEAR(a.normals[v].x, b.normals[v].x, 1e-5f);
            EXPECT_NEAR(a.normals[v].y, b.normals[v].y, 1e-5f);
            EXPECT_NEAR(a.normals[v].z, b.normals[v].z, 1e-5f);
        }
        EXPECT_EQ(a.material, b.material);
    }
    EXPECT_NE(inst.meshes[1].indices, inst.meshes[0].indices) << "the mirrored copy's winding is swapped";
}

TEST(GltfInstancing, AMeshPlacedOnceStaysInWorldSpace) {
    // Two meshes, one node each: nothing is shared, nothing is instanced.
    const std::string nodes = R"({"mesh":0,"translation":[1,0,0]},{"mesh":1,"scale":[2,2,2]})";
    const Scene s = load(doc(nodes, "0,1", 2));
    EXPECT_TRUE(s.prototypes.empty());
    EXPECT_TRUE(s.instances.empty());
    ASSERT_EQ(s.meshes.size(), 2u);
    EXPECT_EQ(s.meshes[0].positions[0].x, 1.0f);
    EXPECT_EQ(s.meshes[1].positions[3].z, 2.0f);
    for (const std::string& n : s.notes) EXPECT_EQ(n.find("instanc"), std::string::npos) << n;
}

TEST(GltfInstancing, SingularPlacementIsDroppedWithANoteNamingTheNode) {
    const Scene s = load(doc(three_nodes(false, R"({"name":"flat","mesh":0,"scale":[1,0,1]})"), "0"));
    ASSERT_EQ(s.prototypes.size(), 1u);
    EXPECT_EQ(s.instances.size(), 3u);
    EXPECT_TRUE(has_note(s, "node 4 ('flat')", "dropped"));
}

TEST(GltfInstancing, AllPlacementsSingularLeavesNothingToRender) {
    const std::string nodes = R"({"mesh":0,"scale":[0,1,1]},{"mesh":0,"scale":[1,1,0]})";
    EXPECT_THROW(load(doc(nodes, "0,1")), scenes::SceneError);
}

TEST(GltfInstancing, InstancesAndUniqueGeometryHaveTheirOwnLimits) {
    scenes::GltfLimits few;
    few.max_instances = 2;
    try {
        load(doc(three_nodes(false), "0"), few);
        FAIL() << "a third instance was accepted past a limit of 2";
    } catch (const scenes::SceneError& e) {
        const std::string m = e.what();
        EXPECT_EQ(m.rfind("inst.gltf: node 3 ('c')", 0), 0u) << m;
        EXPECT_NE(m.find("more than 2 instances"), std::string::npos) << m;
    }
    // Unique geometry counts once: the tetrahedron decodes to 4 + 3 * 12 elements and
    // stores 4 + 12 + 4; three flattened copies would store 60, the twin decodes it three
    // times.
    scenes::GltfLimits small;
    small.max_elements = 50;
    EXPECT_EQ(load(doc(three_nodes(false), "0"), small).instances.size(), 3u);
    EXPECT_THROW(load(doc(three_nodes(true), "0", 3), small), scenes::SceneError);
}

}  // namespace
