// Small glTF documents built in memory (JSON + base64 data-URI buffers): one feature or
// one class of bad input per test.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "renderer/texture.h"
#include "scenes/gltf/gltf.h"

namespace {

using scenes::Scene;
using scenes::SceneError;
using scenes::Vec3f;

std::string base64(const std::vector<uint8_t>& in) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    size_t i = 0;
    for (; i + 2 < in.size(); i += 3) {
        uint32_t v = (uint32_t(in[i]) << 16) | (uint32_t(in[i + 1]) << 8) | in[i + 2];
        for (int k = 3; k >= 0; --k) out += t[(v >> (6 * k)) & 63];
    }
    if (i + 1 == in.size()) {
        uint32_t v = uint32_t(in[i]) << 16;
        out += t[(v >> 18) & 63];
        out += t[(v >> 12) & 63];
        out += "==";
    } else if (i + 2 == in.size()) {
        uint32_t v = (uint32_t(in[i]) << 16) | (uint32_t(in[i + 1]) << 8);
        out += t[(v >> 18) & 63];
        out += t[(v >> 12) & 63];
        out += t[(v >> 6) & 63];
        out += '=';
    }
    return out;
}

uint32_t crc32(const uint8_t* p, size_t n) {
    uint32_t c = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return ~c;
}

/// Minimal RGB8 PNG (zlib "stored" blocks), enough to give the loader a real image.
std::vector<uint8_t> make_png(uint32_t w, uint32_t h, const std::vector<uint8_t>& rgb) {
    std::vector<uint8_t> raw;
    for (uint32_t y = 0; y < h; ++y) {
        raw.push_back(0);
        raw.insert(raw.end(), rgb.begin() + ptrdiff_t(y * w * 3), rgb.begin() + ptrdiff_t((y + 1) * w * 3));
    }
    std::vector<uint8_t> z = {0x78, 0x01, 0x01, uint8_t(raw.size()), uint8_t(raw.size() >> 8),
                              uint8_t(~raw.size()), uint8_t(~raw.size() >> 8)};
    z.insert(z.end(), raw.begin(), raw.end());
    uint32_t a = 1, b = 0;
    for (uint8_t c : raw) {
        a = (a + c) % 65521;
        b = (b + a) % 65521;
    }
    uint32_t adler = (b << 16) | a;
    for (int k = 3; k >= 0; --k) z.push_back(uint8_t(adler >> (8 * k)));
    std::vector<uint8_t> png = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    auto chunk = [&](const char* type, const std::vector<uint8_t>& data) {
        for (int k = 3; k >= 0; --k) png.push_back(uint8_t(data.size() >> (8 * k)));
        size_t start = png.size();
        png.insert(png.end(), type, type + 4);
        png.insert(png.end(), data.begin(), data.end());
        uint32_t c = crc32(png.data() + start, png.size() - start);
        for (int k = 3; k >= 0; --k) png.push_back(uint8_t(c >> (8 * k)));
    };
    std::vector<uint8_t> ihdr;
    for (int k = 3; k >= 0; --k) ihdr.push_back(uint8_t(w >> (8 * k)));
    for (int k = 3; k >= 0; --k) ihdr.push_back(uint8_t(h >> (8 * k)));
    ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});
    chunk("IHDR", ihdr);
    chunk("IDAT", z);
    chunk("IEND", {});
    return png;
}

/// Accumulates binary data, bufferViews and accessors; the test writes the rest of the
/// JSON by hand so each test reads like the file it describes.
struct Doc {
    std::vector<uint8_t> bin;
    std::vector<std::string> views, accessors;

    int view(const void* p, size_t n, size_t stride = 0) {
        while (bin.size() % 4) bin.push_back(0);
        size_t off = bin.size();
        const auto* b = static_cast<const uint8_t*>(p);
        bin.insert(bin.end(), b, b + n);
        views.push_back("{\"buffer\":0,\"byteOffset\":" + std::to_string(off) + ",\"byteLength\":" +
                        std::to_string(n) + (stride ? ",\"byteStride\":" + std::to_string(stride) : "") + "}");
        return int(views.size()) - 1;
    }
    int accessor(int view, int ct, size_t count, const std::string& type, const std::string& extra = "") {
        accessors.push_back("{" + (view >= 0 ? "\"bufferView\":" + std::to_string(view) + "," : std::string()) +
                            "\"componentType\":" + std::to_string(ct) + ",\"count\":" +
                            std::to_string(count) + ",\"type\":\"" + type + "\"" + extra + "}");
        return int(accessors.size()) - 1;
    }
    template <class T>
    int data(const std::vector<T>& v, int ct, size_t ncomp, const std::string& type, const std::string& extra = "") {
        return accessor(view(v.data(), v.size() * sizeof(T)), ct, v.size() / ncomp, type, extra);
    }
    int vec3(const std::vector<float>& v) { return data(v, 5126, 3, "VEC3"); }
    int u16(const std::vector<uint16_t>& v) { return data(v, 5123, 1, "SCALAR"); }

    std::string buffers() const {
        return "\"buffers\":[{\"byteLength\":" + std::to_string(bin.size()) +
               ",\"uri\":\"data:application/octet-stream;base64," + base64(bin) + "\"}]";
    }
    static std::string join(const std::vector<std::string>& v) {
        std::string s;
        for (const auto& x : v) s += (s.empty() ? "" : ",") + x;
        return s;
    }
    /// Full document: `rest` holds scenes/nodes/meshes/... members (no trailing comma).
    std::string json(const std::string& rest) const {
        return "{\"asset\":{\"version\":\"2.0\"}," + buffers() + ",\"bufferViews\":[" + join(views) +
               "],\"accessors\":[" + join(accessors) + "]," + rest + "}";
    }
};

Scene load(const std::string& json, const std::string& name = "test.gltf", const std::string& dir = "") {
    return scenes::load_gltf_memory(json.data(), json.size(), name, dir, false);
}

/// Expects SceneError whose message starts with the file name and contains every needle.
void expect_error(const std::string& json, std::vector<std::string> needles, const std::string& name = "bad.gltf",
                  bool binary = false) {
    try {
        scenes::load_gltf_memory(json.data(), json.size(), name, "", binary);
        ADD_FAILURE() << "no SceneError; expected one containing " << needles[0];
    } catch (const SceneError& e) {
        std::string msg = e.what();
        EXPECT_EQ(msg.rfind(name + ": ", 0), 0u) << msg;
        for (const auto& n : needles) EXPECT_NE(msg.find(n), std::string::npos) << "'" << n << "' not in: " << msg;
    }
}

bool has_note(const Scene& s, const std::string& needle) {
    for (const auto& n : s.notes)
        if (n.find(needle) != std::string::npos) return true;
    return false;
}

void expect_vec(const Vec3f& a, const Vec3f& b, float eps = 1e-5f) {
    EXPECT_NEAR(a.x, b.x, eps);
    EXPECT_NEAR(a.y, b.y, eps);
    EXPECT_NEAR(a.z, b.z, eps);
}

// One triangle (1,0,0), (0,1,0), (0,0,0); index 0 = positions, 1 = indices.
Doc triangle_doc() {
    Doc d;
    d.vec3({1, 0, 0, 0, 1, 0, 0, 0, 0});
    d.u16({0, 1, 2});
    return d;
}
const std::string kTriMesh = "\"meshes\":[{\"name\":\"M\",\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}]";

// ------------------------------------------------------------------------------------
// Transforms

TEST(GltfTransforms, TrsParentChildOrder) {
    Doc d = triangle_doc();
    // Parent translates; child scales by 2 then rotates +90 deg about Z (quaternion).
    const double s = std::sqrt(0.5);
    std::string j = d.json(kTriMesh + ",\"scenes\":[{\"nodes\":[0]}],\"nodes\":[" +
                           "{\"translation\":[10,0,0],\"children\":[1]}," +
                           "{\"mesh\":0,\"scale\":[2,2,2],\"rotation\":[0,0," + std::to_string(s) + "," +
                           std::to_string(s) + "]}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.meshes.size(), 1u);
    // (1,0,0) -> S (2,0,0) -> R (0,2,0) -> T (10,2,0): T*R*S, parent after child.
    expect_vec(sc.meshes[0].positions[0], {10, 2, 0});
    expect_vec(sc.meshes[0].positions[1], {8, 0, 0});
    expect_vec(sc.meshes[0].positions[2], {10, 0, 0});
    EXPECT_EQ(sc.meshes[0].positions.size(), 4u) << "padding element";
}

TEST(GltfTransforms, MatrixIsColumnMajorAndEqualsTrs) {
    Doc d = triangle_doc();
    // Column-major: translation (5,6,7) in elements 12..14; +90 deg about Z, scale 2.
    std::string j = d.json(kTriMesh + ",\"scenes\":[{\"nodes\":[0]}],\"nodes\":[" +
                           "{\"mesh\":0,\"matrix\":[0,2,0,0, -2,0,0,0, 0,0,2,0, 5,6,7,1]}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.meshes.size(), 1u);
    expect_vec(sc.meshes[0].positions[0], {5, 8, 7});
    expect_vec(sc.meshes[0].positions[1], {3, 6, 7});
}

TEST(GltfTransforms, NormalsUseInverseTransposeAndAreUnit) {
    Doc d;
    d.vec3({0, 0, 0, 1, 0, 0, 0, 1, 0});
    float r = std::sqrt(0.5f);
    d.vec3({r, r, 0, r, r, 0, r, r, 0});
    std::string j = d.json(
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"NORMAL\":1}}]}],"
        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,\"scale\":[2,1,1]}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.meshes[0].normals.size(), 3u);
    // Inverse transpose of diag(2,1,1) maps (1,1,0) to (0.5,1,0).
    Vec3f want = accel::normalize(Vec3f{0.5f, 1, 0});
    expect_vec(sc.meshes[0].normals[1], want);
    EXPECT_TRUE(sc.meshes[0].uvs.empty());
}

TEST(GltfTransforms, MirroringFlipsWinding) {
    Doc d = triangle_doc();
    std::string j = d.json(kTriMesh + ",\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,\"scale\":[-1,1,1]}]");
    Scene sc = load(j);
    // A negative determinant reverses the front face; the loader restores CCW order.
    EXPECT_EQ(sc.meshes[0].indices, (std::vector<uint32_t>{0, 2, 1}));
}

TEST(GltfTransforms, DefaultSceneAndAllRoots) {
    Doc d = triangle_doc();
    std::string nodes = ",\"nodes\":[{\"mesh\":0},{\"mesh\":0,\"translation\":[0,0,5]}]";
    Scene one = load(d.json(kTriMesh + ",\"scene\":1,\"scenes\":[{\"nodes\":[0]},{\"nodes\":[1]}]" + nodes));
    ASSERT_EQ(one.meshes.size(), 1u);
    EXPECT_FLOAT_EQ(one.meshes[0].positions[0].z, 5.0f);
    // Only the traversed scene counts: in scene 1 the mesh is placed once, so it is in
    // world space; with every root node it is placed twice, so it is instanced.
    EXPECT_TRUE(one.prototypes.empty());
    Scene all = load(d.json(kTriMesh + nodes));  // no scenes: every root node
    EXPECT_EQ(all.prototypes.size(), 1u);
    ASSERT_EQ(all.instances.size(), 2u);
    EXPECT_FLOAT_EQ(all.instances[1].object_to_world.m[2][3], 5.0f);
    EXPECT_TRUE(has_note(all, "no scenes"));
}

// ------------------------------------------------------------------------------------
// Primitives and accessors

TEST(GltfPrimitives, StripsAndFans) {
    Doc d;
    d.vec3({0, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0, 2, 0, 0});
    std::string j = d.json(
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"mode\":5},"
        "{\"attributes\":{\"POSITION\":0},\"mode\":6}]}],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.meshes.size(), 2u);
    // Strip: odd triangles swap their last two vertices (spec: v_i, v_{i+2}, v_{i+1}).
    EXPECT_EQ(sc.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2, 2, 3, 4}));
    // Fan: (v_{i+1}, v_{i+2}, v_0).
    EXPECT_EQ(sc.meshes[1].indices, (std::vector<uint32_t>{1, 2, 0, 2, 3, 0, 3, 4, 0}));
}

TEST(GltfPrimitives, PointsAndLinesSkippedWithNote) {
    Doc d = triangle_doc();
    std::string j = d.json(
        "\"meshes\":[{\"name\":\"M\",\"primitives\":[{\"attributes\":{\"POSITION\":0},\"mode\":0},"
        "{\"attributes\":{\"POSITION\":0},\"mode\":1},{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.meshes.size(), 1u);
    EXPECT_EQ(sc.num_triangles(), 1u);
    EXPECT_TRUE(has_note(sc, "mesh 'M' primitive 0: POINTS"));
    EXPECT_TRUE(has_note(sc, "mesh 'M' primitive 1: LINES"));
}

TEST(GltfPrimitives, QuantizedPositionsAndTexcoords) {
    Doc d;
    // Normalized int16 positions: 32767 -> 1, -32767 -> -1.
    std::vector<int16_t> pos = {32767, 0, 0, 0, -32767, 0, 0, 0, 16384};
    int a_pos = d.data(pos, 5122, 3, "VEC3", ",\"normalized\":true");
    std::vector<uint8_t> uv = {255, 0, 0, 255, 51, 102};
    int a_uv = d.data(uv, 5121, 2, "VEC2", ",\"normalized\":true");
    // Non-normalized uint8 positions (KHR_mesh_quantization) keep their integer values.
    std::vector<uint8_t> ipos = {3, 0, 0, 0, 0, 4, 0, 0, 0, 0, 5, 0};  // byteStride 4
    int a_ipos = d.accessor(d.view(ipos.data(), ipos.size(), 4), 5121, 3, "VEC3");
    std::vector<uint8_t> px = {255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128};
    std::vector<uint8_t> png = make_png(2, 2, px);
    std::string j = d.json(
        "\"extensionsUsed\":[\"KHR_mesh_quantization\"],\"extensionsRequired\":[\"KHR_mesh_quantization\"],"
        "\"images\":[{\"uri\":\"data:image/png;base64," + base64(png) + "\"}],\"textures\":[{\"source\":0}],"
        "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0},\"metallicFactor\":0}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(a_pos) +
        ",\"TEXCOORD_0\":" + std::to_string(a_uv) + "},\"material\":0},"
        "{\"attributes\":{\"POSITION\":" + std::to_string(a_ipos) + "}}]}],"
        "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.meshes.size(), 2u);
    expect_vec(sc.meshes[0].positions[0], {1, 0, 0});
    expect_vec(sc.meshes[0].positions[1], {0, -1, 0});
    expect_vec(sc.meshes[0].positions[2], {0, 0, 16384.0f / 32767.0f});
    ASSERT_EQ(sc.meshes[0].uvs.size(), 3u);
    EXPECT_FLOAT_EQ(sc.meshes[0].uvs[0].x, 1.0f);
    EXPECT_FLOAT_EQ(sc.meshes[0].uvs[2].x, 0.2f);
    EXPECT_FLOAT_EQ(sc.meshes[0].uvs[2].y, 0.4f);
    expect_vec(sc.meshes[1].positions[1], {0, 4, 0});
    expect_vec(sc.meshes[1].positions[2], {0, 0, 5});
    EXPECT_TRUE(sc.meshes[1].uvs.empty()) << "default material is untextured";
    // Texture: 2x2, kept as 8-bit sRGB (RGB: the PNG has no alpha), decoded on lookup,
    // row 0 at the top, with its pyramid down to 1x1.
    ASSERT_EQ(sc.textures.size(), 1u);
    const scenes::Texture& t = sc.textures[0];
    EXPECT_EQ(t.width, 2u);
    EXPECT_EQ(t.height, 2u);
    EXPECT_EQ(t.format, scenes::TexelFormat::U8);
    EXPECT_TRUE(t.srgb);
    EXPECT_EQ(t.channels, 3);
    ASSERT_EQ(t.levels.size(), 2u);
    EXPECT_EQ(t.data.size(), size_t(4 + 1) * 3);
    EXPECT_FLOAT_EQ(renderer::fetch(t, 0, 0, 0).r, 1.0f);
    EXPECT_FLOAT_EQ(renderer::fetch(t, 0, 0, 0).g, 0.0f);
    EXPECT_NEAR(renderer::fetch(t, 0, 1, 1).r, 0.2158605f, 1e-5f);  // sRGB 128 -> linear
    // The 1x1 level averages light, not codes: (1 + 0 + 0 + 0.2159) / 4 in red, re-encoded.
    EXPECT_NEAR(renderer::fetch(t, 1, 0, 0).r, (1.0f + 0.2158605f) / 4, 0.01f);
}

TEST(GltfPrimitives, TexcoordsOnlyWhenTextured) {
    Doc d = triangle_doc();
    int uv = d.data(std::vector<float>{0, 0, 1, 0, 0, 1}, 5126, 2, "VEC2");
    std::string j = d.json(
        "\"materials\":[{\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.25,1,1],\"metallicFactor\":0}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":" + std::to_string(uv) +
        "},\"indices\":1,\"material\":0}]}],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    Scene sc = load(j);
    EXPECT_TRUE(sc.meshes[0].uvs.empty());
    EXPECT_TRUE(sc.meshes[0].normals.empty()) << "no NORMAL attribute";
    expect_vec(sc.materials[0].albedo, {0.5f, 0.25f, 1.0f});
    EXPECT_TRUE(sc.materials[0].replaced.empty()) << "metallicFactor 0 is plain diffuse";
}

TEST(GltfPrimitives, SparseAccessors) {
    Doc d;
    int base = d.vec3({0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0});
    std::vector<uint16_t> sidx = {2};
    std::vector<float> sval = {7, 8, 9};
    int iv = d.view(sidx.data(), 2);
    int vv = d.view(sval.data(), 12);
    std::string sparse = ",\"sparse\":{\"count\":1,\"indices\":{\"bufferView\":" + std::to_string(iv) +
                         ",\"componentType\":5123},\"values\":{\"bufferView\":" + std::to_string(vv) + "}}";
    // Same base data, patched; plus an accessor with no bufferView (zeros + patch).
    int patched = d.accessor(0, 5126, 4, "VEC3", sparse);
    int zeros = d.accessor(-1, 5126, 4, "VEC3", sparse);
    (void)base;
    std::string j = d.json("\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":" + std::to_string(patched) +
                           "},\"mode\":5},{\"attributes\":{\"POSITION\":" + std::to_string(zeros) +
                           "},\"mode\":5}]}],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.meshes.size(), 2u);
    expect_vec(sc.meshes[0].positions[1], {1, 0, 0});
    expect_vec(sc.meshes[0].positions[2], {7, 8, 9});
    expect_vec(sc.meshes[1].positions[1], {0, 0, 0});
    expect_vec(sc.meshes[1].positions[2], {7, 8, 9});
}

// ------------------------------------------------------------------------------------
// Materials, lights, cameras

TEST(GltfMaterials, EmissiveStrengthAndDefaults) {
    Doc d = triangle_doc();
    std::string j = d.json(
        "\"extensionsUsed\":[\"KHR_materials_emissive_strength\",\"KHR_materials_sheen\"],"
        "\"materials\":[{\"name\":\"glow\",\"emissiveFactor\":[1,0.5,0],\"extensions\":{"
        "\"KHR_materials_emissive_strength\":{\"emissiveStrength\":4}}},"
        "{\"name\":\"metal\",\"pbrMetallicRoughness\":{\"metallicFactor\":0.5}}],"
        "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":0},"
        "{\"attributes\":{\"POSITION\":0},\"indices\":1,\"material\":1},"
        "{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.materials.size(), 3u);
    expect_vec(sc.materials[0].emission, {4, 2, 0});
    EXPECT_EQ(sc.materials[1].bsdf, scenes::BsdfKind::MetallicRoughness);
    EXPECT_FLOAT_EQ(sc.materials[1].metallic, 0.5f);
    EXPECT_FLOAT_EQ(sc.materials[1].roughness, 1.0f) << "glTF default roughnessFactor";
    EXPECT_TRUE(sc.materials[1].replaced.empty());
    expect_vec(sc.materials[2].albedo, {0.8f, 0.8f, 0.8f});  // no material -> grey 0.8
    EXPECT_TRUE(has_note(sc, "KHR_materials_sheen"));
    int ignored_lines = 0;
    for (const auto& n : sc.notes) ignored_lines += n.find("material features ignored") != std::string::npos;
    EXPECT_LE(ignored_lines, 1) << "ignored features are listed on one line";
}

// COLOR_0 multiplies the base colour (and its alpha): read as float or normalized
// unsigned integers, VEC3 or VEC4, and kept only where it changes the image (a colour not
// white; an alpha below 1 on a MASK or BLEND material). It is no longer an ignored feature.
TEST(GltfMaterials, VertexColoursAreReadWhereTheyMatter) {
    const auto doc = [](const std::function<int(Doc&)>& colors, const std::string& material) {
        Doc d = triangle_doc();
        const int ci = colors(d);
        return d.json("\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"COLOR_0\":" + std::to_string(ci) +
                      "},\"indices\":1,\"material\":0}]}],\"materials\":[" + material +
                      "],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    };
    const std::string opaque = "{}", mask = "{\"alphaMode\":\"MASK\"}";
    // Float RGB, one component out of range (clamped).
    const Scene rgb = load(doc([](Doc& d) { return d.vec3({0.5f, 0.25f, 1.0f, 1, 1, 1, 0, 2.0f, 0}); }, opaque));
    ASSERT_EQ(rgb.meshes[0].colors.size(), 3u);
    expect_vec(rgb.meshes[0].colors[0], {0.5f, 0.25f, 1.0f});
    expect_vec(rgb.meshes[0].colors[2], {0.0f, 1.0f, 0.0f});
    EXPECT_TRUE(rgb.meshes[0].alphas.empty());
    EXPECT_FALSE(has_note(rgb, "COLOR_0"));
    // Normalized bytes, RGBA: the alpha is kept for MASK only.
    const auto rgba8 = [](Doc& d) {
        return d.data(std::vector<uint8_t>{255, 0, 51, 128, 255, 255, 255, 255, 0, 0, 0, 0}, 5121, 4, "VEC4",
                      ",\"normalized\":true");
    };
    const Scene masked = load(doc(rgba8, mask));
    ASSERT_EQ(masked.meshes[0].colors.size(), 3u);
    expect_vec(masked.meshes[0].colors[0], {1.0f, 0.0f, 0.2f});
    ASSERT_EQ(masked.meshes[0].alphas.size(), 3u);
    EXPECT_NEAR(masked.meshes[0].alphas[0], 128.0f / 255.0f, 1e-6f);
    EXPECT_EQ(masked.meshes[0].alphas[2], 0.0f);
    EXPECT_TRUE(load(doc(rgba8, opaque)).meshes[0].alphas.empty()) << "an opaque material ignores alpha";
    // White and opaque, as exporters often write: nothing stored.
    const Scene white = load(doc(
        [](Doc& d) {
            return d.data(std::vector<uint16_t>(12, 65535), 5123, 4, "VEC4", ",\"normalized\":true");
        },
        mask));
    EXPECT_TRUE(white.meshes[0].colors.empty());
    EXPECT_TRUE(white.meshes[0].alphas.empty());
    // Bad input: integers not normalized, a count not the positions', a scalar type.
    expect_error(doc([](Doc& d) { return d.data(std::vector<uint8_t>(12, 9), 5121, 4, "VEC4"); }, opaque),
                 {"COLOR of mesh 0 primitive 0", "must be normalized"});
    expect_error(doc([](Doc& d) { return d.vec3({1, 0, 0, 0, 1, 0}); }, opaque), {"COLOR_0 has 2 elements, POSITION 3"});
    expect_error(doc([](Doc& d) { return d.data(std::vector<float>{1, 1, 1}, 5126, 1, "SCALAR"); }, opaque),
                 {"COLOR of mesh 0 primitive 0", "expected VEC3"});
}

// Morph targets are not applied: the mesh loads in its base shape, and the note says so,
// and whether the file's default weights would have posed it otherwise.
TEST(GltfMaterials, MorphTargetsAreNamedAsIgnored) {
    Doc d = triangle_doc();
    const auto doc = [&](const std::string& mesh_extra) {
        return d.json("\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1,"
                      "\"targets\":[{\"POSITION\":0}]}]" + mesh_extra + "}],"
                      "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    };
    const Scene rest = load(doc(""));
    EXPECT_TRUE(has_note(rest, "morph targets ignored: 1 mesh loaded in their base shape"));
    EXPECT_FALSE(has_note(rest, "default weights"));
    EXPECT_TRUE(has_note(load(doc(",\"weights\":[0.5]")), "not in the pose the file's default weights give"));
    EXPECT_FALSE(has_note(load(d.json("\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
                                      "\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]")),
                          "morph targets"));
}

TEST(GltfMaterials, MetallicRoughnessTransmissionAndIor) {
    Doc d = triangle_doc();
    auto doc = [&](const std::string& material) {
        return d.json("\"materials\":[" + material + "],\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},"
                      "\"indices\":1,\"material\":0}]}],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    };
    Scene sc = load(doc("{\"name\":\"glass\",\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":0.1},"
                        "\"extensions\":{\"KHR_materials_transmission\":{\"transmissionFactor\":0.9},"
                        "\"KHR_materials_ior\":{\"ior\":1.7}}}"));
    const scenes::Material& m = sc.materials.at(0);
    EXPECT_EQ(m.bsdf, scenes::BsdfKind::MetallicRoughness);
    EXPECT_FLOAT_EQ(m.metallic, 0.0f);
    EXPECT_FLOAT_EQ(m.roughness, 0.1f);
    EXPECT_FLOAT_EQ(m.transmission, 0.9f);
    EXPECT_FLOAT_EQ(m.ior, 1.7f);
    EXPECT_FALSE(has_note(sc, "KHR_materials_transmission")) << "modelled, not ignored";
    // metallic 0, roughness 1, no maps: close enough to Lambert to stay on the fast path.
    Scene plain = load(doc("{\"pbrMetallicRoughness\":{\"metallicFactor\":0,\"roughnessFactor\":1}}"));
    EXPECT_EQ(plain.materials.at(0).bsdf, scenes::BsdfKind::Diffuse);
    expect_error(doc("{\"name\":\"B\",\"extensions\":{\"KHR_materials_ior\":{\"ior\":0.5}}}"),
                 {"material 'B'", "ior"});
    expect_error(doc("{\"name\":\"R\",\"pbrMetallicRoughness\":{\"roughnessFactor\":2}}"),
                 {"material 'R'", "roughnessFactor"});
}

TEST(GltfLights, PunctualKinds) {
    Doc d = triangle_doc();
    const double s = std::sqrt(0.5);
    // -90 deg about X maps local -Z to world -Y.
    std::string down = "\"rotation\":[" + std::to_string(-s) + ",0,0," + std::to_string(s) + "]";
    std::string j = d.json(
        kTriMesh + ",\"extensionsUsed\":[\"KHR_lights_punctual\"],\"extensions\":{\"KHR_lights_punctual\":{\"lights\":["
        "{\"name\":\"p\",\"type\":\"point\",\"color\":[1,0.5,0.25],\"intensity\":8,\"range\":10},"
        "{\"name\":\"d\",\"type\":\"directional\",\"intensity\":2},"
        "{\"name\":\"s\",\"type\":\"spot\",\"intensity\":3,\"spot\":{\"innerConeAngle\":0.2,\"outerConeAngle\":0.6}}]}},"
        "\"scenes\":[{\"nodes\":[0,1,2,3]}],\"nodes\":[{\"mesh\":0},"
        "{\"translation\":[1,2,3],\"extensions\":{\"KHR_lights_punctual\":{\"light\":0}}},"
        "{" + down + ",\"extensions\":{\"KHR_lights_punctual\":{\"light\":1}}},"
        "{\"translation\":[0,4,0]," + down + ",\"extensions\":{\"KHR_lights_punctual\":{\"light\":2}}}]");
    Scene sc = load(j);
    ASSERT_EQ(sc.lights.size(), 3u);
    EXPECT_EQ(sc.lights[0].type, scenes::LightType::Point);
    expect_vec(sc.lights[0].position, {1, 2, 3});
    expect_vec(sc.lights[0].radiance, {8, 4, 2});
    EXPECT_TRUE(has_note(sc, "range"));
    EXPECT_EQ(sc.lights[1].type, scenes::LightType::Directional);
    expect_vec(sc.lights[1].direction, {0, -1, 0});
    expect_vec(sc.lights[1].radiance, {2, 2, 2});
    EXPECT_EQ(sc.lights[2].type, scenes::LightType::Spot);
    expect_vec(sc.lights[2].position, {0, 4, 0});
    expect_vec(sc.lights[2].direction, {0, -1, 0});
    EXPECT_NEAR(sc.lights[2].spot_cos_inner, std::cos(0.2f), 1e-6f);
    EXPECT_NEAR(sc.lights[2].spot_cos_outer, std::cos(0.6f), 1e-6f);
}

TEST(GltfCameras, FovConversionAndFirstCamera) {
    Doc d = triangle_doc();
    std::string j = d.json(
        kTriMesh + ",\"cameras\":[{\"type\":\"orthographic\",\"orthographic\":{\"xmag\":1,\"ymag\":1,\"zfar\":10,\"znear\":0.1}},"
        "{\"name\":\"main\",\"type\":\"perspective\",\"perspective\":{\"yfov\":0.5,\"aspectRatio\":1.5,\"znear\":0.1}},"
        "{\"name\":\"second\",\"type\":\"perspective\",\"perspective\":{\"yfov\":1.0,\"znear\":0.1}}],"
        "\"scenes\":[{\"nodes\":[0,1,2,3]}],\"nodes\":[{\"mesh\":0},"
        "{\"camera\":1,\"translation\":[0,1,5]},{\"camera\":2},{\"camera\":0}]");
    Scene sc = load(j);
    ASSERT_TRUE(sc.camera.has_value());
    EXPECT_EQ(sc.camera->name, "main");
    EXPECT_NEAR(sc.camera->yfov_deg, 0.5 * 180.0 / M_PI, 1e-4);
    EXPECT_NEAR(sc.camera->xfov_deg, 2.0 * std::atan(std::tan(0.25) * 1.5) * 180.0 / M_PI, 1e-4);
    EXPECT_FLOAT_EQ(sc.camera->aspect, 1.5f);
    EXPECT_FLOAT_EQ(sc.camera->camera_to_world.m[1][3], 1.0f);
    EXPECT_FLOAT_EQ(sc.camera->camera_to_world.m[2][3], 5.0f);
    EXPECT_FALSE(sc.camera->orthographic);
    EXPECT_TRUE(has_note(sc, "several cameras in the scene: using the first, 'main'"));

    Scene noaspect = load(d.json(kTriMesh + ",\"cameras\":[{\"type\":\"perspective\",\"perspective\":{\"yfov\":1.0,\"znear\":0.1}}],"
                                            "\"scenes\":[{\"nodes\":[0,1]}],\"nodes\":[{\"mesh\":0},{\"camera\":0}]"));
    ASSERT_TRUE(noaspect.camera.has_value());
    EXPECT_EQ(noaspect.camera->xfov_deg, 0.0f) << "renderer derives it from the image aspect";
    EXPECT_EQ(noaspect.camera->aspect, 0.0f);
}

// An orthographic camera: its half extents (the renderer keeps ymag and widens x to the
// image); a zero magnification is refused.
TEST(GltfCameras, OrthographicCameraKeepsItsExtents) {
    Doc d = triangle_doc();
    const auto doc = [&](const std::string& mags) {
        return d.json(kTriMesh + ",\"cameras\":[{\"name\":\"top\",\"type\":\"orthographic\",\"orthographic\":{" + mags +
                      ",\"zfar\":10,\"znear\":0.1}}],\"scenes\":[{\"nodes\":[0,1]}],"
                      "\"nodes\":[{\"mesh\":0},{\"camera\":0,\"translation\":[0,0,4]}]");
    };
    const Scene sc = load(doc("\"xmag\":2,\"ymag\":-1.5"));
    ASSERT_TRUE(sc.camera.has_value());
    EXPECT_TRUE(sc.camera->orthographic);
    EXPECT_EQ(sc.camera->name, "top");
    EXPECT_FLOAT_EQ(sc.camera->xmag, 2.0f);
    EXPECT_FLOAT_EQ(sc.camera->ymag, 1.5f);
    EXPECT_FLOAT_EQ(sc.camera->camera_to_world.m[2][3], 4.0f);
    EXPECT_FALSE(has_note(sc, "camera skipped"));
    expect_error(doc("\"xmag\":2,\"ymag\":0"), {"camera 0 ('top')", "xmag and ymag must be finite and non-zero"});
}

TEST(GltfContainer, GlbWithBinChunkMatchesGltf) {
    Doc d = triangle_doc();
    std::string body = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":" + std::to_string(d.bin.size()) +
                       "}],\"bufferViews\":[" + Doc::join(d.views) + "],\"accessors\":[" + Doc::join(d.accessors) +
                       "]," + kTriMesh + ",\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0,\"translation\":[0,0,2]}]}";
    while (body.size() % 4) body += ' ';
    std::vector<uint8_t> bin = d.bin;
    while (bin.size() % 4) bin.push_back(0);
    std::vector<uint8_t> glb;
    auto put = [&](uint32_t v) { for (int i = 0; i < 4; ++i) glb.push_back(uint8_t(v >> (8 * i))); };
    glb.insert(glb.end(), {'g', 'l', 'T', 'F'});
    put(2);
    put(uint32_t(12 + 8 + body.size() + 8 + bin.size()));
    put(uint32_t(body.size()));
    put(0x4E4F534Au);
    glb.insert(glb.end(), body.begin(), body.end());
    put(uint32_t(bin.size()));
    put(0x004E4942u);
    glb.insert(glb.end(), bin.begin(), bin.end());
    Scene sc = scenes::load_gltf_memory(glb.data(), glb.size(), "t.glb", "", true);
    ASSERT_EQ(sc.meshes.size(), 1u);
    expect_vec(sc.meshes[0].positions[0], {1, 0, 2});

    // Truncations of the same file: every one is a SceneError naming the file.
    for (size_t cut : {size_t(0), size_t(11), size_t(19), size_t(40), glb.size() - 9, glb.size() - 1}) {
        std::string part(reinterpret_cast<const char*>(glb.data()), cut);
        expect_error(part, {}, "t.glb", true);
    }
    std::vector<uint8_t> lie = glb;
    lie[8] = uint8_t(lie[8] + 4);  // header length larger than the data
    expect_error(std::string(lie.begin(), lie.end()), {"truncated GLB"}, "t.glb", true);
    std::vector<uint8_t> chunk = glb;
    size_t bin_hdr = 20 + body.size();
    chunk[bin_hdr] = uint8_t(chunk[bin_hdr] + 16);  // BIN chunk longer than the file
    expect_error(std::string(chunk.begin(), chunk.end()), {"BIN chunk"}, "t.glb", true);
}

TEST(GltfTextures, MissingNeededAndUnneededImages) {
    Doc d = triangle_doc();
    int uv = d.data(std::vector<float>{0, 0, 1, 0, 0, 1}, 5126, 2, "VEC2");
    auto doc = [&](const std::string& material) {
        return d.json("\"images\":[{\"uri\":\"nope_normal.png\"},{\"uri\":\"nope_base.png\"}],"
                      "\"textures\":[{\"source\":0},{\"source\":1}],\"materials\":[" + material + "],"
                      "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0,\"TEXCOORD_0\":" + std::to_string(uv) +
                      "},\"indices\":1,\"material\":0}]}],\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}]");
    };
    auto dir = std::filesystem::temp_directory_path() / "gltf_loader_test_empty_dir";
    std::filesystem::create_directories(dir);
    // Normal map missing: the material goes on without it, with a note naming the image.
    Scene ok = load(doc("{\"name\":\"N\",\"normalTexture\":{\"index\":0}}"), "t.gltf", dir.string());
    EXPECT_TRUE(has_note(ok, "nope_normal.png"));
    EXPECT_EQ(ok.materials[0].normal_texture, scenes::kNoTexture);
    EXPECT_TRUE(ok.textures.empty());
    // Base colour missing: needed, so a warning naming the file, image and material, and
    // the material keeps its factor alone (as Blender and glTF viewers do).
    Scene base = load(doc("{\"name\":\"B\",\"pbrMetallicRoughness\":{\"baseColorFactor\":[0.5,0.25,1,1],"
                          "\"baseColorTexture\":{\"index\":1}}}"),
                      "t.gltf", dir.string());
    ASSERT_EQ(base.warnings.size(), 1u);
    const std::string& w = base.warnings[0];
    EXPECT_EQ(w.rfind("t.gltf: ", 0), 0u) << w;
    EXPECT_NE(w.find("nope_base.png"), std::string::npos) << w;
    EXPECT_NE(w.find("material 'B'"), std::string::npos) << w;
    ASSERT_EQ(base.materials.size(), 1u);
    EXPECT_EQ(base.materials[0].albedo_texture, scenes::kNoTexture);
    EXPECT_FLOAT_EQ(base.materials[0].albedo.y, 0.25f);
    EXPECT_TRUE(base.meshes[0].uvs.empty());
    EXPECT_TRUE(base.textures.empty());
    EXPECT_TRUE(ok.warnings.empty());
}

// ------------------------------------------------------------------------------------
// Bad input: one test per class, SceneError naming the file and the element.

const std::string kScene0 = ",\"scenes\":[{\"nodes\":[0]}]";

TEST(GltfErrors, MalformedJson) {
    expect_error("{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [", {"JSON parse error"});
    expect_error("not json at all", {"JSON"});
    expect_error(std::string(200, '[') , {"nested"});
}

TEST(GltfErrors, MissingBin) {
    auto dir = std::filesystem::temp_directory_path() / "gltf_loader_test_empty_dir";
    std::filesystem::create_directories(dir);
    std::string j = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":36,\"uri\":\"missing.bin\"}]}";
    try {
        load(j, "m.gltf", dir.string());
        ADD_FAILURE() << "missing .bin must fail";
    } catch (const SceneError& e) {
        std::string m = e.what();
        EXPECT_EQ(m.rfind("m.gltf: ", 0), 0u) << m;
        EXPECT_NE(m.find("buffer 0"), std::string::npos) << m;
        EXPECT_NE(m.find("missing.bin"), std::string::npos) << m;
    }
}

TEST(GltfErrors, BufferLengthMismatchNamesBufferWithoutDumpingData) {
    std::vector<uint8_t> payload(30000, 'x');
    std::string j = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":10,\"uri\":"
                    "\"data:application/octet-stream;base64," + base64(payload) + "\"}]}";
    try {
        load(j, "big.gltf");
        ADD_FAILURE() << "byteLength mismatch must fail";
    } catch (const SceneError& e) {
        std::string m = e.what();
        EXPECT_EQ(m.rfind("big.gltf: buffer 0", 0), 0u) << m.substr(0, 200);
        EXPECT_LT(m.size(), 600u) << "the data URI must be elided";
    }
}

TEST(GltfErrors, DanglingReferences) {
    Doc d = triangle_doc();
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":5}]"), {"node 0", "mesh 5 does not exist"});
    expect_error(d.json(kTriMesh + ",\"scenes\":[{\"nodes\":[3]}],\"nodes\":[{\"mesh\":0}]"), {"scene 0", "node 3"});
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0,\"children\":[9]}]"), {"node 0", "child 9"});
    expect_error(d.json("\"meshes\":[{\"name\":\"Body\",\"primitives\":[{\"attributes\":{\"POSITION\":9}}]}]" + kScene0 +
                        ",\"nodes\":[{\"mesh\":0}]"),
                 {"mesh 'Body' primitive 0", "accessor 9 does not exist"});
    Doc bad = triangle_doc();
    bad.accessors[0] = "{\"bufferView\":7,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"}";
    expect_error(bad.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"), {"accessor 0", "bufferView 7 does not exist"});
    auto with_material = [&](const std::string& extra) {
        return d.json(extra + "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":0}]}]" +
                      kScene0 + ",\"nodes\":[{\"mesh\":0}]");
    };
    expect_error(with_material("\"materials\":[{\"name\":\"Mat\",\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":3}}}],"),
                 {"material 'Mat' baseColorTexture", "texture 3 does not exist"});
    expect_error(with_material("\"textures\":[{\"source\":4}],\"materials\":[{\"name\":\"Mat\",\"normalTexture\":{\"index\":0}}],"),
                 {"material 'Mat' normalTexture", "image 4 does not exist"});
    expect_error(d.json("\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":2}]}]" + kScene0 +
                        ",\"nodes\":[{\"mesh\":0}]"),
                 {"mesh 0 primitive 0", "material 2 does not exist"});
}

TEST(GltfErrors, IndexOutOfRange) {
    Doc d;
    d.vec3({1, 0, 0, 0, 1, 0, 0, 0, 0});
    d.u16({0, 1, 7});
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"), {"mesh 'M' primitive 0", "index 7", "3 vertices"});
}

TEST(GltfErrors, NonFiniteValues) {
    Doc d;
    float nan = std::nanf("");
    d.vec3({1, 0, 0, nan, 1, 0, 0, 0, 0});
    expect_error(d.json("\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}]" + kScene0 + ",\"nodes\":[{\"mesh\":0}]"),
                 {"accessor 0", "POSITION", "not finite"});
    Doc t = triangle_doc();
    // 1e300 is a finite double but not a finite float.
    expect_error(t.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0,\"matrix\":[1e300,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}]"),
                 {"node 0", "not finite"});
}

TEST(GltfErrors, AbsurdCountsAndRanges) {
    Doc d = triangle_doc();
    d.accessors[0] = "{\"bufferView\":0,\"componentType\":5126,\"count\":4000000000,\"type\":\"VEC3\"}";
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"), {"accessor 0", "4000000000", "do not fit"});
    Doc u = triangle_doc();
    u.accessors[0] = "{\"componentType\":5126,\"count\":4000000000,\"type\":\"VEC3\"}";
    expect_error(u.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"), {"accessor 0", "too large"});
    Doc v = triangle_doc();
    v.views[0] = "{\"buffer\":0,\"byteOffset\":4,\"byteLength\":4000}";
    expect_error(v.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"), {"bufferView 0", "exceed buffer 0"});
    Doc w = triangle_doc();
    w.accessors[0] = "{\"bufferView\":0,\"componentType\":5125,\"count\":3,\"type\":\"VEC3\"}";
    expect_error(w.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"), {"accessor 0", "UNSIGNED_INT", "not allowed"});
}

TEST(GltfErrors, HierarchyCycles) {
    Doc d = triangle_doc();
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0,\"children\":[1]},{\"children\":[0]}]"),
                 {"node 0", "reached twice"});
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0,\"children\":[0]}]"), {"node 0", "reached twice"});
    // A chain of shared children would otherwise multiply instances exponentially.
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"children\":[1,1]},{\"mesh\":0}]"), {"node 1", "reached twice"});
    // Deep but valid chain: no recursion limit, no stack overflow.
    std::string nodes;
    const int depth = 20000;
    for (int i = 0; i < depth; ++i)
        nodes += std::string(i ? "," : "") + "{\"children\":[" + std::to_string(i + 1) + "]}";
    nodes += ",{\"mesh\":0}";
    Scene deep = load(d.json(kTriMesh + kScene0 + ",\"nodes\":[" + nodes + "]"));
    EXPECT_EQ(deep.num_triangles(), 1u);
}

TEST(GltfErrors, EmptyScene) {
    Doc d = triangle_doc();
    expect_error(d.json(kTriMesh + kScene0 + ",\"nodes\":[{\"name\":\"lonely\"}]"), {"no triangles"});
    expect_error("{\"asset\":{\"version\":\"2.0\"}}", {"no triangles"});
}

TEST(GltfErrors, UnsupportedRequiredExtension) {
    Doc d = triangle_doc();
    expect_error(d.json("\"extensionsUsed\":[\"EXT_meshopt_compression\"],\"extensionsRequired\":[\"EXT_meshopt_compression\"]," +
                        kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"),
                 {"EXT_meshopt_compression"});
    Scene sc = load(d.json("\"extensionsUsed\":[\"EXT_unknown_thing\"]," + kTriMesh + kScene0 + ",\"nodes\":[{\"mesh\":0}]"));
    EXPECT_TRUE(has_note(sc, "EXT_unknown_thing"));
    // Every extension the loader reads may be required, and is not called ignored.
    for (const char* e : {"EXT_mesh_gpu_instancing", "KHR_draco_mesh_compression", "KHR_lights_punctual",
                          "KHR_materials_emissive_strength", "KHR_materials_ior", "KHR_materials_transmission",
                          "KHR_materials_unlit", "KHR_mesh_quantization", "KHR_texture_transform"}) {
        const std::string list = std::string("[\"") + e + "\"]";
        const Scene req = load(d.json("\"extensionsUsed\":" + list + ",\"extensionsRequired\":" + list + "," + kTriMesh +
                                      kScene0 + ",\"nodes\":[{\"mesh\":0}]"));
        EXPECT_FALSE(has_note(req, "extensions ignored")) << e;
    }
}

TEST(GltfErrors, LoadFromMissingFile) {
    try {
        scenes::load_gltf("/nonexistent/dir/x.gltf");
        ADD_FAILURE();
    } catch (const SceneError& e) {
        EXPECT_EQ(std::string(e.what()).rfind("/nonexistent/dir/x.gltf: ", 0), 0u);
    }
}

}  // namespace
