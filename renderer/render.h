// The image loop: samples in passes, tiles over TBB, per-sample random numbers, per-pixel
// sums, progress on stderr, clean stop on Ctrl-C. Each pixel's sums are accumulated in
// double in sample order, so the image does not depend on the schedule: any split into
// tiles, passes, threads, ranks or a resumed checkpoint gives the same bits.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "accel/accelerator.h"
#include "renderer/camera.h"
#include "renderer/image.h"
#include "renderer/integrator.h"
#include "renderer/sampler.h"

namespace renderer {

struct Cell {
    int x = 0, y = 0, w = 0, h = 0;  ///< -p X Y DX DY, in pixels, y from the top
};

/// Everything a pixel has accumulated; a checkpoint is an array of these. Counters are
/// kept per pixel so that the statistics lines are sums over pixels, whoever rendered them.
struct PixelSums {
    double rgb[3] = {0, 0, 0}, normal[3] = {0, 0, 0}, albedo[3] = {0, 0, 0};
    double depth = 0, s1 = 0, s2 = 0;  ///< s1, s2: illuminance sums for the confidence test
    uint64_t rays = 0, shadow_rays = 0, nodes = 0, tests = 0;
    uint32_t taken = 0;  ///< samples taken (sample indices 0..taken-1)
    uint32_t n = 0;      ///< finite samples among them
    uint32_t bad = 0;    ///< NaN/Inf samples dropped
    uint32_t done = 0;   ///< 1 once the adaptive test stopped the pixel
};
static_assert(sizeof(PixelSums) == 144, "checkpoint layout");

/// The accumulated state of a render, row-major over the whole image.
struct Accumulation {
    int width = 0, height = 0;
    std::vector<PixelSums> pixels;
};

/// The tiles of a render: index -> pixel rectangle [x0, x1) x [y0, y1).
struct TileGrid {
    Cell cell;
    int tile = 32, tiles_x = 0, tiles_y = 0;
    size_t count() const { return size_t(tiles_x) * size_t(tiles_y); }
    Cell rect(size_t i) const;
};

/// Hands out tiles on demand and takes the finished ones, for a render spread over
/// processes (tools/distributed.cpp implements it over MPI). Each tile is rendered to the
/// full sample count by whoever takes it; per-pixel sums keep the image bit-identical.
struct TileSource {
    virtual ~TileSource() = default;
    /// Before the render threads start: the state finished tiles are written into, and
    /// a callback for each tile that arrives from elsewhere (progress).
    virtual void start(Accumulation& acc, const TileGrid& grid,
                       std::function<void(size_t tile)> arrived) = 0;
    /// The next tile for a render thread, or -1 when none is left (called concurrently).
    virtual long next() = 0;
    /// A render thread finished `tile` (its pixels are in the state).
    virtual void done(long tile) = 0;
    /// After the render threads end: wait for every tile from elsewhere.
    virtual void finish() = 0;
};

struct RenderSettings {
    int width = 800, height = 600;
    int spp = 1;            ///< -s: samples per pixel (the cap under adaptive sampling)
    int threads = 0;        ///< -t: 0 = all cores
    uint64_t seed = 0;
    /// --sampler: where each sample's numbers come from (renderer/sampler.h); the
    /// default's measurements: renderer/README.md, "Samplers and roulette".
    SamplerKind sampler = SamplerKind::Sobol;
    std::optional<Cell> cell;
    bool progress = true;   ///< print progress lines on stderr
    int tile = 32;
    /// -a BATCH TOL: every BATCH samples, stop the pixel once 1.96 sigma / sqrt(n) <= TOL mu
    /// (illuminance); spp is the cap. 0 = off.
    int adaptive_batch = 0;
    float adaptive_tol = 0.05f;
    /// Samples per pass (0 = auto: the adaptive batch, else 8). Passes are the unit of
    /// progressive rendering, of --time-limit and of checkpoints.
    int pass_spp = 0;
    /// --time-limit: stop after the last pass that is expected to end within this many
    /// seconds (the first pass always runs). 0 = no limit.
    double time_limit = 0.0;
    /// Continue from this state (a checkpoint); its size must match the image.
    const Accumulation* resume = nullptr;
    /// Called between passes, at most every checkpoint_every seconds, and once at the end
    /// (final = true), with the state so far: a caller writes its checkpoint here.
    std::function<void(const Accumulation&, bool final)> on_checkpoint;
    double checkpoint_every = 60.0;
    /// Distributed render: tiles come from here, each to full spp (no passes, checkpoints
    /// or time limit). nullptr = this process renders every tile.
    TileSource* tiles = nullptr;
    /// Set from a signal handler to stop early; finished pixels are kept.
    const std::atomic<bool>* cancel = nullptr;
    /// Told what render() does next ("allocating the film", "rendering", "writing a
    /// checkpoint", "resolving the image"), so that a caller can name the step in which
    /// memory ran out.
    std::function<void(const char* stage)> on_stage;
};

/// Bytes of the film render() allocates for a width x height image: the per-pixel sums
/// (PixelSums), three times when resuming (the checkpoint read, the state continued from
/// it, and the first samples drawn again apart for the split's map,
/// renderer/split_map.h), and the resolved image (RenderResult::image), which lives
/// beside the sums.
uint64_t film_bytes(int width, int height, bool resume);

/// Channel layout of RenderResult::image.
enum Channel : int {
    kR, kG, kB, kNx, kNy, kNz, kAlbedoR, kAlbedoG, kAlbedoB, kDepth, kSamples,
    kVariance,   ///< variance of the pixel mean's illuminance (sample variance / n)
    kCostNodes,  ///< BVH nodes visited per camera sample, by the backend that did the work
    kCostTests,  ///< primitive tests per camera sample
    kNaN,        ///< samples dropped because they were NaN or infinite
    kNumChannels
};

struct RenderResult {
    /// See Channel: mean radiance, AOVs, sample count, variance, cost.
    Image image;
    accel::TraceStats stats;  ///< summed over threads
    double seconds = 0.0;
    uint64_t samples = 0;     ///< camera samples taken
    bool partial = false;     ///< stopped (Ctrl-C) before every pass was done
    bool time_limited = false;///< --time-limit ended the render before spp
    int passes = 0;           ///< passes completed in this run
    uint64_t nan_samples = 0; ///< non-finite samples dropped (counted, never averaged)
    Accumulation sums;        ///< the state, for a checkpoint or a gather
    /// Split by noise (renderer/split_map.h): the share of the pixels whose camera hits
    /// split, per branch count their later samples take; empty under a uniform split.
    std::vector<std::pair<int, double>> split_shares;
};

/// The image channels (see Channel) and the totals of an accumulated state.
void resolve(const Accumulation& acc, RenderResult& result);

RenderResult render(const Camera& camera, const Integrator& integrator,
                    const accel::Accelerator& accel, const RenderSettings& settings);

}  // namespace renderer
