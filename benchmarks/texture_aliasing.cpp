// texture_aliasing: does the MIP pyramid remove texture aliasing without blurring?
//
// A checkerboard plane seen at a grazing angle (a glTF written at run time into a temporary
// folder: one quad, a 64x64 checkerboard PNG tiled by REPEAT, KHR_materials_unlit so that
// the texture is the only source of error), rendered at 1, 4 and 16 spp with each
// --texture-filter, against a 4096-spp reference with point-sampled bilinear texels (the
// full-resolution image's continuous reconstruction, which every filter reads where a
// texel spans a pixel) and the renderer's box pixel filter: the pixel's true average of
// the texture. A filter that blurs the near field beyond it keeps an error there that
// samples do not remove.
//
// Error (luminance Y, per pixel): rel_rmse(region) = sqrt(sum (Y - Yref)^2 / sum Yref^2)
// over the plane's pixels (image), over the near field (the bottom quarter of the image,
// where a texel spans a pixel or more, so a filter can only blur) and over the far field
// (the rest of the plane, where many texels fall in a pixel and aliasing lives).
// Writes the table to stdout and, with --out DIR, the reference and the 1-spp bilinear and
// trilinear images as PNG.
#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include "renderer/backend_spec.h"
#include "renderer/camera.h"
#include "renderer/integrators/path.h"
#include "renderer/lights.h"
#include "renderer/render.h"
#include "renderer/scene_geometry.h"
#include "scenes/load.h"
#include "tools/cli.h"

namespace {

namespace fs = std::filesystem;

// ---- A PNG writer small enough to need nothing: zlib "stored" blocks, no compression.
uint32_t crc32(const uint8_t* p, size_t n, uint32_t c = 0xFFFFFFFFu) {
    for (size_t i = 0; i < n; ++i) {
        c ^= p[i];
        for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return c;
}

void put32(std::vector<uint8_t>& v, uint32_t x) {
    for (int s = 24; s >= 0; s -= 8) v.push_back(uint8_t(x >> s));
}

void chunk(std::vector<uint8_t>& out, const char* type, const std::vector<uint8_t>& data) {
    put32(out, uint32_t(data.size()));
    std::vector<uint8_t> td(type, type + 4);
    td.insert(td.end(), data.begin(), data.end());
    out.insert(out.end(), td.begin(), td.end());
    put32(out, crc32(td.data(), td.size()) ^ 0xFFFFFFFFu);
}

/// 8-bit RGB rows, top first.
std::vector<uint8_t> png(uint32_t w, uint32_t h, const std::vector<uint8_t>& rgb) {
    std::vector<uint8_t> raw;
    for (uint32_t y = 0; y < h; ++y) {
        raw.push_back(0);  // filter: none
        raw.insert(raw.end(), rgb.begin() + ptrdiff_t(size_t(y) * w * 3), rgb.begin() + ptrdiff_t(size_t(y + 1) * w * 3));
    }
    std::vector<uint8_t> z = {0x78, 0x01};
    for (size_t i = 0; i < raw.size(); i += 65535) {
        const size_t n = std::min<size_t>(65535, raw.size() - i);
        z.push_back(i + n == raw.size() ? 1 : 0);
        z.push_back(uint8_t(n));
        z.push_back(uint8_t(n >> 8));
        z.push_back(uint8_t(~n));
        z.push_back(uint8_t(~n >> 8));
        z.insert(z.end(), raw.begin() + ptrdiff_t(i), raw.begin() + ptrdiff_t(i + n));
    }
    uint32_t a = 1, b = 0;
    for (uint8_t c : raw) {
        a = (a + c) % 65521;
        b = (b + a) % 65521;
    }
    put32(z, (b << 16) | a);
    std::vector<uint8_t> out = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
    std::vector<uint8_t> ihdr;
    put32(ihdr, w);
    put32(ihdr, h);
    ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8-bit RGB
    chunk(out, "IHDR", ihdr);
    chunk(out, "IDAT", z);
    chunk(out, "IEND", {});
    return out;
}

void write_file(const fs::path& p, const std::vector<uint8_t>& bytes) {
    std::ofstream f(p, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    if (!f) tools::fail("texture_aliasing", "cannot write " + p.string());
}

std::string base64(const std::vector<uint8_t>& in) {
    static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string s;
    for (size_t i = 0; i < in.size(); i += 3) {
        const uint32_t n = (uint32_t(in[i]) << 16) | (i + 1 < in.size() ? uint32_t(in[i + 1]) << 8 : 0) |
                           (i + 2 < in.size() ? in[i + 2] : 0);
        s += t[(n >> 18) & 63];
        s += t[(n >> 12) & 63];
        s += i + 1 < in.size() ? t[(n >> 6) & 63] : '=';
        s += i + 2 < in.size() ? t[n & 63] : '=';
    }
    return s;
}

/// The scene: the plane y = 0, x in [-40, 40], z in [-400, 4], uv = (x, z) / 4 (a check is
/// half a unit, a texel 1/16), seen from 1 unit above, pitched 6 degrees down: the bottom
/// quarter of the image sees about 0.5 to 1.4 texels per pixel.
std::string scene_gltf() {
    const uint32_t n = 64, check = 8;
    std::vector<uint8_t> rgb(size_t(n) * n * 3);
    for (uint32_t y = 0; y < n; ++y)
        for (uint32_t x = 0; x < n; ++x) {
            const uint8_t v = ((x / check + y / check) & 1) ? 235 : 20;
            for (int c = 0; c < 3; ++c) rgb[(size_t(y) * n + x) * 3 + size_t(c)] = v;
        }
    const float x0 = -40, x1 = 40, z0 = -400, z1 = 4;
    const float pos[12] = {x0, 0, z1, x1, 0, z1, x1, 0, z0, x0, 0, z0};
    const float uv[8] = {x0 / 4, z1 / 4, x1 / 4, z1 / 4, x1 / 4, z0 / 4, x0 / 4, z0 / 4};
    const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    std::vector<uint8_t> buf(sizeof(pos) + sizeof(uv) + sizeof(idx));
    std::memcpy(buf.data(), pos, sizeof(pos));
    std::memcpy(buf.data() + sizeof(pos), uv, sizeof(uv));
    std::memcpy(buf.data() + sizeof(pos) + sizeof(uv), idx, sizeof(idx));
    const float pitch = -6.0f * accel::kPi / 180.0f;
    return fmt::format(
        R"({{"asset":{{"version":"2.0"}},"extensionsUsed":["KHR_materials_unlit"],)"
        R"("buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],)"
        R"("bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}},)"
        R"({{"buffer":0,"byteOffset":80,"byteLength":12}}],)"
        R"("accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[{},0,{}],"max":[{},0,{}]}},)"
        R"({{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}},)"
        R"({{"bufferView":2,"componentType":5123,"count":6,"type":"SCALAR"}}],)"
        R"("images":[{{"uri":"data:image/png;base64,{}"}}],"samplers":[{{}}],"textures":[{{"source":0,"sampler":0}}],)"
        R"("materials":[{{"name":"checks","doubleSided":true,"extensions":{{"KHR_materials_unlit":{{}}}},)"
        R"("pbrMetallicRoughness":{{"baseColorTexture":{{"index":0}},"metallicFactor":0}}}}],)"
        R"("meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"indices":2,"material":0}}]}}],)"
        R"("cameras":[{{"type":"perspective","perspective":{{"yfov":{},"znear":0.01,"aspectRatio":1.7778}}}}],)"
        R"("nodes":[{{"mesh":0}},{{"camera":0,"translation":[0,1,0],"rotation":[{},0,0,{}]}}],)"
        R"("scenes":[{{"nodes":[0,1]}}],"scene":0}})",
        buf.size(), base64(buf), x0, z0, x1, z1, base64(png(n, n, rgb)), 40.0f * accel::kPi / 180.0f,
        std::sin(0.5f * pitch), std::cos(0.5f * pitch));
}

struct World {
    scenes::Scene scene;
    std::unique_ptr<renderer::SceneGeometry> geometry;
    std::unique_ptr<renderer::LightSet> lights;
    std::unique_ptr<accel::Accelerator> accel;
    renderer::Camera camera;
};

/// Luminance per pixel (0 where nothing is hit: the sky is black).
std::vector<double> render(World& w, renderer::TextureFilter filter, int width, int height, int spp,
                           uint64_t seed, std::vector<uint8_t>* srgb8 = nullptr, std::vector<uint8_t>* hit = nullptr) {
    renderer::IntegratorSettings is;
    is.texture_filter = filter;
    is.pixel_spread = w.camera.pixel_spread(width, height, spp);
    renderer::PathIntegrator integ(w.scene, *w.geometry, *w.lights, is);
    renderer::RenderSettings rs;
    rs.width = width;
    rs.height = height;
    rs.spp = spp;
    rs.seed = seed;
    rs.progress = false;
    const renderer::RenderResult r = renderer::render(w.camera, integ, *w.accel, rs);
    std::vector<double> y(size_t(width) * height);
    if (srgb8) srgb8->resize(y.size() * 3);
    if (hit) hit->resize(y.size());
    for (int py = 0; py < height; ++py)
        for (int px = 0; px < width; ++px) {
            const float* p = r.image.at(px, py);
            y[size_t(py) * width + px] = 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2];
            if (hit) (*hit)[size_t(py) * width + px] = p[renderer::kDepth] > 0;
            if (srgb8)
                for (int c = 0; c < 3; ++c) {
                    const float l = std::clamp(p[c], 0.0f, 1.0f);
                    const float s = l <= 0.0031308f ? 12.92f * l : 1.055f * std::pow(l, 1.0f / 2.4f) - 0.055f;
                    (*srgb8)[(size_t(py) * width + px) * 3 + size_t(c)] = uint8_t(s * 255.0f + 0.5f);
                }
        }
    return y;
}

double rel_rmse(const std::vector<double>& y, const std::vector<double>& ref, const std::vector<uint8_t>& mask) {
    double e = 0, s = 0;
    for (size_t i = 0; i < y.size(); ++i)
        if (mask[i]) {
            e += (y[i] - ref[i]) * (y[i] - ref[i]);
            s += ref[i] * ref[i];
        }
    return s > 0 ? std::sqrt(e / s) : 0.0;
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"Texture aliasing: MIP (trilinear) against bilinear on a grazing checkerboard."};
    int width = 192, height = 108, ref_spp = 4096;
    std::string out;
    bool quick = false;
    app.add_option("-r", width, "Image width (height is 9/16 of it)");
    app.add_option("--ref-spp", ref_spp, "Reference samples per pixel");
    app.add_option("--out", out, "Folder for the PNG images (reference, bilinear and trilinear at 1 spp)");
    app.add_flag("--quick", quick, "Smoke run: tiny image, 64-spp reference");
    tools::parse_or_exit(app, argc, argv, "texture_aliasing");
    if (quick) {
        width = 48;
        ref_spp = 64;
    }
    height = width * 9 / 16;

    const fs::path dir = fs::temp_directory_path() / fmt::format("texture_aliasing_{}", ::getpid());
    fs::create_directories(dir);
    const fs::path file = dir / "checkerboard.gltf";
    {
        std::ofstream f(file);
        f << scene_gltf();
    }
    World w;
    w.scene = tools::load_scene_or_exit(file.string(), "texture_aliasing");
    fs::remove_all(dir);
    w.geometry = std::make_unique<renderer::SceneGeometry>(w.scene);
    std::vector<std::string> notes;
    w.lights = std::make_unique<renderer::LightSet>(w.scene, renderer::LightModel::Mesh, notes);
    w.accel = renderer::build_accelerator("custom", *w.geometry, {}, false);
    w.camera = renderer::make_camera(w.scene, renderer::CameraMode::File, width, height).camera;

    const auto t0 = std::chrono::steady_clock::now();
    std::vector<uint8_t> ref_png, plane;
    const std::vector<double> ref =
        render(w, renderer::TextureFilter::Bilinear, width, height, ref_spp, 99, &ref_png, &plane);
    const double ref_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    // Regions: the plane's pixels (every sample hit it: the sky, which glTF scenes without
    // lights get, is left out); near = their bottom quarter of the image.
    std::vector<uint8_t> near(ref.size()), far(ref.size());
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) {
            const size_t i = size_t(y) * width + x;
            near[i] = plane[i] && y >= height * 3 / 4;
            far[i] = plane[i] && !near[i];
        }
    std::printf("texture aliasing: %dx%d, reference %d spp bilinear (%.1f s)\n", width, height, ref_spp, ref_s);
    std::printf("%-10s %4s %10s %10s %10s\n", "filter", "spp", "image", "near", "far");
    for (int spp : {1, 4, 16})
        for (renderer::TextureFilter f :
             {renderer::TextureFilter::Nearest, renderer::TextureFilter::Bilinear, renderer::TextureFilter::Trilinear,
              renderer::TextureFilter::Stochastic}) {
            std::vector<uint8_t> img;
            const std::vector<double> y = render(w, f, width, height, spp, 1, spp == 1 ? &img : nullptr);
            std::printf("%-10s %4d %10.4f %10.4f %10.4f\n", renderer::texture_filter_name(f), spp, rel_rmse(y, ref, plane),
                        rel_rmse(y, ref, near), rel_rmse(y, ref, far));
            if (!out.empty() && spp == 1 && f != renderer::TextureFilter::Nearest) {
                fs::create_directories(out);
                write_file(fs::path(out) / fmt::format("{}_1spp.png", renderer::texture_filter_name(f)),
                           png(uint32_t(width), uint32_t(height), img));
            }
        }
    if (!out.empty()) write_file(fs::path(out) / fmt::format("reference_{}spp.png", ref_spp),
                                 png(uint32_t(width), uint32_t(height), ref_png));
    return 0;
}
