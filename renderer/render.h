// The image loop: tiles over TBB, per-pixel random streams, per-thread statistics,
// progress on stderr, clean stop on Ctrl-C.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>

#include "accel/accelerator.h"
#include "renderer/camera.h"
#include "renderer/image.h"
#include "renderer/integrator.h"

namespace renderer {

struct Cell {
    int x = 0, y = 0, w = 0, h = 0;  ///< -p X Y DX DY, in pixels, y from the top
};

struct RenderSettings {
    int width = 800, height = 600;
    int spp = 1;            ///< -s: samples per pixel (the cap under adaptive sampling)
    int threads = 0;        ///< -t: 0 = all cores
    uint64_t seed = 0;
    std::optional<Cell> cell;
    bool progress = true;   ///< print progress lines on stderr
    int tile = 32;
    /// -a BATCH TOL: every BATCH samples, stop the pixel once 1.96 sigma / sqrt(n) <= TOL mu
    /// (illuminance); spp is the cap. 0 = off.
    int adaptive_batch = 0;
    float adaptive_tol = 0.05f;
    /// Set from a signal handler to stop early; finished tiles are kept.
    const std::atomic<bool>* cancel = nullptr;
};

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
    bool partial = false;     ///< stopped before every tile was done
    uint64_t nan_samples = 0; ///< non-finite samples dropped (counted, never averaged)
};

RenderResult render(const Camera& camera, const Integrator& integrator,
                    const accel::Accelerator& accel, const RenderSettings& settings);

}  // namespace renderer
