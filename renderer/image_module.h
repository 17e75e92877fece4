// The code that reads and writes image files (OpenImageIO, OpenEXR, OpenColorIO) as a
// module that the pathtracer loads the first time it reads or writes one.
//
// Linked in, those libraries and the ~270 they pull in (OpenVDB, GDAL, codecs) cost every
// run about 130 MiB of resident memory and their start-up before the scene is even read,
// whether or not the render writes a single image before it ends: with the module, a
// render pays for them only at the save, after the scene, the BVH and the film are freed
// (renderer/README.md, "Image files as a module"). Tests and benchmarks link
// renderer_image directly and never load the module.
#pragma once

#include <stdexcept>
#include <string>

#include "renderer/image.h"

namespace renderer {

/// Bumped whenever the table changes: a module left over from another build is refused.
inline constexpr int kImageModuleVersion = 1;

/// What the module exports (as `pt_image_module`, the only symbol it exports). Module and
/// program are built together from one tree, so C++ types cross the boundary.
struct ImageModule {
    int version;
    void (*write_image)(const std::string& path, const Image& image, const WriteOptions& options);
    scenes::Texture (*load_environment_image)(const std::string& path);
};

/// The module could not be mapped for want of memory or address space (ulimit -v): an
/// out-of-memory failure, not a missing or broken installation.
class ImageModuleMemoryError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

/// In programs that link renderer_image_lazy: loads the module now rather than at the
/// first image file. Throws ImageModuleMemoryError or std::runtime_error as a lazy load
/// would.
void load_image_module();

/// In programs that link renderer_image_lazy: empty when the module is where it will be
/// loaded from, else why not (checked with the outputs, before any work; nothing loaded).
std::string image_module_missing();

}  // namespace renderer
