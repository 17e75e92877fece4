// glTF extensions on small files made here.
// KHR_draco_mesh_compression: files encoded here with Draco's encoder load as the same
// triangles as their uncompressed twins (within quantization), and bad Draco data is
// refused with a message naming the file, mesh, primitive and extension.
// KHR_texture_transform: offset, rotation, scale and the texCoord override reach the uvs.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>

#include "scenes/gltf/gltf.h"
#include "tests/render/render_world.h"
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
/// KHR_texture_transform object ("" = none). `textures`: the material's texture slots
/// instead (its pbrMetallicRoughness and top-level members, written out).
std::string textured_triangle(const std::string& transform, const std::string& textures = "") {
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
           R"("materials":[{"name":"t",)" +
           (textures.empty() ? R"("pbrMetallicRoughness":{"baseColorTexture":{"index":0)" + ext + "}}" : textures) + "}],"
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

// The data maps take their own transform where they are the material's first texture,
// and one that differs from the base colour's is named in a note (one uv transform per
// material).
TEST(GltfTextureTransform, DataMapsTakeTheirTransform) {
    const std::string half = R"({"KHR_texture_transform":{"scale":[0.5,0.5]}})";
    for (const std::string& textures :
         {R"("pbrMetallicRoughness":{"metallicRoughnessTexture":{"index":0,"extensions":)" + half + "}}",
          R"("normalTexture":{"index":0,"extensions":)" + half + "}",
          R"("extensions":{"KHR_materials_transmission":{"transmissionFactor":1,"transmissionTexture":{"index":0,"extensions":)" +
              half + "}}}"}) {
        scenes::Scene s = load(textured_triangle("", textures), "tt.gltf");
        ASSERT_EQ(s.meshes.size(), 1u) << textures;
        EXPECT_NEAR(s.meshes[0].uvs[1].x, 0.5f, 1e-6f) << textures;
        EXPECT_NEAR(s.meshes[0].uvs[2].y, 0.5f, 1e-6f) << textures;
    }
    const std::string both = R"("pbrMetallicRoughness":{"baseColorTexture":{"index":0}},"normalTexture":{"index":0,"extensions":)" +
                             half + "}";
    scenes::Scene s = load(textured_triangle("", both), "tt.gltf");
    EXPECT_NEAR(s.meshes[0].uvs[1].x, 1.0f, 1e-6f) << "the base colour's (no) transform";
    bool noted = false;
    for (const std::string& n : s.notes) noted |= n.find("normalTexture has another KHR_texture_transform") != std::string::npos;
    EXPECT_TRUE(noted);
    scenes::Scene same = load(textured_triangle("", R"("pbrMetallicRoughness":{"baseColorTexture":{"index":0,"extensions":)" +
                                                        half + R"(}},"normalTexture":{"index":0,"extensions":)" + half + "}"),
                              "tt.gltf");
    for (const std::string& n : same.notes) EXPECT_EQ(n.find("KHR_texture_transform than"), std::string::npos) << n;
    EXPECT_NEAR(same.meshes[0].uvs[1].x, 0.5f, 1e-6f);
}

// A texture's sampler reaches its lookups (renderer/texture.h): the wrap of each axis and
// a NEAREST magnification filter. glTF's default sampler, or none, repeats and filters.
// Samplers are no longer among the features a note says are ignored.
TEST(GltfSamplers, WrapsAndMagnificationReachTheTexture) {
    using scenes::TextureWrap;
    const auto with_samplers = [](const std::string& textures, const std::string& samplers,
                                  const std::string& material = "") {
        std::string j = textured_triangle("", material);
        const std::string plain = R"("textures":[{"source":0}])";
        j.replace(j.find(plain), plain.size(), R"("textures":)" + textures + R"(,"samplers":[)" + samplers + "]");
        return load(j, "tt.gltf");
    };
    const auto noted = [](const scenes::Scene& s, const std::string& what) {
        for (const std::string& n : s.notes)
            if (n.find(what) != std::string::npos) return true;
        return false;
    };
    const std::string one = R"([{"source":0,"sampler":0}])";
    const scenes::Scene clamp = with_samplers(one, R"({"wrapS":33071,"wrapT":33648,"magFilter":9728})");
    ASSERT_EQ(clamp.textures.size(), 1u);
    EXPECT_EQ(clamp.textures[0].wrap_s, TextureWrap::ClampToEdge);
    EXPECT_EQ(clamp.textures[0].wrap_t, TextureWrap::MirroredRepeat);
    EXPECT_TRUE(clamp.textures[0].magnify_nearest);
    EXPECT_FALSE(noted(clamp, "sampler"));
    for (const std::string& sampler : {std::string(R"({"wrapS":10497,"magFilter":9729})"), std::string("{}")}) {
        const scenes::Scene plain = with_samplers(one, sampler);
        ASSERT_EQ(plain.textures.size(), 1u);
        EXPECT_EQ(plain.textures[0].wrap_s, TextureWrap::Repeat) << sampler;
        EXPECT_EQ(plain.textures[0].wrap_t, TextureWrap::Repeat) << sampler;
        EXPECT_FALSE(plain.textures[0].magnify_nearest) << sampler;
        EXPECT_FALSE(noted(plain, "sampler")) << sampler;
    }
    // A wrap glTF does not define repeats, with a note naming it.
    const scenes::Scene odd = with_samplers(one, R"({"wrapT":1234})");
    EXPECT_EQ(odd.textures[0].wrap_t, TextureWrap::Repeat);
    EXPECT_TRUE(noted(odd, "sampler 0: wrapT 1234 is not a glTF wrap mode")) << testing::PrintToString(odd.notes);
    // A sampler that does not exist is an error naming the texture and the sampler.
    try {
        with_samplers(R"([{"source":0,"sampler":5}])", "{}");
        ADD_FAILURE() << "a missing sampler was accepted";
    } catch (const scenes::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("texture 0: sampler 5 does not exist"), std::string::npos) << e.what();
    }
    // One image through two samplers, as base colour and emission: decoded once per way
    // of sampling it, once when both sample it alike.
    const std::string glow = R"("pbrMetallicRoughness":{"baseColorTexture":{"index":0}},"emissiveTexture":{"index":1},"emissiveFactor":[1,1,1])";
    const std::string two = R"([{"source":0,"sampler":0},{"source":0,"sampler":1}])";
    const scenes::Scene apart = with_samplers(two, R"({"wrapS":33071},{"wrapS":33648})", glow);
    ASSERT_EQ(apart.textures.size(), 2u);
    EXPECT_EQ(apart.textures[apart.materials[0].albedo_texture].wrap_s, TextureWrap::ClampToEdge);
    EXPECT_EQ(apart.textures[apart.materials[0].emission_texture].wrap_s, TextureWrap::MirroredRepeat);
    EXPECT_EQ(with_samplers(two, R"({"wrapS":33071},{"wrapS":33071})", glow).textures.size(), 1u);
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


// EXT_mesh_gpu_instancing: a unit cube placed 125 times, on a 5x5x5 grid, turned and
// scaled non-uniformly per instance; once by the extension's accessors, once as 125
// nodes with the same translation, rotation and scale, and once as 125 nodes each with
// its own copy of the mesh (so each is placed once and loaded in world space, as the
// loader did before instancing). The first two load as one prototype and 125 instances;
// flattened, all three are the same world-space triangles.
struct Placement {
    float t[3], r[4], s[3];
};

std::vector<Placement> grid_placements() {
    std::vector<Placement> out;
    for (int i = 0; i < 125; ++i) {
        const float a = 0.05f * float(i), half = 0.5f * a;
        // A unit quaternion about a tilted axis (1, 2, 2) / 3.
        const float sn = std::sin(half) / 3.0f;
        out.push_back({{float(i % 5) * 3.0f, float((i / 5) % 5) * 3.0f, float(i / 25) * 3.0f},
                       {sn, 2.0f * sn, 2.0f * sn, std::cos(half)},
                       {1.0f + 0.1f * float(i % 3), 0.5f, 2.0f - 0.01f * float(i)}});
    }
    return out;
}

/// A cube of 8 corners and 12 triangles at buffer offset 0, placed by 125 nodes
/// (`instanced` false) or by one node with EXT_mesh_gpu_instancing. `own_meshes`: the
/// 125 nodes reference 125 mesh entries (all on the same accessors) instead of one.
std::string cubes(bool instanced, bool own_meshes = false) {
    const std::vector<float> pos = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 1, 1, 0, 1, 1, 1, 1, 0, 1, 1};
    const std::vector<uint16_t> idx = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                       3, 6, 2, 3, 7, 6, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
    std::vector<uint8_t> bytes;
    auto put = [&](const void* p, size_t n) {
        const uint8_t* b = static_cast<const uint8_t*>(p);
        bytes.insert(bytes.end(), b, b + n);
    };
    put(pos.data(), pos.size() * 4);
    put(idx.data(), idx.size() * 2);
    const std::vector<Placement> pl = grid_placements();
    std::string nodes, extras;
    if (instanced) {
        for (const Placement& p : pl) put(p.t, 12);
        for (const Placement& p : pl) put(p.r, 16);
        for (const Placement& p : pl) put(p.s, 12);
        nodes = R"({"mesh":0,"extensions":{"EXT_mesh_gpu_instancing":{"attributes":{"TRANSLATION":2,"ROTATION":3,"SCALE":4}}}})";
        extras = R"(,{"bufferView":2,"componentType":5126,"count":125,"type":"VEC3"},)"
                 R"({"bufferView":3,"componentType":5126,"count":125,"type":"VEC4"},)"
                 R"({"bufferView":4,"componentType":5126,"count":125,"type":"VEC3"})";
    } else {
        auto list = [](const float* v, int n) {
            std::string o = "[";
            for (int k = 0; k < n; ++k) {
                if (k) o += ",";
                o += std::to_string(v[k]);  // not "," + to_string: GCC 12's -Wrestrict misfires on it
            }
            return o + "]";
        };
        for (size_t i = 0; i < pl.size(); ++i)
            nodes += std::string(i ? "," : "") + R"({"mesh":)" + std::to_string(own_meshes ? i : 0) +
                     R"(,"translation":)" + list(pl[i].t, 3) + R"(,"rotation":)" +
                     list(pl[i].r, 4) + R"(,"scale":)" + list(pl[i].s, 3) + "}";
    }
    std::string roots;
    for (size_t i = 0; i < (instanced ? 1u : pl.size()); ++i) {
        if (i) roots += ",";
        roots += std::to_string(i);
    }
    const size_t inst = instanced ? 125 * 40 : 0;
    std::string meshes;
    for (size_t i = 0; i < (own_meshes ? pl.size() : 1u); ++i)
        meshes += std::string(i ? "," : "") + R"({"primitives":[{"attributes":{"POSITION":0},"indices":1}]})";
    return R"({"asset":{"version":"2.0"},"extensionsUsed":["EXT_mesh_gpu_instancing"],"scene":0,"scenes":[{"nodes":[)" +
           roots + R"(]}],"nodes":[)" + nodes + R"(],"meshes":[)" + meshes + R"(],)"
           R"("accessors":[{"bufferView":0,"componentType":5126,"count":8,"type":"VEC3","min":[0,0,0],"max":[1,1,1]},)"
           R"({"bufferView":1,"componentType":5123,"count":36,"type":"SCALAR"})" + extras +
           R"(],"bufferViews":[{"buffer":0,"byteLength":96},{"buffer":0,"byteOffset":96,"byteLength":72})" +
           (instanced ? R"(,{"buffer":0,"byteOffset":168,"byteLength":1500},{"buffer":0,"byteOffset":1668,"byteLength":2000},)"
                        R"({"buffer":0,"byteOffset":3668,"byteLength":1500})"
                      : "") +
           R"(],"buffers":[{"byteLength":)" + std::to_string(168 + inst) +
           R"(,"uri":"data:application/octet-stream;base64,)" + draco_writer::base64(bytes) + R"("}]})";
}

// The 125 cubes placed by the extension render as the 125 written as nodes of their own
// meshes (loaded in world space, as before instancing), on every backend: the instanced
// file traced through two levels, the other flat, region means within their errors.
TEST(GltfGpuInstancing, RendersAsTheNodesOfOwnMeshesDo) {
    const auto dir = std::filesystem::temp_directory_path() / ("pt_cubes_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const std::string inst = (dir / "instanced.gltf").string(), own = (dir / "own.gltf").string();
    std::ofstream(inst) << cubes(true);
    std::ofstream(own) << cubes(false, true);
    renderer::IntegratorSettings is;
    is.max_depth = 2;
    for (const std::string& backend : accel::available_backends()) {
        if (backend == "naive") continue;  // 125 x 12 triangles per ray: the others suffice
        const renderer::Rendered a = renderer::render_file(inst, is, 40, 30, 16, 2, backend, 5);
        const renderer::Rendered b = renderer::render_file(own, is, 40, 30, 16, 2, backend, 5);
        renderer::expect_same_regions(a.result.image, b.result.image, 5, 4.0, backend + " EXT vs nodes");
        // Not a black frame: the cubes are seen and lit.
        double sum = 0;
        for (const renderer::Estimate& e : renderer::region_means(a.result.image, 5)) sum += e.mean;
        EXPECT_GT(sum, 0.1) << backend;
    }
    std::filesystem::remove_all(dir);
}

TEST(GltfGpuInstancing, PlacesEveryInstanceAsItsNodeTwinWould) {
    scenes::Scene inst = load(cubes(true), "instanced.gltf"), nodes = load(cubes(false), "nodes.gltf");
    const scenes::Scene before = load(cubes(false, true), "own.gltf");
    // One mesh placed 125 times, by the extension or by 125 nodes: one prototype, 125
    // instances, the cube stored once in object space.
    for (const scenes::Scene* s : {&inst, &nodes}) {
        SCOPED_TRACE(s->source);
        ASSERT_EQ(s->prototypes.size(), 1u);
        ASSERT_EQ(s->instances.size(), 125u);
        ASSERT_EQ(s->meshes.size(), 1u);
        EXPECT_EQ(s->num_triangles(), 12u);
        EXPECT_EQ(s->instanced_triangles(), 125u * 12u);
        EXPECT_EQ(s->meshes[0].positions[6].x, 1.0f) << "object space";
    }
    for (size_t i = 0; i < 125; ++i)
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 4; ++c)
                EXPECT_NEAR(inst.instances[i].object_to_world.m[r][c], nodes.instances[i].object_to_world.m[r][c], 2e-5f)
                    << "instance " << i;
    bool noted = false;
    for (const std::string& n : inst.notes) {
        EXPECT_EQ(n.find("extensions ignored"), std::string::npos) << n;
        noted = noted || n.find("instancing: 1 node places 125 instances of 1 mesh (1 node by "
                                "EXT_mesh_gpu_instancing)") == 0;
    }
    EXPECT_TRUE(noted);
    // The file whose nodes each have their own mesh is loaded as before instancing.
    ASSERT_TRUE(before.prototypes.empty());
    ASSERT_EQ(before.meshes.size(), 125u);
    scenes::flatten_instances(inst);
    scenes::flatten_instances(nodes);
    ASSERT_EQ(inst.meshes.size(), 125u);
    ASSERT_EQ(nodes.meshes.size(), 125u);
    for (size_t i = 0; i < 125; ++i) {
        ASSERT_EQ(inst.meshes[i].num_triangles(), 12u);
        ASSERT_EQ(inst.meshes[i].indices, before.meshes[i].indices) << "instance " << i;
        ASSERT_EQ(nodes.meshes[i].indices, before.meshes[i].indices) << "instance " << i;
        for (size_t v = 0; v < 8; ++v) {
            EXPECT_LT(dist(inst.meshes[i].positions[v], before.meshes[i].positions[v]), 2e-5f)
                << "instance " << i << " corner " << v;
            // The nodes file composes the same matrices as the old loader did: the same bits.
            EXPECT_EQ(nodes.meshes[i].positions[v].x, before.meshes[i].positions[v].x);
            EXPECT_EQ(nodes.meshes[i].positions[v].y, before.meshes[i].positions[v].y);
            EXPECT_EQ(nodes.meshes[i].positions[v].z, before.meshes[i].positions[v].z);
        }
    }
    // Non-uniform scale and rotation really moved the corners (the comparison above is not
    // between two identity placements).
    EXPECT_GT(dist(inst.meshes[7].positions[6], scenes::Vec3f{1, 1, 1}), 1.0f);
}

TEST(GltfGpuInstancing, ALoneInstanceIsLoadedInWorldSpace) {
    // One instance, and no other node places the mesh: flattened, as before instancing.
    std::string one = cubes(true);
    for (const char* a : {R"("count":125,"type":"VEC3"})", R"("count":125,"type":"VEC4"})"})
        for (size_t at = one.find(a); at != std::string::npos; at = one.find(a, at + 1))
            one[at + 8] = '1', one.erase(at + 9, 2);  // "125" -> "1" (replace() trips GCC 12's -Wrestrict)
    const scenes::Scene s = load(one, "one.gltf");
    EXPECT_TRUE(s.prototypes.empty());
    EXPECT_TRUE(s.instances.empty());
    ASSERT_EQ(s.meshes.size(), 1u);
    const scenes::Scene before = load(cubes(false, true), "own.gltf");
    for (size_t v = 0; v < 8; ++v) EXPECT_LT(dist(s.meshes[0].positions[v], before.meshes[0].positions[v]), 2e-5f);
    bool noted = false;
    for (const std::string& n : s.notes) noted = noted || n.find("EXT_mesh_gpu_instancing: 1 node places the only instance") == 0;
    EXPECT_TRUE(noted);
}

TEST(GltfGpuInstancing, InstanceLimitAndHostileCountsFailNamingTheNode) {
    scenes::GltfLimits limits;
    limits.max_instances = 100;
    const std::string text = cubes(true);
    try {
        scenes::load_gltf_memory(text.data(), text.size(), "many.gltf", "/nonexistent", false, limits);
        FAIL() << "125 instances accepted past a limit of 100";
    } catch (const scenes::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("many.gltf: node 0: scene too large (more than 100 instances)"),
                  std::string::npos)
            << e.what();
    }
    // A count the buffer cannot hold is refused before anything is allocated for it.
    std::string huge = cubes(true);
    const std::string t = R"({"bufferView":2,"componentType":5126,"count":125,"type":"VEC3"})";
    huge.replace(huge.find(t), t.size(), R"({"bufferView":2,"componentType":5126,"count":4000000000,"type":"VEC3"})");
    try {
        load(huge, "huge.gltf");
        FAIL() << "an accessor count past its bufferView accepted";
    } catch (const scenes::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("accessor 2: 4000000000 elements"), std::string::npos) << e.what();
    }
}

TEST(GltfGpuInstancing, MismatchedCountsAndBadAccessorsFailNamingTheNode) {
    std::string bad = cubes(true);
    const std::string vec4 = R"({"bufferView":3,"componentType":5126,"count":125,"type":"VEC4"})";
    bad.replace(bad.find(vec4), vec4.size(), R"({"bufferView":3,"componentType":5126,"count":124,"type":"VEC4"})");
    try {
        load(bad, "bad.gltf");
        FAIL() << "mismatched instance counts accepted";
    } catch (const scenes::SceneError& e) {
        EXPECT_NE(std::string(e.what()).find("node 0: EXT_mesh_gpu_instancing: ROTATION has 124 instances"),
                  std::string::npos)
            << e.what();
    }
    std::string noattr = cubes(true);
    noattr.replace(noattr.find(R"("TRANSLATION":2)"), 15, R"("TRANSLATION":9)");
    EXPECT_THROW(load(noattr, "bad.gltf"), scenes::SceneError);
}

}  // namespace
