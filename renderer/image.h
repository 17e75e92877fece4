// Float images with named channels, and writing them through OpenImageIO. Programs that
// link renderer_image_lazy load OpenImageIO only when they first read or write a file
// (renderer/image_module.h).
#pragma once

#include <string>
#include <vector>

#include "scenes/scene.h"

namespace renderer {

/// Interleaved float image; channel names follow EXR conventions ("R","G","B",
/// "normal.X", "samples", ...). The first three channels are the picture.
struct Image {
    int width = 0, height = 0;
    std::vector<std::string> channels;
    std::vector<float> pixels;  ///< width*height*channels.size(), row 0 at the top

    Image() = default;
    Image(int w, int h, std::vector<std::string> names)
        : width(w), height(h), channels(std::move(names)),
          pixels(size_t(w) * size_t(h) * channels.size(), 0.0f) {}
    size_t nchannels() const { return channels.size(); }
    float* at(int x, int y) { return pixels.data() + (size_t(y) * width + x) * nchannels(); }
    const float* at(int x, int y) const {
        return pixels.data() + (size_t(y) * width + x) * nchannels();
    }
};

/// How the first three channels are to be read.
enum class Encoding {
    SceneLinear,  ///< radiance: PNG/JPEG go through the OCIO display/view transform
    Display,      ///< already display values (normal shading, heat maps): written as is
};

struct WriteOptions {
    Encoding encoding = Encoding::SceneLinear;
    std::string ocio_config;  ///< path of a user's OCIO config; empty = the project's own
    std::string display, view;  ///< empty = the config's defaults
    /// Extra metadata (e.g. "pathtracer:partial" = "1").
    std::vector<std::pair<std::string, std::string>> attributes;
};

/// Writes `image` to `path`, the format chosen by extension: .exr keeps every channel as
/// float; .png/.jpg/.jpeg/.tif/... keep RGB as 8 bits after the display transform. The
/// file is written under a temporary name and renamed, so it appears whole or not at
/// all. Throws std::runtime_error naming the path on failure.
void write_image(const std::string& path, const Image& image, const WriteOptions& options = {});

/// Blue (low) -> green -> red (high) heat map of one value per pixel, as display RGB,
/// normalised to [lo, hi].
Image heat_map(const std::vector<float>& values, int width, int height, float lo, float hi);

/// True for extensions that hold float channels (EXR).
bool is_float_format(const std::string& path);

/// True for the extensions write_image can write (.exr, .png, .jpg, .tif, ...). Needs no
/// image library, so outputs are checked before any work.
bool is_writable_image_format(const std::string& path);

/// Reads a latitude-longitude environment map (EXR/HDR, anything OpenImageIO reads) as
/// linear float RGB for renderer::EnvironmentMap. Throws scenes::SceneError naming the
/// file when it cannot be read, is not an image, or has a negative or non-finite pixel.
scenes::Texture load_environment_image(const std::string& path);

}  // namespace renderer
