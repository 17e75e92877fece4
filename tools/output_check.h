// Image outputs are checked before any work: a render that cannot save is refused before
// the scene loads, not after hours of rendering. The format check is a list of the
// extensions write_image can write (renderer/image_common.cpp), so it needs no image
// library: those load only at the save (renderer/image_module.h).
#pragma once

#include <filesystem>
#include <string>

#include "renderer/image.h"
#include "tools/cli.h"

namespace tools {

/// check_writable, and write_image can write the extension of `path`.
inline std::string check_image_output(const std::string& flag, const std::string& path) {
    if (std::string why = check_writable(flag, path); !why.empty()) return why;
    if (!renderer::is_writable_image_format(path))
        return flag + " " + path + ": no image writer for the extension '" +
               std::filesystem::path(path).extension().string() + "' (.exr, .png, .jpg, .tif, ...)";
    return {};
}

}  // namespace tools
