#include "scenes/gltf/gltf_draco.h"

#include <cmath>
#include <cstring>
#include <memory>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>

namespace scenes::gltf_detail {

constexpr char kDracoExt[] = "KHR_draco_mesh_compression";

std::string decode_draco(const unsigned char* data, size_t size,
                         const std::map<std::string, std::pair<int, int>>& wanted,
                         uint64_t max_elements, DracoPrimitive& out) {
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char*>(data), size);
    auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
    if (!type.ok()) return "Draco data: " + type.status().error_msg_string();
    if (type.value() != draco::TRIANGULAR_MESH)
        return "Draco data is a point cloud, not a triangle mesh";
    draco::Decoder decoder;
    auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
    if (!decoded.ok()) return "Draco data: " + decoded.status().error_msg_string();
    const std::unique_ptr<draco::Mesh>& mesh = decoded.value();
    if (!mesh) return "Draco data: no mesh decoded";
    const uint64_t np = mesh->num_points(), nf = mesh->num_faces();
    if (np + 3 * nf > max_elements) return "Draco mesh too large";
    out.num_points = size_t(np);
    for (const auto& [semantic, id_components] : wanted) {
        const auto [id, components] = id_components;
        const draco::PointAttribute* a =
            id < 0 ? nullptr : mesh->GetAttributeByUniqueId(uint32_t(id));
        if (!a) return semantic + ": Draco attribute id " + std::to_string(id) + " does not exist";
        if (a->num_components() < components)
            return semantic + ": Draco attribute " + std::to_string(id) + " has " +
                   std::to_string(int(a->num_components())) + " components, expected " +
                   std::to_string(components);
        std::vector<float>& values = out.attributes[semantic];
        values.resize(size_t(np) * size_t(components));
        for (draco::PointIndex p(0); p < mesh->num_points(); ++p) {
            const draco::AttributeValueIndex v = a->mapped_index(p);
            float* dst = values.data() + size_t(p.value()) * size_t(components);
            if (v.value() >= a->size() ||
                !a->ConvertValue<float>(v, int8_t(components), dst))
                return semantic + ": Draco attribute " + std::to_string(id) +
                       " has no value for point " + std::to_string(p.value());
            for (int c = 0; c < components; ++c)
                if (!std::isfinite(dst[c]))
                    return semantic + ": Draco attribute " + std::to_string(id) + " point " +
                           std::to_string(p.value()) + " is not finite";
        }
    }
    out.triangles.resize(size_t(nf) * 3);
    for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
        for (int k = 0; k < 3; ++k) {
            const uint32_t i = mesh->face(f)[k].value();
            if (i >= np)
                return "Draco face " + std::to_string(f.value()) + " refers to point " +
                       std::to_string(i) + " of " + std::to_string(np);
            out.triangles[size_t(f.value()) * 3 + size_t(k)] = i;
        }
    return "";
}

bool mentions_draco(const unsigned char* data, size_t size) {
    const size_t n = sizeof(kDracoExt) - 1;
    for (size_t i = 0; i + n <= size; ++i)
        if (data[i] == 'K' && std::memcmp(data + i, kDracoExt, n) == 0) return true;
    return false;
}

namespace {

/// One open JSON container while scanning.
struct Frame {
    bool object = false;
    std::string name;        // key under which the parent holds it ("" in arrays)
    bool expect_key = false;
    std::string key;         // last key read in this object
    size_t indices_at = 0;   // offset of the "indices" key + 1 (0 = none)
    bool draco = false;
};

}  // namespace

size_t hide_draco_indices(unsigned char* s, size_t n) {
    std::vector<Frame> stack;
    size_t renamed = 0;
    for (size_t i = 0; i < n; ++i) {
        const unsigned char c = s[i];
        if (c == '"') {
            const size_t start = i++;
            while (i < n && s[i] != '"') i += s[i] == '\\' ? 2 : 1;
            if (i >= n) return renamed;
            if (!stack.empty() && stack.back().object && stack.back().expect_key) {
                Frame& f = stack.back();
                f.key.assign(reinterpret_cast<const char*>(s + start + 1), i - start - 1);
                f.expect_key = false;
                const size_t d = stack.size();
                // primitive object: root{ meshes[ {mesh primitives[ {primitive
                if (d == 5 && stack[1].name == "meshes" && stack[3].name == "primitives" &&
                    f.key == "indices")
                    f.indices_at = start + 1;
                if (d == 6 && f.name == "extensions" && stack[1].name == "meshes" &&
                    stack[3].name == "primitives" && f.key == kDracoExt)
                    stack[4].draco = true;
            }
        } else if (c == '{' || c == '[') {
            std::string name;
            if (!stack.empty() && stack.back().object) name = stack.back().key;
            stack.emplace_back();
            stack.back().object = c == '{';
            stack.back().name = std::move(name);
            stack.back().expect_key = c == '{';
            if (stack.size() > 64) return renamed;  // the loader refuses such depth anyway
        } else if (c == '}' || c == ']') {
            if (stack.empty()) return renamed;
            Frame f = std::move(stack.back());
            stack.pop_back();
            if (f.object && f.draco && f.indices_at) {
                std::memcpy(s + f.indices_at, "dracoIx", 7);  // same length as indices
                ++renamed;
            }
        } else if (c == ',') {
            if (!stack.empty() && stack.back().object) stack.back().expect_key = true;
        }
    }
    return renamed;
}

}  // namespace scenes::gltf_detail
