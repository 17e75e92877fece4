#include "renderer/render.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <optional>
#include <stdexcept>

#include "renderer/split_map.h"

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

Cell TileGrid::rect(size_t i) const {
    const int x0 = cell.x + int(i % size_t(tiles_x)) * tile, y0 = cell.y + int(i / size_t(tiles_x)) * tile;
    return {x0, y0, std::min(tile, cell.x + cell.w - x0), std::min(tile, cell.y + cell.h - y0)};
}

static Image make_image(int width, int height) {
    return Image(width, height,
                 {"R", "G", "B", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B", "Z",
                  "samples", "variance", "cost.nodes", "cost.tests", "nan"});
}

void resolve(const Accumulation& acc, RenderResult& result) {
    result.image = make_image(acc.width, acc.height);
    result.stats = {};
    result.samples = 0;
    result.nan_samples = 0;
    for (int y = 0; y < acc.height; ++y)
        for (int x = 0; x < acc.width; ++x) {
            const PixelSums& q = acc.pixels[size_t(y) * size_t(acc.width) + size_t(x)];
            float* p = result.image.at(x, y);
            const double inv = q.n > 0 ? 1.0 / double(q.n) : 0.0;
            for (int c = 0; c < 3; ++c) {
                p[kR + c] = float(q.rgb[c] * inv);
                p[kNx + c] = float(q.normal[c] * inv);
                p[kAlbedoR + c] = float(q.albedo[c] * inv);
            }
            p[kDepth] = float(q.depth * inv);
            p[kSamples] = float(q.taken);
            const double n = double(q.n);
            p[kVariance] = q.n > 1 ? float(std::max(0.0, (q.s2 - q.s1 * q.s1 / n) / (n - 1)) / n) : 0.0f;
            p[kCostNodes] = q.taken ? float(double(q.nodes) / double(q.taken)) : 0.0f;
            p[kCostTests] = q.taken ? float(double(q.tests) / double(q.taken)) : 0.0f;
            p[kNaN] = float(q.bad);
            result.stats.rays += q.rays;
            result.stats.shadow_rays += q.shadow_rays;
            result.stats.nodes_visited += q.nodes;
            result.stats.prim_tests += q.tests;
            result.samples += q.taken;
            result.nan_samples += q.bad;
        }
}

uint64_t film_bytes(int width, int height, bool resume) {
    const uint64_t pixels = uint64_t(std::max(0, width)) * uint64_t(std::max(0, height));
    return pixels * (sizeof(PixelSums) * (resume ? 3 : 1) + sizeof(float) * kNumChannels);
}

RenderResult render(const Camera& camera, const Integrator& integrator,
                    const accel::Accelerator& accel, const RenderSettings& s) {
    auto stage = [&](const char* name) {
        if (s.on_stage) s.on_stage(name);
    };
    stage("allocating the film");
    RenderResult result;
    Accumulation& acc = result.sums;
    if (s.resume) {
        acc = *s.resume;
        if (acc.width != s.width || acc.height != s.height ||
            acc.pixels.size() != size_t(s.width) * size_t(s.height))
            throw std::invalid_argument("resume: the saved state does not match the image size");
    } else {
        acc.width = s.width;
        acc.height = s.height;
        acc.pixels.assign(size_t(s.width) * size_t(s.height), PixelSums{});
    }
    Cell cell = s.cell.value_or(Cell{0, 0, s.width, s.height});
    cell.w = std::min(cell.w, s.width - cell.x);
    cell.h = std::min(cell.h, s.height - cell.y);
    const TileGrid grid{cell, s.tile, (cell.w + s.tile - 1) / s.tile, (cell.h + s.tile - 1) / s.tile};
    const size_t num_tiles = grid.count();
    const int pass_spp = s.tiles ? s.spp : std::max(1, s.pass_spp > 0 ? s.pass_spp
                                            : s.adaptive_batch > 0 ? s.adaptive_batch : 8);
    const int num_passes = (s.spp + pass_spp - 1) / pass_spp;

    // Built before the clock starts: pmj02 draws its tables here (0.07 s).
    const Sampler sampler(s.sampler, s.seed, s.spp, s.width, s.height);
    const bool independent = s.sampler == SamplerKind::Independent;
    const int branches = integrator.branches();
    // Split by noise (renderer/split_map.h): the first p0 samples of every pixel split
    // `branches` ways and size the map that the later ones follow.
    const int p0 =
        branches > 1 && integrator.splits_by_noise() ? SplitMap::first_samples(s.spp) : 0;
    SplitMap split_map(branches);
    // One branch sampler: branch j of sample i of a pixel reads sample i * K + j of it
    // under a uniform split K; under a map, the pixel's first p0 samples take
    // [0, p0 * K) and its later ones follow on at their own count (ctx.branch_base), so
    // that a pixel's branches are one prefix of the sampler's sequence.
    const int max_k = 2 * branches;
    std::optional<Sampler> branch_sampler;
    if (branches > 1 && !independent)
        branch_sampler.emplace(
            sampler.with_spp(p0 * branches + (s.spp - p0) * (p0 > 0 ? max_k : branches),
                             s.width, s.height));

    stage(p0 > 0 ? "sizing the split" : "rendering");
    tbb::enumerable_thread_specific<accel::TraceStats> thread_stats;
    Progress progress(s.progress, num_tiles * size_t(num_passes + (p0 > 0 ? 2 : 0)));
    const auto start = Clock::now();
    std::atomic<bool> stopped{false};
    auto cancelled = [&] { return s.cancel && s.cancel->load(std::memory_order_relaxed); };

    // Takes pixel (x, y) up to `target` samples; samples are added in index order, so the
    // sums are the same whichever pass, thread or process takes them.
    auto render_pixel = [&](int x, int y, uint32_t target, accel::TraceStats& stats,
                            Accumulation& into) {
        const uint64_t pixel = uint64_t(y) * uint64_t(s.width) + uint64_t(x);
        PixelSums& q = into.pixels[pixel];
        if (q.done) return;
        const accel::TraceStats before = stats;
        // The pixel's split: the render's before sample p0, its map's from then on.
        const int k_later = split_map.at(x, y);
        while (q.taken < target) {
            Rng rng(s.seed, pixel, q.taken);
            const PixelSample ld(sampler, x, y, s.width, q.taken);
            SampleContext ctx{accel, stats, rng, {}, independent ? nullptr : &ld};
            const bool first = q.taken < uint32_t(p0);
            ctx.split = first ? branches : k_later;
            ctx.branch_base = first ? q.taken * uint32_t(branches)
                                    : uint32_t(p0 * branches) +
                                          (q.taken - uint32_t(p0)) * uint32_t(k_later);
            if (branch_sampler) ctx.branch_sampler = &*branch_sampler;
            ctx.x = x;
            ctx.y = y;
            ctx.width = s.width;
            // One sample sits at the pixel centre (as the course does); more are spread
            // inside the pixel.
            Vec2f j{0.5f, 0.5f};
            if (s.spp > 1) j = ctx.get2d(dims::kPixel);
            // Lens samples are drawn only for a thin lens, so pinhole images keep their
            // random streams.
            Vec2f lens{0.5f, 0.5f};
            if (camera.lens_radius() > 0) lens = ctx.get2d(dims::kLens);
            const accel::Ray ray = camera.generate_ray((float(x) + j.x) / float(s.width),
                                                       (float(y) + j.y) / float(s.height), lens.x, lens.y);
            const Vec3f L = integrator.li(ray, ctx);
            ++q.taken;
            if (!accel::is_finite(L)) {
                ++q.bad;  // a NaN/Inf sample is counted and reported, never averaged
            } else {
                const Vec3f c[3] = {L, ctx.aov.normal, ctx.aov.albedo};
                for (int k = 0; k < 3; ++k) {
                    q.rgb[k] += double(c[0][k]);
                    q.normal[k] += double(c[1][k]);
                    q.albedo[k] += double(c[2][k]);
                }
                q.depth += double(ctx.aov.depth);
                const double lum = 0.2126 * L.x + 0.7152 * L.y + 0.0722 * L.z;
                q.s1 += lum;
                q.s2 += lum * lum;
                ++q.n;
            }
            if (s.adaptive_batch > 0 && q.taken % uint32_t(s.adaptive_batch) == 0 && q.n > 1) {
                const double n = double(q.n), mu = q.s1 / n;
                const double var = std::max(0.0, (q.s2 - q.s1 * q.s1 / n) / (n - 1));
                if (1.96 * std::sqrt(var / n) <= double(s.adaptive_tol) * mu) {
                    q.done = 1;
                    break;
                }
            }
        }
        q.rays += stats.rays - before.rays;
        q.shadow_rays += stats.shadow_rays - before.shadow_rays;
        q.nodes += stats.nodes_visited - before.nodes_visited;
        q.tests += stats.prim_tests - before.prim_tests;
    };

    auto render_tile = [&](size_t tile_index, uint32_t target, Accumulation& into) {
        if (cancelled()) return;
        accel::TraceStats& stats = thread_stats.local();
        const uint64_t rays_before = stats.total_rays();
        const Cell r = grid.rect(tile_index);
        for (int y = r.y; y < r.y + r.h; ++y) {
            // Checked per row too, so Ctrl-C answers promptly at high sample counts; a
            // pixel is never left half-way through a sample, so the state stays resumable.
            if (cancelled()) {
                stopped = true;
                return;
            }
            for (int x = r.x; x < r.x + r.w; ++x) render_pixel(x, y, target, stats, into);
        }
        progress.tile_done(stats.total_rays() - rays_before);
    };

    const int threads = s.threads > 0 ? s.threads : tbb::info::default_concurrency();
    tbb::task_arena arena(threads);
    // Every tile of the cell up to `target` samples, into `into`. Grain 1: tiles are
    // already coarse; dynamic balance matters more.
    auto render_tiles = [&](uint32_t target, Accumulation& into) {
        arena.execute([&] {
            tbb::parallel_for(tbb::blocked_range<size_t>(0, num_tiles, 1),
                              [&](const tbb::blocked_range<size_t>& r) {
                                  for (size_t i = r.begin(); i != r.end(); ++i)
                                      render_tile(i, target, into);
                              });
        });
    };
    double last_checkpoint = 0.0;
    if (p0 > 0) {
        // The first p0 samples of every pixel of the cell, then the map. A resumed
        // state's sums mix all of its samples, so its first samples are drawn again,
        // apart (the same numbers, so the same map). Under MPI every rank takes them for
        // the whole cell, so that each has the map; a tile's owner keeps its own,
        // identical, sums.
        const bool fresh = std::none_of(acc.pixels.begin(), acc.pixels.end(),
                                        [](const PixelSums& q) { return q.taken > 0; });
        Accumulation scratch;
        if (!fresh) {
            scratch.width = s.width;
            scratch.height = s.height;
            scratch.pixels.assign(acc.pixels.size(), PixelSums{});
        }
        Accumulation& first = fresh ? acc : scratch;
        // In two halves, whose difference measures the noise of a mean of stratified
        // samples (not of one sample: a pixel's edge or its light sample are stratified
        // across its samples, its branches are one stratified set).
        std::vector<double> half(size_t(cell.w) * size_t(cell.h) * 3);
        for (uint32_t target : {uint32_t(p0 / 2), uint32_t(p0)}) {
            render_tiles(target, first);
            if (target == uint32_t(p0)) break;
            for (int y = 0; y < cell.h; ++y)
                for (int x = 0; x < cell.w; ++x)
                    for (int c = 0; c < 3; ++c)
                        half[3 * (size_t(y) * size_t(cell.w) + size_t(x)) + size_t(c)] =
                            first
                                .pixels[size_t(cell.y + y) * size_t(s.width) +
                                        size_t(cell.x + x)]
                                .rgb[c];
        }
        if (cancelled()) stopped = true;
        if (!stopped)
            split_map = SplitMap::from_sums(first, half, cell, p0, branches, max_k);
        stage("rendering");
    }
    if (s.tiles) {
        // Distributed: every thread pulls tiles until the source runs dry.
        s.tiles->start(acc, grid, [&](size_t t) {
            const Cell r = grid.rect(t);
            uint64_t rays = 0;
            for (int y = r.y; y < r.y + r.h; ++y)
                for (int x = r.x; x < r.x + r.w; ++x) {
                    const PixelSums& q = acc.pixels[size_t(y) * size_t(s.width) + size_t(x)];
                    rays += q.rays + q.shadow_rays;
                }
            progress.tile_done(rays);
        });
        arena.execute([&] {
            tbb::parallel_for(0, threads, [&](int) {
                for (long t; !cancelled() && (t = s.tiles->next()) >= 0;) {
                    render_tile(size_t(t), uint32_t(s.spp), acc);
                    s.tiles->done(t);
                }
            });
        });
        s.tiles->finish();
    }
    for (int pass = 0; pass < num_passes && !s.tiles && !stopped; ++pass) {
        const auto pass_start = Clock::now();
        const uint32_t target = uint32_t(std::min(s.spp, (pass + 1) * pass_spp));
        render_tiles(target, acc);
        if (cancelled()) stopped = true;
        if (stopped) break;
        ++result.passes;
        const auto now = Clock::now();
        const double elapsed = std::chrono::duration<double>(now - start).count();
        const double pass_seconds = std::chrono::duration<double>(now - pass_start).count();
        if (pass + 1 < num_passes && s.on_checkpoint && elapsed - last_checkpoint >= s.checkpoint_every) {
            stage("writing a checkpoint");
            s.on_checkpoint(acc, false);
            stage("rendering");
            last_checkpoint = elapsed;
        }
        if (pass + 1 < num_passes && s.time_limit > 0 && elapsed + pass_seconds > s.time_limit) {
            result.time_limited = true;
            break;
        }
    }
    if (s.on_checkpoint && !s.tiles) {
        stage("writing a checkpoint");
        s.on_checkpoint(acc, true);
    }

    result.seconds = std::chrono::duration<double>(Clock::now() - start).count();
    result.split_shares = split_map.shares();
    stage("resolving the image");
    resolve(acc, result);
    result.partial = stopped.load();
    if (s.progress) {
        if (result.partial)
            std::fprintf(stderr, "%s[PathTracer] Rendering... stopped after %d of %d passes (%.4f s)\n",
                         ::isatty(2) == 1 ? "\r" : "", result.passes, num_passes, result.seconds);
        else if (result.time_limited)
            std::fprintf(stderr, "%s[PathTracer] Rendering... time limit: %d of %d passes (%.4f s)\n",
                         ::isatty(2) == 1 ? "\r" : "", result.passes, num_passes, result.seconds);
        else
            std::fprintf(stderr, "%s[PathTracer] Rendering... 100%%! (%.4fs)%s\n",
                         ::isatty(2) == 1 ? "\r" : "", result.seconds,
                         ::isatty(2) == 1 ? "                              " : "");
    }
    return result;
}

}  // namespace renderer
