// Writes small glTF files with KHR_draco_mesh_compression, and their uncompressed twins,
// from a mesh built here with Draco's encoder. Used by the Draco tests and to make the
// fuzzing seeds (tests/fuzz/make_draco_seeds.cpp); no Draco file is downloaded.
#pragma once

#include <cmath>
#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include <draco/compression/encode.h>
#include <draco/mesh/mesh.h>

namespace draco_writer {

struct SourceMesh {
    std::vector<float> positions, normals, uvs;  // 3, 3, 2 per vertex
    std::vector<uint32_t> indices;
};

/// A bumpy (nx x ny)-quad grid: distinct positions, normals and uvs per vertex.
inline SourceMesh grid(int nx, int ny) {
    SourceMesh m;
    for (int j = 0; j <= ny; ++j)
        for (int i = 0; i <= nx; ++i) {
            float u = float(i) / float(nx), v = float(j) / float(ny);
            float x = 2.0f * u - 1.0f, y = 2.0f * v - 1.0f;
            float z = 0.25f * std::sin(3.0f * x) * std::cos(2.0f * y);
            m.positions.insert(m.positions.end(), {x, y, z});
            float gx = -0.75f * std::cos(3.0f * x) * std::cos(2.0f * y);
            float gy = 0.5f * std::sin(3.0f * x) * std::sin(2.0f * y);
            float len = std::sqrt(gx * gx + gy * gy + 1.0f);
            m.normals.insert(m.normals.end(), {gx / len, gy / len, 1.0f / len});
            m.uvs.insert(m.uvs.end(), {u, 1.0f - v});
        }
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i) {
            uint32_t a = uint32_t(j * (nx + 1) + i), b = a + 1, c = a + uint32_t(nx + 1), d = c + 1;
            m.indices.insert(m.indices.end(), {a, b, d, a, d, c});
        }
    return m;
}

inline std::string base64(const std::vector<uint8_t>& in) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (size_t i = 0; i < in.size(); i += 3) {
        uint32_t n = uint32_t(in[i]) << 16;
        if (i + 1 < in.size()) n |= uint32_t(in[i + 1]) << 8;
        if (i + 2 < in.size()) n |= in[i + 2];
        out += t[(n >> 18) & 63];
        out += t[(n >> 12) & 63];
        out += i + 1 < in.size() ? t[(n >> 6) & 63] : '=';
        out += i + 2 < in.size() ? t[n & 63] : '=';
    }
    return out;
}

struct Ids {
    int position = -1, normal = -1, texcoord = -1;
};

/// Encodes with Draco (edgebreaker, quantized). Draco may reorder the points.
inline std::vector<uint8_t> encode(const SourceMesh& s, bool with_normals, bool with_uvs, Ids& ids,
                                   int speed = 5) {
    draco::Mesh mesh;
    const size_t nv = s.positions.size() / 3;
    mesh.set_num_points(uint32_t(nv));
    auto add = [&](draco::GeometryAttribute::Type type, const std::vector<float>& values, int nc) {
        draco::GeometryAttribute ga;
        ga.Init(type, nullptr, int8_t(nc), draco::DT_FLOAT32, false, int64_t(sizeof(float)) * nc, 0);
        int id = mesh.AddAttribute(ga, true, uint32_t(nv));
        for (size_t i = 0; i < nv; ++i)
            mesh.attribute(id)->SetAttributeValue(draco::AttributeValueIndex(uint32_t(i)),
                                                  &values[i * size_t(nc)]);
        return int(mesh.attribute(id)->unique_id());
    };
    ids.position = add(draco::GeometryAttribute::POSITION, s.positions, 3);
    if (with_normals) ids.normal = add(draco::GeometryAttribute::NORMAL, s.normals, 3);
    if (with_uvs) ids.texcoord = add(draco::GeometryAttribute::TEX_COORD, s.uvs, 2);
    for (size_t f = 0; f < s.indices.size() / 3; ++f)
        mesh.AddFace({draco::PointIndex(s.indices[3 * f]), draco::PointIndex(s.indices[3 * f + 1]),
                      draco::PointIndex(s.indices[3 * f + 2])});
    draco::Encoder enc;
    enc.SetAttributeQuantization(draco::GeometryAttribute::POSITION, 14);
    enc.SetAttributeQuantization(draco::GeometryAttribute::NORMAL, 10);
    enc.SetAttributeQuantization(draco::GeometryAttribute::TEX_COORD, 12);
    enc.SetSpeedOptions(speed, speed);
    draco::EncoderBuffer buf;
    if (!enc.EncodeMeshToBuffer(mesh, &buf).ok()) return {};
    return std::vector<uint8_t>(buf.data(), buf.data() + buf.size());
}

/// 1x1 white PNG, so a textured material makes the loader read TEXCOORD_0.
inline const char* kWhitePng =
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAIAAACQd1PeAAAADElEQVR4nGP4//8/AAX+Av4N70a4AAAAAElFTkSuQmCC";

inline std::string material_json(bool textured) {
    std::string m = R"("materials":[{"name":"m","pbrMetallicRoughness":{"baseColorFactor":[0.8,0.8,0.8,1])";
    if (textured) m += R"(,"baseColorTexture":{"index":0})";
    m += "}}]";
    if (textured)
        m += std::string(R"(,"textures":[{"source":0}],"images":[{"uri":"data:image/png;base64,)") +
             kWhitePng + "\"}]";
    return m;
}

/// The Draco-compressed glTF (embedded buffer); accessors carry no bufferView.
inline std::string draco_gltf(const SourceMesh& s, bool with_normals, bool textured, int speed = 5) {
    Ids ids;
    std::vector<uint8_t> bytes = encode(s, with_normals, textured, ids, speed);
    const size_t nv = s.positions.size() / 3, ni = s.indices.size();
    std::string attrs = "\"POSITION\":0", dattrs = "\"POSITION\":" + std::to_string(ids.position);
    std::string acc = R"({"componentType":5126,"count":)" + std::to_string(nv) +
                      R"(,"type":"VEC3","min":[-1,-1,-1],"max":[1,1,1]})";
    acc += R"(,{"componentType":5125,"count":)" + std::to_string(ni) + R"(,"type":"SCALAR"})";
    int next = 2;
    if (with_normals) {
        attrs += ",\"NORMAL\":" + std::to_string(next++);
        dattrs += ",\"NORMAL\":" + std::to_string(ids.normal);
        acc += R"(,{"componentType":5126,"count":)" + std::to_string(nv) + R"(,"type":"VEC3"})";
    }
    if (textured) {
        attrs += ",\"TEXCOORD_0\":" + std::to_string(next++);
        dattrs += ",\"TEXCOORD_0\":" + std::to_string(ids.texcoord);
        acc += R"(,{"componentType":5126,"count":)" + std::to_string(nv) + R"(,"type":"VEC2"})";
    }
    return R"({"asset":{"version":"2.0"},"extensionsUsed":["KHR_draco_mesh_compression"],)"
           R"("extensionsRequired":["KHR_draco_mesh_compression"],"scene":0,"scenes":[{"nodes":[0]}],)"
           R"("nodes":[{"mesh":0}],"meshes":[{"name":"grid","primitives":[{"attributes":{)" +
           attrs + R"(},"indices":1,"material":0,"extensions":{"KHR_draco_mesh_compression":)"
                   R"({"bufferView":0,"attributes":{)" +
           dattrs + "}}}}]}],\"accessors\":[" + acc +
           R"(],"bufferViews":[{"buffer":0,"byteLength":)" + std::to_string(bytes.size()) +
           R"(}],"buffers":[{"byteLength":)" + std::to_string(bytes.size()) +
           R"(,"uri":"data:application/octet-stream;base64,)" + base64(bytes) + "\"}]," +
           material_json(textured) + "}";
}

/// The same mesh without compression (float attributes, uint32 indices).
inline std::string plain_gltf(const SourceMesh& s, bool with_normals, bool textured) {
    std::vector<uint8_t> bytes;
    auto put = [&](const void* p, size_t n) {
        const uint8_t* b = static_cast<const uint8_t*>(p);
        bytes.insert(bytes.end(), b, b + n);
    };
    const size_t nv = s.positions.size() / 3, ni = s.indices.size();
    std::string views, acc, attrs;
    int k = 0;
    auto view = [&](const void* p, size_t n, const std::string& type, int ct, size_t count) {
        size_t off = bytes.size();
        put(p, n);
        views += std::string(k ? "," : "") + R"({"buffer":0,"byteOffset":)" + std::to_string(off) +
                 R"(,"byteLength":)" + std::to_string(n) + "}";
        acc += std::string(k ? "," : "") + R"({"bufferView":)" + std::to_string(k) +
               R"(,"componentType":)" + std::to_string(ct) + R"(,"count":)" + std::to_string(count) +
               R"(,"type":")" + type + "\"" +
               (type == "VEC3" && k == 0 ? R"(,"min":[-1,-1,-1],"max":[1,1,1])" : "") + "}";
        return k++;
    };
    attrs = "\"POSITION\":" + std::to_string(view(s.positions.data(), nv * 12, "VEC3", 5126, nv));
    int ind = view(s.indices.data(), ni * 4, "SCALAR", 5125, ni);
    if (with_normals)
        attrs += ",\"NORMAL\":" + std::to_string(view(s.normals.data(), nv * 12, "VEC3", 5126, nv));
    if (textured)
        attrs += ",\"TEXCOORD_0\":" + std::to_string(view(s.uvs.data(), nv * 8, "VEC2", 5126, nv));
    return R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],)"
           R"("meshes":[{"name":"grid","primitives":[{"attributes":{)" +
           attrs + R"(},"indices":)" + std::to_string(ind) + R"(,"material":0}]}],"accessors":[)" +
           acc + "],\"bufferViews\":[" + views + R"(],"buffers":[{"byteLength":)" +
           std::to_string(bytes.size()) + R"(,"uri":"data:application/octet-stream;base64,)" +
           base64(bytes) + "\"}]," + material_json(textured) + "}";
}

inline bool write(const std::string& path, const std::string& text) {
    std::ofstream f(path, std::ios::binary);
    f << text;
    return bool(f);
}

}  // namespace draco_writer
