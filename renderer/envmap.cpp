#include "renderer/envmap.h"

#include <algorithm>
#include <cmath>

#include "renderer/sampling.h"
#include "renderer/texture.h"

namespace renderer {

EnvironmentMap::EnvironmentMap(const scenes::Texture& image, const Vec3f& up, const Vec3f& scale)
    : w_(image.empty() ? 0 : image.width), h_(image.empty() ? 0 : image.height), image_(&image), scale_(scale) {
    up_ = accel::normalize(up);
    onb(up_, e1_, e2_);
    // Piecewise-constant weights: luminance x sin(theta) at the row centre, so the pdf in
    // solid angle (which divides by sin theta) follows luminance alone.
    func_.resize(size_t(w_) * h_);
    row_func_.resize(h_);
    col_cdf_.resize(size_t(h_) * (w_ + 1));
    row_cdf_.resize(h_ + 1);
    for (uint32_t y = 0; y < h_; ++y) {
        const float sin_t = std::sin(accel::kPi * (float(y) + 0.5f) / float(h_));
        float* cdf = &col_cdf_[size_t(y) * (w_ + 1)];
        cdf[0] = 0;
        for (uint32_t x = 0; x < w_; ++x) {
            const Vec3f c = texel(x, y);
            const float f = (0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z) * sin_t;
            func_[size_t(y) * w_ + x] = f;
            cdf[x + 1] = cdf[x] + f / float(w_);
        }
        row_func_[y] = cdf[w_];
        if (cdf[w_] > 0)
            for (uint32_t x = 1; x <= w_; ++x) cdf[x] /= cdf[w_];
        else
            for (uint32_t x = 1; x <= w_; ++x) cdf[x] = float(x) / float(w_);
    }
    row_cdf_[0] = 0;
    for (uint32_t y = 0; y < h_; ++y) row_cdf_[y + 1] = row_cdf_[y] + row_func_[y] / float(h_);
    total_ = row_cdf_[h_];
    if (total_ > 0)
        for (uint32_t y = 1; y <= h_; ++y) row_cdf_[y] /= total_;
}

Vec3f EnvironmentMap::texel(uint32_t x, uint32_t y) const {
    // Unfiltered: the sampling distribution is piecewise constant over texels, and the
    // radiance must be the same function.
    const Vec3f c = fetch(*image_, 0, x, y).rgb();
    return {c.x * scale_.x, c.y * scale_.y, c.z * scale_.z};
}

void EnvironmentMap::to_uv(const Vec3f& d, float& u, float& v) const {
    const float z = std::clamp(accel::dot(d, up_), -1.0f, 1.0f);
    float phi = std::atan2(accel::dot(d, e2_), accel::dot(d, e1_));
    if (phi < 0) phi += 2.0f * accel::kPi;
    u = phi / (2.0f * accel::kPi);
    v = std::acos(z) / accel::kPi;
}

Vec3f EnvironmentMap::from_uv(float u, float v) const {
    const float theta = v * accel::kPi, phi = u * 2.0f * accel::kPi;
    const float s = std::sin(theta);
    return e1_ * (s * std::cos(phi)) + e2_ * (s * std::sin(phi)) + up_ * std::cos(theta);
}

Vec3f EnvironmentMap::radiance(const Vec3f& dir) const {
    float u, v;
    to_uv(dir, u, v);
    const uint32_t x = std::min(w_ - 1, uint32_t(u * float(w_)));
    const uint32_t y = std::min(h_ - 1, uint32_t(v * float(h_)));
    return texel(x, y);
}

namespace {
/// Index i with cdf[i] <= u < cdf[i+1] over n intervals, and the offset within it.
uint32_t find_interval(const float* cdf, uint32_t n, float u, float& du) {
    const uint32_t i = uint32_t(std::clamp<long>(std::upper_bound(cdf, cdf + n + 1, u) - cdf - 1, 0L, long(n) - 1));
    const float width = cdf[i + 1] - cdf[i];
    du = width > 0 ? (u - cdf[i]) / width : 0.5f;
    return i;
}
}  // namespace

bool EnvironmentMap::sample(float u1, float u2, Vec3f& dir, float& pdf, Vec3f& radiance) const {
    if (!(total_ > 0)) return false;
    float dv, du;
    const uint32_t y = find_interval(row_cdf_.data(), h_, u1, dv);
    const uint32_t x = find_interval(&col_cdf_[size_t(y) * (w_ + 1)], w_, u2, du);
    const float f = func_[size_t(y) * w_ + x];
    if (!(f > 0)) return false;
    const float u = (float(x) + du) / float(w_), v = (float(y) + dv) / float(h_);
    dir = from_uv(u, v);
    const float sin_t = std::sin(v * accel::kPi);
    if (!(sin_t > 0)) return false;
    // pdf(u, v) = f / total; d omega = 2 pi^2 sin(theta) du dv. The weight uses the row
    // centre's sin(theta) while the density of directions uses the sample's own.
    pdf = (f / total_) / (2.0f * accel::kPi * accel::kPi * sin_t);
    radiance = texel(x, y);
    return pdf > 0;
}

float EnvironmentMap::pdf(const Vec3f& dir) const {
    if (!(total_ > 0)) return 0.0f;
    float u, v;
    to_uv(dir, u, v);
    const uint32_t x = std::min(w_ - 1, uint32_t(u * float(w_)));
    const uint32_t y = std::min(h_ - 1, uint32_t(v * float(h_)));
    const float sin_t = std::sin(v * accel::kPi);
    if (!(sin_t > 0)) return 0.0f;
    return (func_[size_t(y) * w_ + x] / total_) / (2.0f * accel::kPi * accel::kPi * sin_t);
}

}  // namespace renderer
