// Environment light from a latitude-longitude image (-e FILE): radiance by direction and
// importance sampling from a piecewise-constant 2D distribution of luminance x sin(theta)
// (pbrt-v4 ImageInfiniteLight with PiecewiseConstant2D; Pharr, Jakob, Humphreys,
// "Physically Based Rendering" 4th ed., A.5.6 and 12.5.2). The image's pole is the scene's
// up axis; row 0 is straight up, u runs with the azimuth.
#pragma once

#include <string>
#include <vector>

#include "accel/math.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec3f;

/// Reading the image (-e FILE) is load_environment_image, in renderer/image.h: file I/O
/// lives in the renderer_image library.

class EnvironmentMap {
public:
    EnvironmentMap() = default;
    /// `up`: the scene's up axis (the map's pole). `scale` multiplies the radiance. The map
    /// reads `image` (level 0, at its stored precision) in place rather than keeping a
    /// copy: the image must outlive the map (the scene's textures do).
    EnvironmentMap(const scenes::Texture& image, const Vec3f& up, const Vec3f& scale = Vec3f(1.0f));
    EnvironmentMap(scenes::Texture&&, const Vec3f&, const Vec3f& = Vec3f(1.0f)) = delete;

    bool empty() const { return w_ == 0; }
    Vec3f radiance(const Vec3f& dir) const;
    /// Direction by importance; pdf in solid angle. False if the map is black.
    bool sample(float u1, float u2, Vec3f& dir, float& pdf, Vec3f& radiance) const;
    float pdf(const Vec3f& dir) const;
    /// Uniform-sphere sampling of the same map, kept for the variance comparison test.
    static constexpr float kUniformPdf = 1.0f / (4.0f * accel::kPi);

private:
    void to_uv(const Vec3f& dir, float& u, float& v) const;
    Vec3f from_uv(float u, float v) const;
    Vec3f texel(uint32_t x, uint32_t y) const;

    uint32_t w_ = 0, h_ = 0;
    const scenes::Texture* image_ = nullptr;
    Vec3f scale_{1.0f};
    Vec3f e1_, e2_, up_;               // frame: up_ is the pole
    std::vector<float> row_cdf_;       // h_+1 entries, marginal over rows
    std::vector<float> col_cdf_;       // h_ * (w_+1), conditional per row
    std::vector<float> row_func_;      // per-row integral (unnormalised)
    std::vector<float> func_;          // per-texel weight
    float total_ = 0;                  // integral of func over [0,1]^2
};

}  // namespace renderer
