// glTF extensions on small files made here.
// KHR_draco_mesh_compression: files encoded here with Draco's encoder load as the same
// triangles as their uncompressed twins (within quantization), and bad Draco data is
// refused with a message naming the file, mesh, primitive and extension.
// KHR_texture_transform: offset, rotation, scale and the texCoord override reach the uvs.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>

#include "scenes/gltf/gltf.h"
#include "tests/gltf/draco_writer.h"

namespace {

scenes::Scene load(const std::string& text, const std::string& name = "draco.gltf") {
    return scenes::load_gltf_memory(text.data(), text.size(), name, "/nonexistent", false);
}

float dist(const scenes::Vec3f& a, const scenes::Vec3f& b) {
    float dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
    return std::sqrt(dx * dx + dy * dy + dz * dz);
}

/// Every triangle of `b` matches one of `a` with the same winding (Draco may reorder
/// points and rotate a face's corners), positions within `tol`, normals within `ntol`,
/// uvs within `tol`.
void expect_same_triangles(const scenes::Mesh& a, const scenes::Mesh& b, float tol, float ntol) {
    ASSERT_EQ(a.num_triangles(), b.num_triangles());
    ASSERT_EQ(a.normals.empty(), b.normals.empty());
    ASSERT_EQ(a.uvs.empty(), b.uvs.empty());
    std::vector<bool> used(a.num_triangles(), false);
    for (uint32_t tb = 0; tb < b.num_triangles(); ++tb) {
        bool found = false;
        for (uint32_t ta = 0; ta < a.num_triangles() && !found; ++ta) {
            if (used[ta]) continue;
            for (int rot = 0; rot < 3 && !found; ++rot) {
                bool same = true;
                for (int k = 0; k < 3 && same; ++k) {
                    uint32_t ia = a.indices[ta * 3 + uint32_t((k + rot) % 3)], ib = b.indices[tb * 3 + uint32_t(k)];
                    same = dist(a.positions[ia], b.positions[ib]) < tol;
                    if (same && !a.normals.empty()) same = dist(a.normals[ia], b.normals[ib]) < ntol;
                    if (same && !a.uvs.empty())
                        same = std::abs(a.uvs[ia].x - b.uvs[ib].x) < tol && std::abs(a.uvs[ia].y - b.uvs[ib].y) < tol;
                }
                if (same) found = used[ta] = true;
            }
        }
        EXPECT_TRUE(found) << "draco triangle " << tb << " has no uncompressed twin";
    }
}

TEST(GltfDraco, SameTrianglesAsUncompressedTwin) {
    const auto src = draco_writer::grid(6, 4);
    for (bool normals : {false, true})
        for (bool textured : {false, true}) {
            SCOPED_TRACE("normals " + std::to_string(normals) + " textured " + std::to_string(textured));
            scenes::Scene plain = load(draco_writer::plain_gltf(src, normals, textured), "plain.gltf");
            scenes::Scene draco = load(draco_writer::draco_gltf(src, normals, textured));
            ASSERT_EQ(plain.meshes.size(), 1u);
            ASSERT_EQ(draco.meshes.size(), 1u);
            EXPECT_EQ(draco.meshes[0].num_triangles(), 48u);
            // 14-bit positions over a range of 2: step 1.2e-4; 10-bit normals.
            expect_same_triangles(plain.meshes[0], draco.meshes[0], 1e-3f, 2e-2f);
        }
}

TEST(GltfDraco, BadDataNamesFileMeshAndPrimitive) {
    const std::string good = draco_writer::draco_gltf(draco_writer::grid(3, 2), true, false);
    auto expect_refused = [&](const std::string& text, const std::string& what) {
        try {
            load(text);
            ADD_FAILURE() << "accepted: " << what;
        } catch (const scenes::SceneError& e) {
            std::string m = e.what();
            EXPECT_NE(m.find("draco.gltf"), std::string::npos) << m;
            EXPECT_NE(m.find("mesh 'grid' primitive 0"), std::string::npos) << m;
            EXPECT_NE(m.find("KHR_draco_mesh_compression"), std::string::npos) << m;
            EXPECT_NE(m.find(what), std::string::npos) << m;
        }
    };
    // Truncated stream: the bufferView keeps only the first 12 bytes.
    expect_refused(std::regex_replace(good, std::regex(R"("bufferViews":\[\{"buffer":0,"byteLength":\d+)"),
                                      R"("bufferViews":[{"buffer":0,"byteLength":12)"),
                   "Draco data");
    // An attribute id the stream does not have.
    expect_refused(std::regex_replace(good, std::regex(R"("NORMAL":\d+\}\}\}\})"), R"("NORMAL":9}}}})"),
                   "Draco attribute id 9 does not exist");
    // The extension's bufferView does not exist.
    expect_refused(std::regex_replace(good, std::regex(R"(\{"bufferView":0,"attributes")"),
                                      R"({"bufferView":4,"attributes")"),
                   "bufferView 4 does not exist");
}

/// One textured triangle with two uv sets; `transform` is the baseColorTexture's
/// KHR_texture_transform object ("" = none).
std::string textured_triangle(const std::string& transform) {
    std::vector<float> pos = {0, 0, 0, 1, 0, 0, 0, 1, 0}, uv0 = {0, 0, 1, 0, 0, 1}, uv1 = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f};
    std::vector<uint8_t> bytes;
    for (const auto* v : {&pos, &uv0, &uv1}) {
        const uint8_t* b = reinterpret_cast<const uint8_t*>(v->data());
        bytes.insert(bytes.end(), b, b + v->size() * 4);
    }
    std::string ext = transform.empty() ? "" : R"(,"extensions":{"KHR_texture_transform":)" + transform + "}";
    return R"({"asset":{"version":"2.0"},"extensionsUsed":["KHR_texture_transform"],"scene":0,"scenes":[{"nodes":[0]}],)"
           R"("nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1,"TEXCOORD_1":2},"material":0}]}],)"
           R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},)"
           R"({"bufferView":1,"componentType":5126,"count":3,"type":"VEC2"},{"bufferView":2,"componentType":5126,"count":3,"type":"VEC2"}],)"
           R"("bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":24},{"buffer":0,"byteOffset":60,"byteLength":24}],)"
           R"("buffers":[{"byteLength":84,"uri":"data:application/octet-stream;base64,)" + draco_writer::base64(bytes) + R"("}],)"
           R"("materials":[{"name":"t","pbrMetallicRoughness":{"baseColorTexture":{"index":0)" + ext + R"(}}}],)"
           R"("textures":[{"source":0}],"images":[{"uri":"data:image/png;base64,)" + draco_writer::kWhitePng + R"("}]})";
}

TEST(GltfTextureTransform, OffsetRotationScaleReachTheUvs) {
    // The extension README's example: the lower-left quadrant, turned 90 degrees clockwise.
    scenes::Scene s = load(textured_triangle(R"({"offset":[0,1],"rotation":1.5707963268,"scale":[0.5,0.5]})"), "tt.gltf");
    ASSERT_EQ(s.meshes.size(), 1u);
    const auto& uv = s.meshes[0].uvs;
    ASSERT_EQ(uv.size(), 3u);
    const float want[3][2] = {{0.0f, 1.0f}, {0.0f, 0.5f}, {0.5f, 1.0f}};
    for (int i = 0; i < 3; ++i) {
        EXPECT_NEAR(uv[size_t(i)].x, want[i][0], 1e-6f) << i;
        EXPECT_NEAR(uv[size_t(i)].y, want[i][1], 1e-6f) << i;
    }
    // No transform: the uvs as stored.
    scenes::Scene plain = load(textured_triangle(""), "tt.gltf");
    EXPECT_NEAR(plain.meshes[0].uvs[1].x, 1.0f, 1e-7f);
    EXPECT_NEAR(plain.meshes[0].uvs[1].y, 0.0f, 1e-7f);
}

TEST(GltfTextureTransform, TexCoordOverrideAndBadValues) {
    scenes::Scene s = load(textured_triangle(R"({"texCoord":1,"scale":[2,2]})"), "tt.gltf");
    for (const auto& t : s.meshes[0].uvs) {
        EXPECT_NEAR(t.x, 1.0f, 1e-6f);
        EXPECT_NEAR(t.y, 1.0f, 1e-6f);
    }
    try {
        load(textured_triangle(R"({"scale":[1]})"), "tt.gltf");
        ADD_FAILURE() << "a 1-number scale was accepted";
    } catch (const scenes::SceneError& e) {
        std::string m = e.what();
        EXPECT_EQ(m.rfind("tt.gltf: ", 0), 0u) << m;
        EXPECT_NE(m.find("material 't' baseColorTexture: KHR_texture_transform: scale"), std::string::npos) << m;
    }
}

}  // namespace
