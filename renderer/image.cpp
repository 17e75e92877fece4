#include "renderer/image.h"

#include <OpenColorIO/OpenColorIO.h>
#include <OpenImageIO/imageio.h>
#include <fmt/format.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "renderer/ocio_config.h"  // generated: kProjectOcioConfig

namespace OCIO = OCIO_NAMESPACE;

namespace renderer {

namespace {
/// Applies the display/view transform of the chosen OCIO config to packed RGB.
void display_transform(std::vector<float>& rgb, int width, int height, const WriteOptions& o) {
    try {
        OCIO::ConstConfigRcPtr config;
        if (o.ocio_config.empty()) {
            std::istringstream in(kProjectOcioConfig);
            config = OCIO::Config::CreateFromStream(in);
        } else {
            config = OCIO::Config::CreateFromFile(o.ocio_config.c_str());
        }
        const char* display = o.display.empty() ? config->getDefaultDisplay() : o.display.c_str();
        const char* view = o.view.empty() ? config->getDefaultView(display) : o.view.c_str();
        auto proc = config->getProcessor(OCIO::ROLE_SCENE_LINEAR, display, view,
                                         OCIO::TRANSFORM_DIR_FORWARD);
        OCIO::PackedImageDesc desc(rgb.data(), width, height, 3);
        proc->getDefaultCPUProcessor()->apply(desc);
    } catch (const OCIO::Exception& e) {
        throw std::runtime_error(fmt::format("OpenColorIO: {}", e.what()));
    }
}
}  // namespace


void write_image(const std::string& path, const Image& image, const WriteOptions& o) {
    namespace fs = std::filesystem;
    if (image.width <= 0 || image.height <= 0 || image.nchannels() < 3)
        throw std::runtime_error(fmt::format("{}: nothing to write", path));
    const bool is_float = is_float_format(path);
    const int w = image.width, h = image.height;

    std::vector<float> data;
    OIIO::ImageSpec spec;
    if (is_float) {
        spec = OIIO::ImageSpec(w, h, int(image.nchannels()), OIIO::TypeDesc::FLOAT);
        spec.channelnames = image.channels;
        spec.attribute("compression", "zip");
        data = image.pixels;
    } else {
        data.resize(size_t(w) * h * 3);
        for (size_t i = 0, n = size_t(w) * h; i < n; ++i)
            for (int c = 0; c < 3; ++c) data[i * 3 + c] = image.pixels[i * image.nchannels() + c];
        if (o.encoding == Encoding::SceneLinear) display_transform(data, w, h, o);
        spec = OIIO::ImageSpec(w, h, 3, OIIO::TypeDesc::UINT8);
    }
    spec.attribute("Software", "pathtracer");
    for (const auto& [k, v] : o.attributes) spec.attribute(k, v);

    // Same folder (so rename is atomic), same extension (OIIO picks the format by it).
    const fs::path target(path);
    const fs::path tmp = target.parent_path() /
                         fmt::format(".{}.tmp{}{}", target.stem().string(), ::getpid(),
                                     target.extension().string());
    auto out = OIIO::ImageOutput::create(tmp.string());
    if (!out)
        throw std::runtime_error(fmt::format("{}: no image writer for this extension ({})", path,
                                             OIIO::geterror()));
    // Whatever ends the write (a full disk, an exception such as std::bad_alloc from the
    // encoder), the temporary file goes: the target is whole or untouched.
    bool ok = false;
    try {
        ok = out->open(tmp.string(), spec) && out->write_image(OIIO::TypeDesc::FLOAT, data.data()) &&
             out->close();
    } catch (...) {
        out.reset();
        std::error_code ec;
        fs::remove(tmp, ec);
        throw;
    }
    if (!ok) {
        std::string err = out->geterror();
        out.reset();
        std::error_code ec;
        fs::remove(tmp, ec);
        throw std::runtime_error(fmt::format("{}: cannot write: {}", path, err));
    }
    // The encoder's writes may sit in the page cache; a disk that fills (or a delayed
    // allocation that fails) shows here, before the rename could put a short file in
    // place of a good one.
    if (const int fd = ::open(tmp.c_str(), O_RDONLY); fd < 0 || ::fsync(fd) != 0) {
        const std::string why = std::strerror(errno);
        if (fd >= 0) ::close(fd);
        std::error_code ec;
        fs::remove(tmp, ec);
        throw std::runtime_error(fmt::format("{}: cannot write: {}", path, why));
    } else {
        ::close(fd);
    }
    std::error_code ec;
    fs::rename(tmp, target, ec);
    if (ec) {
        fs::remove(tmp, ec);
        throw std::runtime_error(fmt::format("{}: cannot rename into place: {}", path, ec.message()));
    }
}

scenes::Texture load_environment_image(const std::string& path) {
    auto in = OIIO::ImageInput::open(path);
    if (!in) throw scenes::SceneError(path + ": cannot read the environment map (" + OIIO::geterror() + ")");
    const OIIO::ImageSpec& spec = in->spec();
    if (spec.width <= 0 || spec.height <= 0 || spec.nchannels < 1 || uint64_t(spec.width) * spec.height > (1u << 28))
        throw scenes::SceneError(path + ": environment map has an unsupported size");
    // Kept at the file's precision (EXR half stays half; RGBE and float stay float; 8- and
    // 16-bit files stay integers, read as OIIO reads them, without a transfer curve), and
    // only R, G, B: the file is decoded straight into the texture, with no float copy.
    const OIIO::TypeDesc::BASETYPE base = OIIO::TypeDesc::BASETYPE(spec.format.basetype);
    const scenes::TexelFormat format = base == OIIO::TypeDesc::HALF     ? scenes::TexelFormat::F16
                                       : base == OIIO::TypeDesc::UINT8  ? scenes::TexelFormat::U8
                                       : base == OIIO::TypeDesc::UINT16 ? scenes::TexelFormat::U16
                                                                        : scenes::TexelFormat::F32;
    const OIIO::TypeDesc type = format == scenes::TexelFormat::F16   ? OIIO::TypeDesc::HALF
                                : format == scenes::TexelFormat::U8  ? OIIO::TypeDesc::UINT8
                                : format == scenes::TexelFormat::U16 ? OIIO::TypeDesc::UINT16
                                                                     : OIIO::TypeDesc::FLOAT;
    const int nc = std::min(spec.nchannels, 3);
    scenes::Texture t = scenes::Texture::make(path, uint32_t(spec.width), uint32_t(spec.height), format, "RGB");
    const size_t npix = size_t(t.width) * t.height, cb = scenes::texel_format_bytes(format);
    if (!in->read_image(0, 0, 0, nc, type, t.data.data()))
        throw scenes::SceneError(path + ": cannot decode the environment map (" + in->geterror() + ")");
    // Fewer than three channels: spread in place from the back, grey (or the last
    // channel) filling the missing ones, as the float reader did.
    if (nc < 3)
        for (size_t p = npix; p-- > 0;)
            for (int c = 2; c >= 0; --c)
                std::memmove(&t.data[(p * 3 + size_t(c)) * cb], &t.data[(p * size_t(nc) + size_t(std::min(c, nc - 1))) * cb], cb);
    for (size_t p = 0; p < npix; ++p)
        for (int c = 0; c < 3; ++c) {
            float v = 0;
            const uint8_t* q = &t.data[(p * 3 + size_t(c)) * cb];
            if (format == scenes::TexelFormat::F32) {
                std::memcpy(&v, q, 4);
            } else if (format == scenes::TexelFormat::F16) {
                uint16_t h;
                std::memcpy(&h, q, 2);
                v = scenes::half_to_float(h);
            } else {
                continue;  // integers are never negative or non-finite
            }
            if (!std::isfinite(v) || v < 0)
                throw scenes::SceneError(path + ": environment map has a negative or non-finite pixel at (" +
                                         std::to_string(p % t.width) + ", " + std::to_string(p / t.width) + ")");
        }
    return t;
}

}  // namespace renderer
