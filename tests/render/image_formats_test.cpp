// The output check refuses, before any work, an extension write_image could not write;
// it does so from a list (renderer/image_common.cpp), without loading OpenImageIO. These
// tests hold the list to the library it stands for.
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "renderer/image.h"

namespace {

bool oiio_writes(const std::string& ext) {
    const std::unique_ptr<OIIO::ImageOutput> out = OIIO::ImageOutput::create("x" + ext);
    if (!out) (void)OIIO::geterror();
    return out != nullptr;
}

TEST(ImageFormats, EveryAcceptedExtensionHasAWriter) {
    int accepted = 0;
    for (const char* ext : {".exr", ".png", ".jpg", ".jpeg", ".tif", ".tiff", ".tga", ".bmp", ".hdr", ".ppm",
                            ".pnm", ".webp", ".gif", ".psd", ".dds", ".ico", ".jp2", ".heic", ".avif",
                            ".dpx", ".cin", ".fits", ".sgi", ".rla", ".iff", ".zfile", ".txt", ".obj", ""}) {
        if (!renderer::is_writable_image_format(std::string("out") + ext)) continue;
        ++accepted;
        EXPECT_TRUE(oiio_writes(ext)) << ext << " is accepted but OpenImageIO has no writer for it";
    }
    EXPECT_GE(accepted, 4);
}

TEST(ImageFormats, TheDocumentedFormatsAreAccepted) {
    for (const char* path : {"a.exr", "a.png", "a.jpg", "a.JPEG", "dir.with.dots/a.tif"})
        EXPECT_TRUE(renderer::is_writable_image_format(path)) << path;
    for (const char* path : {"a", "a.txt", "a.dae", "a.exr/", "png"})
        EXPECT_FALSE(renderer::is_writable_image_format(path)) << path;
}

}  // namespace
