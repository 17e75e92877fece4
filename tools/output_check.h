// Image outputs are checked before any work: a render that cannot save is refused before
// the scene loads, not after hours of rendering. Included by pathtracer only (it links
// OpenImageIO, which knows which extensions it can write).
#pragma once

#include <OpenImageIO/imageio.h>

#include <filesystem>
#include <memory>
#include <string>

#include "tools/cli.h"

namespace tools {

/// check_writable, and OpenImageIO has a writer for the extension of `path`.
inline std::string check_image_output(const std::string& flag, const std::string& path) {
    if (std::string why = check_writable(flag, path); !why.empty()) return why;
    const std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create(path);
    if (!out) {
        (void)OIIO::geterror();  // OpenImageIO keeps the message per thread otherwise
        return flag + " " + path + ": no image writer for the extension '" +
               std::filesystem::path(path).extension().string() + "' (.exr, .png, .jpg, .tif, ...)";
    }
    return {};
}

}  // namespace tools
