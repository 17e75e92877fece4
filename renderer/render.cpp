#include "renderer/render.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <mutex>

#include <unistd.h>

namespace renderer {

namespace {

using Clock = std::chrono::steady_clock;

/// Throttled progress line on stderr: percent, rays/s, time left.
class Progress {
public:
    Progress(bool enabled, size_t total_tiles)
        : enabled_(enabled), tty_(::isatty(2) == 1), total_(total_tiles) {}

    void tile_done(uint64_t rays) {
        const size_t done = ++done_;
        rays_ += rays;
        if (!enabled_) return;
        std::unique_lock lock(mutex_, std::try_to_lock);
        if (!lock.owns_lock()) return;
        const double t = std::chrono::duration<double>(Clock::now() - start_).count();
        // A terminal gets a line rewritten twice a second; a log file gets a line every
        // 10 s so that it stays readable.
        if (t - last_ < (tty_ ? 0.5 : 10.0) || done == total_) return;
        last_ = t;
        const double frac = double(done) / double(total_);
        const double left = frac > 0 ? t / frac - t : 0.0;
        std::fprintf(stderr, "%s[PathTracer] Rendering... %3d%% (%.2f Mrays/s, %.0f s left)%s",
                     tty_ ? "\r" : "", int(frac * 100.0),
                     double(rays_.load()) / std::max(t, 1e-9) / 1e6, left, tty_ ? "   " : "\n");
        std::fflush(stderr);
    }

private:
    bool enabled_, tty_;
    size_t total_;
    std::atomic<size_t> done_{0};
    std::atomic<uint64_t> rays_{0};
    std::mutex mutex_;
    Clock::time_point start_ = Clock::now();
    double last_ = -1.0;
};

}  // namespace

RenderResult render(const Camera& camera, const Integrator& integrator,
                    const accel::Accelerator& accel, const RenderSettings& s) {
    RenderResult result;
    result.image = Image(s.width, s.height,
                         {"R", "G", "B", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B",
                          "Z", "samples"});
    Cell cell = s.cell.value_or(Cell{0, 0, s.width, s.height});
    cell.w = std::min(cell.w, s.width - cell.x);
    cell.h = std::min(cell.h, s.height - cell.y);
    const int tiles_x = (cell.w + s.tile - 1) / s.tile, tiles_y = (cell.h + s.tile - 1) / s.tile;
    const size_t num_tiles = size_t(tiles_x) * size_t(tiles_y);

    tbb::enumerable_thread_specific<accel::TraceStats> thread_stats;
    tbb::enumerable_thread_specific<uint64_t> thread_samples(0);
    std::atomic<size_t> tiles_done{0};
    Progress progress(s.progress, num_tiles);
    const auto start = Clock::now();

    auto render_tile = [&](size_t tile_index) {
        if (s.cancel && s.cancel->load(std::memory_order_relaxed)) return;
        accel::TraceStats& stats = thread_stats.local();
        const uint64_t rays_before = stats.total_rays();
        const int x0 = cell.x + int(tile_index % tiles_x) * s.tile;
        const int y0 = cell.y + int(tile_index / tiles_x) * s.tile;
        const int x1 = std::min(x0 + s.tile, cell.x + cell.w);
        const int y1 = std::min(y0 + s.tile, cell.y + cell.h);
        uint64_t samples = 0;
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
                Rng rng(s.seed, uint64_t(y) * uint64_t(s.width) + uint64_t(x));
                Vec3f sum(0.0f), nsum(0.0f), asum(0.0f);
                float dsum = 0.0f;
                for (int i = 0; i < s.spp; ++i) {
                    // One sample sits at the pixel centre (as the course does); more are
                    // jittered uniformly inside the pixel.
                    float jx = 0.5f, jy = 0.5f;
                    if (s.spp > 1) {
                        jx = rng.next_float();
                        jy = rng.next_float();
                    }
                    const accel::Ray ray = camera.generate_ray((float(x) + jx) / float(s.width),
                                                               (float(y) + jy) / float(s.height));
                    SampleContext ctx{accel, stats, rng, {}};
                    sum += integrator.li(ray, ctx);
                    nsum += ctx.aov.normal;
                    asum += ctx.aov.albedo;
                    dsum += ctx.aov.depth;
                }
                samples += uint64_t(s.spp);
                const float inv = 1.0f / float(s.spp);
                float* p = result.image.at(x, y);
                p[kR] = sum.x * inv; p[kG] = sum.y * inv; p[kB] = sum.z * inv;
                p[kNx] = nsum.x * inv; p[kNy] = nsum.y * inv; p[kNz] = nsum.z * inv;
                p[kAlbedoR] = asum.x * inv; p[kAlbedoG] = asum.y * inv; p[kAlbedoB] = asum.z * inv;
                p[kDepth] = dsum * inv;
                p[kSamples] = float(s.spp);
            }
        thread_samples.local() += samples;
        ++tiles_done;
        progress.tile_done(stats.total_rays() - rays_before);
    };

    const int threads = s.threads > 0 ? s.threads : tbb::info::default_concurrency();
    tbb::task_arena arena(threads);
    arena.execute([&] {
        // Grain 1: tiles are already coarse; dynamic balance matters more.
        tbb::parallel_for(tbb::blocked_range<size_t>(0, num_tiles, 1),
                          [&](const tbb::blocked_range<size_t>& r) {
                              for (size_t i = r.begin(); i != r.end(); ++i) render_tile(i);
                          });
    });

    result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    for (const accel::TraceStats& st : thread_stats) result.stats += st;
    for (uint64_t n : thread_samples) result.samples += n;
    result.partial = tiles_done.load() < num_tiles;
    if (s.progress) {
        if (result.partial)
            std::fprintf(stderr, "%s[PathTracer] Rendering... stopped at %d%% (%.4f s)\n",
                         ::isatty(2) == 1 ? "\r" : "",
                         int(100.0 * double(tiles_done.load()) / double(std::max<size_t>(num_tiles, 1))),
                         result.seconds);
        else
            std::fprintf(stderr, "%s[PathTracer] Rendering... 100%%! (%.4fs)%s\n",
                         ::isatty(2) == 1 ? "\r" : "", result.seconds,
                         ::isatty(2) == 1 ? "                              " : "");
    }
    return result;
}

}  // namespace renderer
