#include "renderer/render.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
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
                          "Z", "samples", "variance", "cost.nodes", "cost.tests", "nan"});
    Cell cell = s.cell.value_or(Cell{0, 0, s.width, s.height});
    cell.w = std::min(cell.w, s.width - cell.x);
    cell.h = std::min(cell.h, s.height - cell.y);
    const int tiles_x = (cell.w + s.tile - 1) / s.tile, tiles_y = (cell.h + s.tile - 1) / s.tile;
    const size_t num_tiles = size_t(tiles_x) * size_t(tiles_y);

    tbb::enumerable_thread_specific<accel::TraceStats> thread_stats;
    tbb::enumerable_thread_specific<uint64_t> thread_samples(0), thread_nans(0);
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
        uint64_t samples = 0, nans = 0;
        bool stopped = false;
        for (int y = y0; y < y1 && !stopped; ++y) {
            // Checked per row too, so Ctrl-C answers promptly at high sample counts.
            if (s.cancel && s.cancel->load(std::memory_order_relaxed)) {
                stopped = true;
                break;
            }
            for (int x = x0; x < x1; ++x) {
                Rng rng(s.seed, uint64_t(y) * uint64_t(s.width) + uint64_t(x));
                const uint64_t nodes0 = stats.nodes_visited, tests0 = stats.prim_tests;
                Vec3f sum(0.0f), nsum(0.0f), asum(0.0f);
                float dsum = 0.0f;
                double s1 = 0.0, s2 = 0.0;  // illuminance sums for the confidence test
                int n = 0, taken = 0, bad = 0;
                while (taken < s.spp) {
                    // One sample sits at the pixel centre (as the course does); more are
                    // jittered uniformly inside the pixel.
                    float jx = 0.5f, jy = 0.5f;
                    if (s.spp > 1) {
                        jx = rng.next_float();
                        jy = rng.next_float();
                    }
                    // Lens samples are drawn only for a thin lens, so pinhole images keep
                    // their random streams.
                    float lu = 0.5f, lv = 0.5f;
                    if (camera.lens_radius() > 0) {
                        lu = rng.next_float();
                        lv = rng.next_float();
                    }
                    const accel::Ray ray = camera.generate_ray((float(x) + jx) / float(s.width),
                                                               (float(y) + jy) / float(s.height), lu, lv);
                    SampleContext ctx{accel, stats, rng, {}};
                    const Vec3f L = integrator.li(ray, ctx);
                    ++taken;
                    if (!accel::is_finite(L)) {
                        ++bad;  // a NaN/Inf sample is counted and reported, never averaged
                    } else {
                        sum += L;
                        nsum += ctx.aov.normal;
                        asum += ctx.aov.albedo;
                        dsum += ctx.aov.depth;
                        const double lum = 0.2126 * L.x + 0.7152 * L.y + 0.0722 * L.z;
                        s1 += lum;
                        s2 += lum * lum;
                        ++n;
                    }
                    if (s.adaptive_batch > 0 && taken % s.adaptive_batch == 0 && n > 1) {
                        const double mu = s1 / n;
                        const double var = std::max(0.0, (s2 - s1 * s1 / n) / (n - 1));
                        if (1.96 * std::sqrt(var / n) <= double(s.adaptive_tol) * mu) break;
                    }
                }
                samples += uint64_t(taken);
                nans += uint64_t(bad);
                const float inv = n > 0 ? 1.0f / float(n) : 0.0f;
                float* p = result.image.at(x, y);
                p[kR] = sum.x * inv; p[kG] = sum.y * inv; p[kB] = sum.z * inv;
                p[kNx] = nsum.x * inv; p[kNy] = nsum.y * inv; p[kNz] = nsum.z * inv;
                p[kAlbedoR] = asum.x * inv; p[kAlbedoG] = asum.y * inv; p[kAlbedoB] = asum.z * inv;
                p[kDepth] = dsum * inv;
                p[kSamples] = float(taken);
                p[kVariance] = n > 1 ? float(std::max(0.0, (s2 - s1 * s1 / n) / (n - 1)) / n) : 0.0f;
                p[kCostNodes] = float(stats.nodes_visited - nodes0) / float(taken);
                p[kCostTests] = float(stats.prim_tests - tests0) / float(taken);
                p[kNaN] = float(bad);
            }
        }
        thread_nans.local() += nans;
        thread_samples.local() += samples;
        if (stopped) return;  // an unfinished tile does not count as done
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
    for (uint64_t n : thread_nans) result.nan_samples += n;
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
