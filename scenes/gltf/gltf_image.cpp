#include "scenes/gltf/gltf_image.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>

#include <tiny_gltf.h>

namespace scenes::gltf_detail {
namespace {

uint32_t be32(const unsigned char* p) {
    return (uint32_t(p[0]) << 24) | (uint32_t(p[1]) << 16) | (uint32_t(p[2]) << 8) | p[3];
}
uint32_t be16(const unsigned char* p) { return (uint32_t(p[0]) << 8) | p[1]; }

float srgb_to_linear(float c) {
    return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

const std::array<float, 256>& srgb8_table() {
    static const std::array<float, 256> table = [] {
        std::array<float, 256> t{};
        for (int i = 0; i < 256; ++i) t[size_t(i)] = srgb_to_linear(float(i) / 255.0f);
        return t;
    }();
    return table;
}

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

bool decode_srgb_texture(const unsigned char* bytes, size_t size, Texture& out,
                         std::string& why, bool srgb) {
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
    out.width = uint32_t(img.width);
    out.height = uint32_t(img.height);
    size_t npix = size_t(out.width) * out.height;
    out.rgb.resize(npix * 3);
    if (img.bits == 8) {
        const auto& lut = srgb8_table();
        for (size_t p = 0; p < npix; ++p)
            for (int c = 0; c < 3; ++c) {
                const uint8_t v = img.image[p * 4 + size_t(c)];
                out.rgb[p * 3 + size_t(c)] = srgb ? lut[v] : float(v) / 255.0f;
            }
    } else {
        for (size_t p = 0; p < npix; ++p)
            for (int c = 0; c < 3; ++c) {
                size_t o = (p * 4 + size_t(c)) * 2;
                uint16_t v;
                std::memcpy(&v, &img.image[o], 2);  // stb returns native-endian uint16
                const float x = float(v) / 65535.0f;
                out.rgb[p * 3 + size_t(c)] = srgb ? srgb_to_linear(x) : x;
            }
    }
    return true;
}

}  // namespace scenes::gltf_detail
