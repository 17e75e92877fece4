// KHR_draco_mesh_compression for the glTF loader, decoded with Google's Draco
// (Debian libdraco-dev). Debian's tinygltf is a prebuilt library without its Draco hook,
// and that hook trusts the file (unchecked indices, null attributes), so the extension
// is decoded here from the raw bufferView, after the loader has validated its range.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace scenes::gltf_detail {

/// A decoded Draco primitive: float attributes by glTF semantic, triangle list.
struct DracoPrimitive {
    size_t num_points = 0;
    std::map<std::string, std::vector<float>> attributes;  // num_points * components each
    std::vector<uint32_t> triangles;
};

/// Decodes `size` bytes of Draco mesh data. `wanted` maps each glTF semantic to its
/// Draco attribute id and the number of components the glTF accessor declares.
/// `max_elements` bounds points + 3 * faces. Returns "" or a message naming the
/// problem (never throws for bad data).
std::string decode_draco(const unsigned char* data, size_t size,
                         const std::map<std::string, std::pair<int, int>>& wanted,
                         uint64_t max_elements, DracoPrimitive& out);

/// tinygltf refuses an `indices` accessor without a bufferView, which is exactly how
/// Draco primitives describe theirs. In the JSON text `json` (modified in place), the
/// key `"indices"` of each primitive carrying KHR_draco_mesh_compression is renamed to
/// a key of the same length that tinygltf ignores; byte lengths (and so GLB chunk
/// offsets) do not change. Returns the number of keys renamed.
size_t hide_draco_indices(unsigned char* json, size_t size);

/// True when the bytes mention the extension at all (a cheap pre-check, so files
/// without Draco are never copied or rescanned).
bool mentions_draco(const unsigned char* data, size_t size);

}  // namespace scenes::gltf_detail
