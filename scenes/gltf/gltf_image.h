// Image decoding for the glTF loader: PNG/JPEG bytes -> linear float RGB Texture.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "scenes/scene.h"

namespace scenes::gltf_detail {

/// Largest decoded image we accept (pixels). A float RGB texture costs 12 bytes per
/// pixel, so this bounds one texture at ~800 MB; a header claiming more is bad input,
/// and refusing it before stb allocates keeps hostile files from exhausting memory.
inline constexpr uint64_t kMaxImagePixels = uint64_t(1) << 26;

/// Reads width/height from a PNG or JPEG header without decoding. Returns false (and
/// sets `why`) for other formats or a malformed header.
bool peek_image_size(const unsigned char* bytes, size_t size, uint32_t& width,
                     uint32_t& height, std::string& why);

/// Decodes PNG/JPEG bytes (8 or 16 bit) and converts sRGB to linear float RGB; alpha is
/// dropped. Returns false with `why` on failure. Never throws for bad data. With
/// `srgb` false the values stay as stored (data textures: metallic-roughness, normal,
/// transmission).
bool decode_srgb_texture(const unsigned char* bytes, size_t size, Texture& out,
                         std::string& why, bool srgb = true);

}  // namespace scenes::gltf_detail
