// The parts of renderer/image.h that need no image library: every program links them, and
// the pathtracer checks its outputs with them before the image module is ever loaded.
#include <algorithm>
#include <array>
#include <cctype>
#include <filesystem>
#include <string>

#include "renderer/image.h"

namespace renderer {
namespace {
std::string lower_ext(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return e;
}
}  // namespace

bool is_float_format(const std::string& path) { return lower_ext(path) == ".exr"; }

bool is_writable_image_format(const std::string& path) {
    // Formats Debian's OpenImageIO writes; the test ImageFormats.EveryListedExtensionHasAWriter
    // keeps this list honest against the library.
    static constexpr std::array<const char*, 12> kWritable = {
        ".exr", ".png", ".jpg", ".jpeg", ".tif", ".tiff", ".tga", ".bmp", ".hdr", ".ppm", ".pnm", ".webp"};
    const std::string e = lower_ext(path);
    return std::find(kWritable.begin(), kWritable.end(), e) != kWritable.end();
}

Image heat_map(const std::vector<float>& values, int width, int height, float lo, float hi) {
    Image img(width, height, {"R", "G", "B"});
    const float range = hi > lo ? hi - lo : 1.0f;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            float t = std::clamp((values[size_t(y) * width + x] - lo) / range, 0.0f, 1.0f);
            // Blue -> green over [0, 0.5], green -> red over [0.5, 1].
            float r = std::clamp(2.0f * t - 1.0f, 0.0f, 1.0f);
            float b = std::clamp(1.0f - 2.0f * t, 0.0f, 1.0f);
            float g = 1.0f - r - b;
            float* p = img.at(x, y);
            p[0] = r; p[1] = g; p[2] = b;
        }
    return img;
}

}  // namespace renderer
