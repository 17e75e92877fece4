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
    /// Set from a signal handler to stop early; finished tiles are kept.
    const std::atomic<bool>* cancel = nullptr;
};

/// Channel layout of RenderResult::image.
enum Channel : int { kR, kG, kB, kNx, kNy, kNz, kAlbedoR, kAlbedoG, kAlbedoB, kDepth, kSamples, kNumChannels };

struct RenderResult {
    /// R,G,B (mean radiance), N.{X,Y,Z}, albedo.{R,G,B}, Z (depth), samples.
    Image image;
    accel::TraceStats stats;  ///< summed over threads
    double seconds = 0.0;
    uint64_t samples = 0;     ///< camera samples taken
    bool partial = false;     ///< stopped before every tile was done
};

RenderResult render(const Camera& camera, const Integrator& integrator,
                    const accel::Accelerator& accel, const RenderSettings& settings);

}  // namespace renderer
