// write_image and load_environment_image for programs that load the image libraries only
// when they first read or write an image file (renderer/image_module.h).
#include <dlfcn.h>

#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "renderer/image_module.h"

namespace renderer {
namespace {

namespace fs = std::filesystem;

/// Beside the program (the build tree), then the install tree's library folder; or where
/// PT_IMAGE_MODULE says.
std::vector<fs::path> candidates() {
    if (const char* env = std::getenv("PT_IMAGE_MODULE"); env && *env) return {fs::path(env)};
    std::error_code ec;
    const fs::path dir = fs::read_symlink("/proc/self/exe", ec).parent_path();
    return {dir / "libpt_image.so", dir / ".." / PT_INSTALL_LIBDIR / "pathtracer" / "libpt_image.so"};
}

/// The first candidate that exists, or empty with `why` naming every place looked at.
fs::path locate(std::string& why) {
    std::string tried;
    for (const fs::path& p : candidates()) {
        std::error_code ec;
        if (fs::exists(p, ec)) return p;
        tried += (tried.empty() ? "" : ", ") + p.lexically_normal().string();
    }
    why = "the image module (libpt_image.so) is missing; looked at " + tried;
    return {};
}

const ImageModule& module() {
    static const ImageModule* table = nullptr;
    static std::string error;
    static bool memory = false;
    static std::once_flag once;
    std::call_once(once, [] {
        if (const fs::path p = locate(error); !p.empty()) {
            void* h = dlopen(p.c_str(), RTLD_NOW | RTLD_LOCAL);
            if (!h) {
                const std::string why = dlerror();
                // The dynamic loader's words when mmap fails: ENOMEM, from memory or from
                // the address-space limit.
                memory = why.find("failed to map segment") != std::string::npos ||
                         why.find("annot allocate memory") != std::string::npos;
                error = (memory ? "the image libraries cannot be mapped (" + p.string() + "): "
                                : std::string("the image module cannot be loaded: ")) + why;
                return;
            }
            using Entry = const ImageModule* (*)();
            const auto entry = reinterpret_cast<Entry>(dlsym(h, "pt_image_module"));
            const ImageModule* t = entry ? entry() : nullptr;
            if (!t || t->version != kImageModuleVersion) {
                error = p.string() + ": not an image module of this build";
                return;
            }
            table = t;
        }
    });
    if (!table) {
        if (memory) throw ImageModuleMemoryError(error);
        throw std::runtime_error(error);
    }
    return *table;
}

}  // namespace

void load_image_module() { (void)module(); }

std::string image_module_missing() {
    std::string why;
    return locate(why).empty() ? why : std::string();
}

void write_image(const std::string& path, const Image& image, const WriteOptions& options) {
    module().write_image(path, image, options);
}

scenes::Texture load_environment_image(const std::string& path) {
    return module().load_environment_image(path);
}

}  // namespace renderer
