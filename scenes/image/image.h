// Image decoding for the loaders (glTF's textures, COLLADA's diffuse images): PNG/JPEG
// bytes -> a Texture at the image's own precision, with its MIP pyramid.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "scenes/scene.h"

namespace scenes::image {

/// Largest decoded image we accept (pixels). Decoding goes through an RGBA buffer of up
/// to 8 bytes per pixel, so this bounds one image at ~512 MB while it decodes; a header
/// claiming more is bad input, and refusing it before stb allocates keeps hostile files
/// from exhausting memory.
inline constexpr uint64_t kMaxImagePixels = uint64_t(1) << 26;

/// The whole of the file at `path`, the loaders' external files (glTF buffers and images,
/// COLLADA images): only a regular file (a FIFO or device a hostile document names would
/// block or never end) of at most `max_bytes`. False with `why` otherwise.
bool read_regular_file(const std::string& path, uint64_t max_bytes, std::vector<unsigned char>& out,
                       std::string& why);

/// Reads width/height from a PNG or JPEG header without decoding. Returns false (and
/// sets `why`) for other formats or a malformed header.
bool peek_image_size(const unsigned char* bytes, size_t size, uint32_t& width,
                     uint32_t& height, std::string& why);

/// Decodes PNG/JPEG bytes (8 or 16 bit) into a Texture at the source's precision (U8 or
/// U16) holding only the source channels `channels` names (e.g. "RGB", "GB", "R"; an
/// "A" is kept only when some pixel is not opaque), then builds its MIP pyramid. With
/// `srgb` the R, G, B values stay sRGB-encoded and are decoded on lookup (base colour,
/// emissive); otherwise they are linear (metallic-roughness, normal, transmission).
/// Returns false with `why` on failure. Never throws for bad data.
bool decode_texture(const unsigned char* bytes, size_t size, const char* channels, bool srgb,
                    Texture& out, std::string& why);

/// Appends the MIP pyramid to a texture that holds level 0 alone: each level halves the
/// one above (at least 1 texel) with a 2x2 box, averaged in linear values (sRGB texels
/// decoded, averaged, re-encoded), as in Williams, "Pyramidal parametrics" (SIGGRAPH
/// 1983). An odd size drops the last row or column of the finer level: glTF's textures
/// are powers of two in practice, and the alternative (pbrt-v4 resamples to a power of
/// two first) would double the memory of a large odd-sized image while it is built.
void build_mip_pyramid(Texture& t);

}  // namespace scenes::image
