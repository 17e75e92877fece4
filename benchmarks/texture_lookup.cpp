// texture_lookup: the figures behind building our own MIP pyramid instead of using
// OpenImageIO's TextureSystem. On one 8-bit sRGB RGB image it measures nanoseconds per
// filtered lookup for our trilinear lookup (renderer/texture.h) and for
// TextureSystem::texture with a trilinear MIP filter, each with what a multi-threaded
// renderer would hold per thread (TextureSystem: a Perthread and a TextureHandle), and
// the memory each keeps. TextureSystem reads files, not bytes in memory: the image is
// written as a PNG (what a glTF file embeds) and read both as is (automip: the pyramid
// is built in its cache) and as a tiled, MIP-mapped .tx made by make_texture (what
// production pipelines feed it); the IOProxy route (the embedded PNG's bytes in memory,
// handed to ImageCache::add_file) is tried and its outcome printed.
#include <CLI/CLI.hpp>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imagecache.h>
#include <OpenImageIO/imageio.h>
#include <OpenImageIO/texture.h>
#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <thread>
#include <vector>

#include "renderer/texture.h"
#include "scenes/image/image.h"
#include "tools/cli.h"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
OIIO_NAMESPACE_USING

/// One lookup: uv and its footprint (d(u, v)/dx, d(u, v)/dy).
struct Query {
    float u, v, dudx, dvdx, dudy, dvdy;
};

/// Smooth colour fields plus fine detail, so that every level differs and no filter
/// reads a constant. Not random per texel: PNG compression stays realistic.
std::vector<uint8_t> make_image(int n) {
    std::vector<uint8_t> px(size_t(n) * n * 3);
    for (int y = 0; y < n; ++y)
        for (int x = 0; x < n; ++x)
            for (int c = 0; c < 3; ++c) {
                const float f = 0.5f + 0.25f * std::sin(0.013f * float(x + 37 * c)) * std::cos(0.011f * float(y)) +
                                0.2f * float(((x >> (2 + c)) ^ (y >> 3)) & 1);
                px[(size_t(y) * n + size_t(x)) * 3 + size_t(c)] = uint8_t(std::clamp(f, 0.0f, 1.0f) * 255.0f + 0.5f);
            }
    return px;
}

/// Random points with footprints from 1/2 to 16 texels (of an n-texel image) per pixel
/// step, as a path tracer's hits spread over a model ("random"); or a raster sweep across
/// the image at 4 texels a pixel, as camera rays hit it in tiles ("coherent").
std::vector<Query> make_queries(int n, size_t count, bool coherent) {
    std::vector<Query> q(count);
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    const int side = int(std::sqrt(double(count)));
    for (size_t i = 0; i < count; ++i) {
        if (coherent) {
            const float w = 4.0f / float(n);
            const size_t x = i % size_t(side), y = (i / size_t(side)) % size_t(side);
            q[i] = {float(x) * w + 0.1f * w * u01(rng), float(y) * w + 0.1f * w * u01(rng), w, 0, 0, w};
        } else {
            const float w = std::exp2(u01(rng) * 5.0f - 1.0f) / float(n);
            q[i] = {u01(rng), u01(rng), w, 0.2f * w * (u01(rng) - 0.5f), 0.2f * w * (u01(rng) - 0.5f), w};
        }
    }
    return q;
}

/// Seconds for `threads` threads each running body(thread index) once, after all start.
template <class F>
double timed(int threads, F&& body) {
    std::atomic<int> ready{0};
    std::vector<std::thread> pool;
    Clock::time_point t0;
    std::atomic<bool> go{false};
    for (int k = 0; k < threads; ++k)
        pool.emplace_back([&, k] {
            ready.fetch_add(1);
            while (!go.load()) std::this_thread::yield();
            body(k);
        });
    while (ready.load() < threads) std::this_thread::yield();
    t0 = Clock::now();
    go.store(true);
    for (auto& t : pool) t.join();
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// Best of `reps` runs: ns per lookup per thread (each thread runs all queries).
template <class F>
double ns_per_lookup(int threads, int reps, size_t count, F&& body) {
    double best = 1e30;
    for (int r = 0; r < reps; ++r) best = std::min(best, timed(threads, body));
    return best * 1e9 / double(count);
}

int64_t cache_bytes(TextureSystem* ts) {
    int64_t mem = 0;
    ts->imagecache()->getattribute("stat:cache_memory_used", TypeDesc::INT64, &mem);
    return mem;
}

/// The image as a PNG and as a tiled, MIP-mapped .tx, for TextureSystem. False on failure.
bool write_sources(const std::vector<uint8_t>& px, int n, const std::string& png, const std::string& tx) {
    ImageBuf buf(ImageSpec(n, n, 3, TypeDesc::UINT8), const_cast<uint8_t*>(px.data()));
    buf.specmod().attribute("oiio:ColorSpace", "sRGB");
    if (!buf.write(png)) {
        std::fprintf(stderr, "texture_lookup: cannot write %s: %s\n", png.c_str(), buf.geterror().c_str());
        return false;
    }
    ImageSpec config;
    config.attribute("maketx:filtername", "box");
    if (!ImageBufAlgo::make_texture(ImageBufAlgo::MakeTxTexture, buf, tx, config)) {
        std::fprintf(stderr, "texture_lookup: make_texture failed: %s\n", OIIO::geterror().c_str());
        return false;
    }
    return true;
}

void print_row(const char* name, int threads, bool coherent, double ns, double mib) {
    fmt::print("{:<44} {:>10} {:>10} {:>12.1f} {:>12.1f}\n", name, threads, coherent ? "coherent" : "random", ns, mib);
}

/// Ours: 8-bit texels as the glTF loader stores them, pyramid built at load.
void bench_ours(const std::vector<uint8_t>& px, int n, size_t count, int reps, const std::vector<int>& thread_counts) {
    scenes::Texture tex = scenes::Texture::make("image", uint32_t(n), uint32_t(n), scenes::TexelFormat::U8, "RGB");
    tex.srgb = true;
    std::copy(px.begin(), px.end(), tex.data.begin());
    scenes::image::build_mip_pyramid(tex);
    const double ours_mib = double(tex.data.size()) / (1024.0 * 1024.0);
    for (const bool coherent : {false, true}) {
        const std::vector<Query> qs = make_queries(n, count, coherent);
        for (const auto& [name, filter] :
             {std::pair{"ours stochastic (one level per lookup)", renderer::TextureFilter::Stochastic},
              std::pair{"ours trilinear (two levels)", renderer::TextureFilter::Trilinear}}) {
            for (const int threads : thread_counts) {
                std::vector<float> sink(size_t(threads) * 16, 0.0f);
                const double ns = ns_per_lookup(threads, reps, count, [&](int k) {
                    float acc = 0;
                    for (const Query& q : qs) {
                        const float lod = renderer::uv_lod({q.dudx, q.dvdx, q.dudy, q.dvdy});
                        acc += renderer::lookup(tex, {q.u, q.v}, lod, filter).g;
                    }
                    sink[size_t(k) * 16] = acc;
                });
                print_row(name, threads, coherent, ns, ours_mib);
            }
        }
    }
}

/// OpenImageIO: one TextureSystem per source, as a renderer would hold it, with a 256 MB
/// cache bound and trilinear, bilinear-per-level filtering.
void bench_oiio(const char* name, const std::string& path, bool automip, int n, size_t count, int reps,
                const std::vector<int>& thread_counts) {
    TextureSystem* ts = TextureSystem::create(false);
    ts->attribute("automip", automip ? 1 : 0);
    ts->attribute("autotile", 64);
    ts->attribute("max_memory_MB", 256.0f);
    const ustring file(path);
    for (const bool coherent : {false, true}) {
        const std::vector<Query> qs = make_queries(n, count, coherent);
        for (const int threads : thread_counts) {
            std::vector<float> sink(size_t(threads) * 16, 0.0f);
            const double ns = ns_per_lookup(threads, reps, count, [&](int k) {
                TextureSystem::Perthread* pt = ts->get_perthread_info();
                TextureSystem::TextureHandle* h = ts->get_texture_handle(file, pt);
                TextureOpt opt;
                opt.mipmode = TextureOpt::MipModeTrilinear;
                opt.interpmode = TextureOpt::InterpBilinear;
                float acc = 0, rgb[3];
                for (const Query& q : qs) {
                    ts->texture(h, pt, opt, q.u, q.v, q.dudx, q.dvdx, q.dudy, q.dvdy, 3, rgb);
                    acc += rgb[1];
                }
                sink[size_t(k) * 16] = acc;
            });
            print_row(name, threads, coherent, ns, double(cache_bytes(ts)) / (1024.0 * 1024.0));
        }
    }
    if (ts->has_error()) std::fprintf(stderr, "texture_lookup: %s\n", ts->geterror().c_str());
    TextureSystem::destroy(ts);
}

/// The embedded-image route: the PNG's bytes in memory (as a .glb holds them) behind an
/// IOProxy, registered under a made-up name with ImageCache::add_file.
void try_ioproxy(const std::string& png) {
    std::ifstream f(png, std::ios::binary);
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
    ImageSpec config;
    config.attribute("oiio:ioproxy", TypeDesc::PTR, &proxy);
    TextureSystem* ts = TextureSystem::create(false);
    ts->attribute("automip", 1);
    ts->attribute("autotile", 64);
    const ustring name("embedded.png");
    const bool added = ts->imagecache()->add_file(name, nullptr, &config);
    float rgb[3] = {-1, -1, -1};
    TextureOpt opt;
    const bool looked = added && ts->texture(name, opt, 0.5f, 0.5f, 0, 0, 0, 0, 3, rgb);
    fmt::print("IOProxy route (add_file with oiio:ioproxy): add_file {}, lookup {}{}\n", added ? "ok" : "failed",
               looked ? "ok" : "failed", looked ? fmt::format(" (g = {:.4f})", rgb[1]) : std::string());
    if (ts->has_error()) std::fprintf(stderr, "texture_lookup: IOProxy route: %s\n", ts->geterror().c_str());
    TextureSystem::destroy(ts);
}
}  // namespace

int main(int argc, char** argv) {
    CLI::App app{"ns per filtered texture lookup: our trilinear MIP lookup against OpenImageIO's TextureSystem."};
    int n = 2048;
    size_t count = 1 << 20;
    int reps = 3;
    bool quick = false;
    app.add_option("-n", n, "Image side in texels (8-bit RGB, sRGB)")->check(CLI::Range(16, 16384));
    app.add_option("--lookups", count, "Lookups per thread per run");
    app.add_option("--reps", reps, "Runs per figure (the best is printed)")->check(CLI::PositiveNumber);
    app.add_flag("--quick", quick, "Smoke run: a 256-texel image, few lookups");
    tools::parse_or_exit(app, argc, argv, "texture_lookup");
    if (quick) {
        n = 256;
        count = 1 << 14;
        reps = 1;
    }
    const int hw = int(std::max(1u, std::thread::hardware_concurrency()));
    const std::vector<int> thread_counts = hw >= 2 ? std::vector<int>{1, 2} : std::vector<int>{1};

    const std::vector<uint8_t> px = make_image(n);
    const fs::path dir = fs::temp_directory_path() / fmt::format("texture_lookup_{}", ::getpid());
    fs::create_directories(dir);
    const std::string png = (dir / "image.png").string(), tx = (dir / "image.tx").string();
    if (!write_sources(px, n, png, tx)) return 1;

    fmt::print("texture lookup: {0}x{0} 8-bit sRGB RGB, {1} lookups per thread, best of {2}\n", n, count, reps);
    fmt::print("{:<44} {:>10} {:>10} {:>12} {:>12}\n", "lookup", "threads", "pattern", "ns/lookup", "MiB held");
    bench_ours(px, n, count, reps, thread_counts);
    bench_oiio("OIIO TextureSystem, PNG (automip)", png, true, n, count, reps, thread_counts);
    bench_oiio("OIIO TextureSystem, .tx (tiled MIP)", tx, false, n, count, reps, thread_counts);
    try_ioproxy(png);
    std::error_code ec;
    fs::remove_all(dir, ec);
    return 0;
}
