#include "scenes/image/image.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <vector>

#include <tiny_gltf.h>

namespace scenes::image {
namespace {

uint32_t be32(const unsigned char* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}
uint32_t be16(const unsigned char* p) { return (uint32_t(p[0]) << 8) | p[1]; }

bool peek_jpeg(const unsigned char* b, size_t n, uint32_t& w, uint32_t& h) {
    size_t i = 2;  // after SOI
    while (i + 4 <= n) {
        if (b[i] != 0xFF) return false;
        unsigned char marker = b[i + 1];
        if (marker == 0xFF) {  // fill byte
            ++i;
            continue;
        }
        if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {  // no length field
            i += 2;
            continue;
        }
        if (marker == 0xD9 || marker == 0xDA) return false;  // EOI/SOS before any SOF
        uint32_t len = be16(b + i + 2);
        if (len < 2) return false;
        bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 &&
                   marker != 0xCC;
        if (sof) {
            if (i + 9 > n) return false;
            h = be16(b + i + 5);
            w = be16(b + i + 7);
            return true;
        }
        i += 2 + len;
    }
    return false;
}

}  // namespace

bool peek_image_size(const unsigned char* b, size_t n, uint32_t& w, uint32_t& h,
                     std::string& why) {
    static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    if (n >= 8 && std::equal(kPng, kPng + 8, b)) {
        if (n < 24 || std::string(reinterpret_cast<const char*>(b + 12), 4) != "IHDR") {
            why = "truncated PNG header";
            return false;
        }
        w = be32(b + 16);
        h = be32(b + 20);
        return true;
    }
    if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) {
        if (!peek_jpeg(b, n, w, h)) {
            why = "malformed JPEG header (no frame header found)";
            return false;
        }
        return true;
    }
    why = "not a PNG or JPEG image";
    return false;
}

namespace {

/// Linear value to the nearest 8-bit sRGB code, through a 16-bit table: its step,
/// 1/65535 in linear, is at most 0.05 of an 8-bit code where the curve is steepest (the
/// 12.92 slope near black), so the table rounds as the exact curve does but for ties.
const std::vector<uint8_t>& linear_to_srgb8_table() {
    static const std::vector<uint8_t> table = [] {
        std::vector<uint8_t> t(65536);
        for (size_t i = 0; i < t.size(); ++i) {
            const float l = float(i) / 65535.0f;
            const float s = l <= 0.0031308f ? 12.92f * l : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
            t[i] = uint8_t(std::clamp(s * 255.0f + 0.5f, 0.0f, 255.0f));
        }
        return t;
    }();
    return table;
}

/// Level sizes down to 1x1 and one buffer for all of them: allocated once, so building
/// the pyramid never holds two copies of level 0.
void lay_out_levels(Texture& t) {
    t.levels.clear();
    uint32_t w = t.width, h = t.height;
    uint64_t offset = 0;
    for (;;) {
        t.levels.push_back(Texture::Level{w, h, offset});
        offset += uint64_t(w) * h * t.texel_bytes();
        if (w == 1 && h == 1) break;
        w = std::max(1u, w / 2);
        h = std::max(1u, h / 2);
    }
    t.data.assign(size_t(offset), 0);
}

/// Fills levels 1.. from level 0 (Williams 1983: each level the 2x2 box of the one above).
void fill_levels(Texture& t) {
    const size_t nc = t.channels, cb = texel_format_bytes(t.format);
    // Stored channels that hold sRGB-encoded colour: all but a stored alpha.
    const size_t ncolour = t.srgb ? (t.slot[3] >= 0 ? nc - 1 : nc) : 0;
    const auto& lut = srgb8_to_linear();
    const auto& enc = linear_to_srgb8_table();
    auto load = [&](const uint8_t* p, size_t c) -> float {
        switch (t.format) {
            case TexelFormat::U8: return c < ncolour ? lut[p[c]] : float(p[c]) / 255.0f;
            case TexelFormat::U16: {
                uint16_t v;
                std::memcpy(&v, p + 2 * c, 2);
                return float(v) / 65535.0f;
            }
            case TexelFormat::F16: {
                uint16_t v;
                std::memcpy(&v, p + 2 * c, 2);
                return half_to_float(v);
            }
            case TexelFormat::F32: {
                float v;
                std::memcpy(&v, p + 4 * c, 4);
                return v;
            }
        }
        return 0.0f;
    };
    auto store = [&](uint8_t* p, size_t c, float v) {
        switch (t.format) {
            case TexelFormat::U8:
                p[c] = c < ncolour ? enc[size_t(std::clamp(v, 0.0f, 1.0f) * 65535.0f + 0.5f)]
                                   : uint8_t(std::clamp(v * 255.0f + 0.5f, 0.0f, 255.0f));
                break;
            case TexelFormat::U16: {
                const uint16_t u = uint16_t(std::clamp(v * 65535.0f + 0.5f, 0.0f, 65535.0f));
                std::memcpy(p + 2 * c, &u, 2);
                break;
            }
            case TexelFormat::F16: {
                const uint16_t u = float_to_half(v);
                std::memcpy(p + 2 * c, &u, 2);
                break;
            }
            case TexelFormat::F32: std::memcpy(p + 4 * c, &v, 4); break;
        }
    };
    (void)cb;
    // Each level averages the unrounded values of the one above (kept as floats while
    // the next is built), so every level is within half a code of the exact average:
    // rounding once per level, not once per level above it.
    std::vector<float> above, here;
    for (size_t l = 1; l < t.levels.size(); ++l) {
        const Texture::Level& src = t.levels[l - 1];
        const Texture::Level& dst = t.levels[l];
        here.assign(size_t(dst.width) * dst.height * nc, 0.0f);
        auto value = [&](uint32_t x, uint32_t y, size_t ch) {
            return above.empty() ? load(t.texel(uint32_t(l - 1), x, y), ch) : above[(size_t(y) * src.width + x) * nc + ch];
        };
        for (uint32_t y = 0; y < dst.height; ++y) {
            const uint32_t y0 = std::min(src.height - 1, 2 * y), y1 = std::min(src.height - 1, 2 * y + 1);
            for (uint32_t x = 0; x < dst.width; ++x) {
                const uint32_t x0 = std::min(src.width - 1, 2 * x), x1 = std::min(src.width - 1, 2 * x + 1);
                uint8_t* o = t.data.data() + dst.offset + (size_t(y) * dst.width + x) * t.texel_bytes();
                for (size_t ch = 0; ch < nc; ++ch) {
                    const float v = 0.25f * (value(x0, y0, ch) + value(x1, y0, ch) + value(x0, y1, ch) + value(x1, y1, ch));
                    here[(size_t(y) * dst.width + x) * nc + ch] = v;
                    store(o, ch, v);
                }
            }
        }
        std::swap(above, here);
    }
}

}  // namespace

void build_mip_pyramid(Texture& t) {
    if (t.empty() || t.width == 0 || t.height == 0) return;
    std::vector<uint8_t> level0 = std::move(t.data);
    const size_t bytes0 = size_t(t.width) * t.height * t.texel_bytes();
    lay_out_levels(t);
    std::memcpy(t.data.data(), level0.data(), std::min(bytes0, level0.size()));
    level0 = {};
    fill_levels(t);
}

bool read_regular_file(const std::string& path, uint64_t max_bytes, std::vector<unsigned char>& out,
                       std::string& why) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec)) {
        why = "not a regular file";
        return false;
    }
    const uint64_t size = std::filesystem::file_size(path, ec);
    if (ec || size > max_bytes) {
        why = ec ? ec.message() : "file too large";
        return false;
    }
    std::ifstream f(path, std::ios::binary);
    out.resize(size_t(size));
    if (!f || (size > 0 && !f.read(reinterpret_cast<char*>(out.data()), std::streamsize(size)))) {
        why = "read failed";
        return false;
    }
    return true;
}

bool decode_texture(const unsigned char* bytes, size_t size, const char* channels, bool srgb,
                    Texture& out, std::string& why) {
    uint32_t w = 0, h = 0;
    if (!peek_image_size(bytes, size, w, h, why)) return false;
    if (w == 0 || h == 0 || uint64_t(w) * h > kMaxImagePixels) {
        why = "unsupported image size " + std::to_string(w) + "x" + std::to_string(h);
        return false;
    }
    if (size > size_t(std::numeric_limits<int>::max())) {
        why = "image data too large";
        return false;
    }
    tinygltf::Image img;
    std::string err, warn;
    // tinygltf's default loader is stb_image, forced to RGBA (8 or 16 bit); passing no
    // user data selects those defaults.
    if (!tinygltf::LoadImageData(&img, 0, &err, &warn, 0, 0, bytes, int(size), nullptr)) {
        why = "cannot decode image";
        return false;
    }
    if (img.width <= 0 || img.height <= 0 || img.component != 4 ||
        (img.bits != 8 && img.bits != 16) ||
        img.image.size() != size_t(img.width) * size_t(img.height) * 4 * size_t(img.bits / 8)) {
        why = "decoder returned an unexpected pixel layout";
        return false;
    }
    const size_t npix = size_t(img.width) * size_t(img.height);
    const size_t cb = size_t(img.bits / 8);
    auto sample = [&](size_t p, size_t c) -> uint32_t {
        if (cb == 1) return img.image[p * 4 + c];
        uint16_t v;
        std::memcpy(&v, &img.image[(p * 4 + c) * 2], 2);  // stb returns native-endian uint16
        return v;
    };
    // Alpha is worth its byte only where some pixel is not opaque.
    std::string list;
    for (const char* c = channels; *c; ++c) {
        if (*c == 'A') {
            const uint32_t opaque = cb == 1 ? 255u : 65535u;
            bool all_opaque = true;
            for (size_t p = 0; p < npix && all_opaque; ++p) all_opaque = sample(p, 3) == opaque;
            if (all_opaque) continue;
        }
        list += *c;
    }
    out = Texture::make(out.name, uint32_t(img.width), uint32_t(img.height),
                        cb == 1 ? TexelFormat::U8 : TexelFormat::U16, list.c_str());
    // sRGB stays encoded at 8 bits (decoded on lookup through a 256-entry table); a
    // 16-bit sRGB image is decoded here, as a table of 65536 floats per lookup would not
    // pay for the rare 16-bit colour texture.
    out.srgb = srgb && cb == 1;
    lay_out_levels(out);
    int src[4];
    for (int c = 0; c < 4; ++c)
        if (out.slot[c] >= 0) src[out.slot[c]] = c;
    uint8_t* dst = out.data.data();
    for (size_t p = 0; p < npix; ++p)
        for (size_t k = 0; k < out.channels; ++k) {
            const size_t c = size_t(src[k]);
            if (cb == 1) {
                *dst++ = uint8_t(sample(p, c));
            } else {
                uint32_t v = sample(p, c);
                if (srgb && c < 3)
                    v = uint32_t(std::clamp(srgb_to_linear(float(v) / 65535.0f) * 65535.0f + 0.5f, 0.0f, 65535.0f));
                const uint16_t u = uint16_t(v);
                std::memcpy(dst, &u, 2);
                dst += 2;
            }
        }
    img.image = {};
    fill_levels(out);
    return true;
}

}  // namespace scenes::image
