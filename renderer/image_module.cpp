// The exported entry of the image module (renderer/image_module.h).
#include "renderer/image_module.h"

extern "C" __attribute__((visibility("default"))) const renderer::ImageModule* pt_image_module() {
    static const renderer::ImageModule table{renderer::kImageModuleVersion, &renderer::write_image,
                                             &renderer::load_environment_image};
    return &table;
}
