#include "renderer/camera.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace renderer {

namespace {
constexpr float kDegToRad = accel::kPi / 180.0f;
float deg(float rad) { return rad / kDegToRad; }

/// Any unit vector not parallel to `v`, for an up vector that degenerates.
Vec3f fallback_up(const Vec3f& fwd, const Vec3f& up) {
    if (accel::length(accel::cross(fwd, up)) > 1e-6f) return up;
    return std::abs(fwd.y) < 0.9f ? Vec3f(0, 1, 0) : Vec3f(0, 0, 1);
}
}  // namespace

Camera::Camera(const Vec3f& position, const Vec3f& target, const Vec3f& up, float hfov_deg,
               float vfov_deg)
    : pos_(position) {
    fwd_ = accel::normalize(target - position);
    right_ = accel::normalize(accel::cross(fwd_, fallback_up(fwd_, up)));
    up_ = accel::cross(right_, fwd_);
    tan_h_ = std::tan(0.5f * hfov_deg * kDegToRad);
    tan_v_ = std::tan(0.5f * vfov_deg * kDegToRad);
}

Camera Camera::orthographic(const Vec3f& position, const Vec3f& target, const Vec3f& up, float half_w,
                           float half_h) {
    Camera c(position, target, up, 90.0f, 90.0f);
    c.ortho_ = true;
    c.tan_h_ = half_w;
    c.tan_v_ = half_h;
    return c;
}

accel::Ray Camera::generate_ray(float x, float y) const {
    // Camera space: sensor at z = -1; image top (y = 0) maps to +tan_v.
    const float cx = (2.0f * x - 1.0f) * tan_h_;
    const float cy = (1.0f - 2.0f * y) * tan_v_;
    accel::Ray ray;
    if (ortho_) {
        ray.org = pos_ + right_ * cx + up_ * cy;
        ray.dir = fwd_;
        ray.t_min = 0.0f;
        ray.t_max = accel::kInfinity;
        return ray;
    }
    ray.org = pos_;
    ray.dir = accel::normalize(right_ * cx + up_ * cy + fwd_);
    ray.t_min = 0.0f;
    ray.t_max = accel::kInfinity;
    return ray;
}

accel::Ray Camera::generate_ray(float x, float y, float u1, float u2) const {
    accel::Ray ray = generate_ray(x, y);
    if (!(lens_radius_ > 0) || ortho_) return ray;
    // The in-focus point lies on the plane focal_distance in front of the camera.
    const float t = focal_distance_ / accel::dot(ray.dir, fwd_);
    const Vec3f focus = pos_ + ray.dir * t;
    // Concentric-free polar mapping of the disc, as the course samples its lens.
    const float r = lens_radius_ * std::sqrt(u1), phi = 2.0f * accel::kPi * u2;
    ray.org = pos_ + right_ * (r * std::cos(phi)) + up_ * (r * std::sin(phi));
    ray.dir = accel::normalize(focus - ray.org);
    return ray;
}

PixelSpread Camera::pixel_spread(int width, int height, int spp) const {
    PixelSpread s;
    if (width <= 0 || height <= 0) return s;
    // pbrt-v4 (Camera::Approximate_dp_dxy, 5.2.4): more samples per pixel already
    // average over the pixel, so each one's filter narrows, down to an eighth.
    const float scale = std::max(0.125f, 1.0f / std::sqrt(float(std::max(1, spp))));
    s.position = pos_;
    s.right = right_;
    s.up = up_;
    s.forward = fwd_;
    s.dx = 2.0f * tan_h_ / float(width) * scale;
    s.dy = 2.0f * tan_v_ / float(height) * scale;
    s.orthographic = ortho_;
    return s;
}

CameraSettings read_camera_settings(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::invalid_argument(path + ": cannot read the camera settings file");
    std::stringstream text;
    text << in.rdbuf();
    static const char* const kFields[] = {
        "hFov", "vFov", "ar", "nClip", "fClip", "position.x", "position.y", "position.z", "target.x", "target.y",
        "target.z", "phi", "theta", "r", "minR", "maxR", "c2w[0][0]", "c2w[0][1]", "c2w[0][2]", "c2w[1][0]",
        "c2w[1][1]", "c2w[1][2]", "c2w[2][0]", "c2w[2][1]", "c2w[2][2]", "screenW", "screenH", "screenDist",
        "focalDistance", "lensRadius"};
    constexpr size_t kBase = 28, kAll = 30;
    float v[kAll] = {};
    size_t got = 0;
    std::string tok;
    while (got < kAll && text >> tok) {
        char* end = nullptr;
        v[got] = std::strtof(tok.c_str(), &end);
        if (end == tok.c_str() || *end != '\0' || !std::isfinite(v[got]))
            throw std::invalid_argument(fmt::format("{}: field {} ({}): '{}' is not a finite number", path, got + 1,
                                                    kFields[got], tok));
        ++got;
    }
    if (got < kBase)
        throw std::invalid_argument(fmt::format("{}: field {} ({}) is missing: the file has {} of the {} numbers",
                                                path, got + 1, kFields[got], got, kBase));
    if (got != kBase && got != kAll)
        throw std::invalid_argument(fmt::format("{}: field {} ({}) is missing: 3-2 files end with focalDistance "
                                                "lensRadius", path, got + 1, kFields[got]));
    if (text >> tok) throw std::invalid_argument(fmt::format("{}: unexpected text after lensRadius: '{}'", path, tok));
    auto check = [&](size_t i, bool ok, const char* why) {
        if (!ok) throw std::invalid_argument(fmt::format("{}: field {} ({}) = {:g} {}", path, i + 1, kFields[i], v[i], why));
    };
    check(0, v[0] > 0 && v[0] < 180, "must be in (0, 180) degrees");
    check(1, v[1] > 0 && v[1] < 180, "must be in (0, 180) degrees");
    CameraSettings c;
    c.hfov_deg = v[0];
    c.vfov_deg = v[1];
    c.aspect = v[2];
    c.position = {v[5], v[6], v[7]};
    c.target = {v[8], v[9], v[10]};
    // The course's camera-to-world columns are (right, up, back).
    c.up = {v[17], v[20], v[23]};
    if (accel::length(c.target - c.position) == 0)
        throw std::invalid_argument(fmt::format("{}: fields 6-11 (position, target): the target equals the position", path));
    if (got == kAll) {
        check(28, v[28] > 0, "must be positive");
        check(29, v[29] >= 0, "must not be negative");
        c.has_lens = true;
        c.focal_distance = v[28];
        c.lens_radius = v[29];
    }
    return c;
}

float Camera::hfov_deg() const { return ortho_ ? 0.0f : 2.0f * deg(std::atan(tan_h_)); }
float Camera::vfov_deg() const { return ortho_ ? 0.0f : 2.0f * deg(std::atan(tan_v_)); }

CameraSetup make_camera(const scenes::Scene& scene, CameraMode mode, int width, int height,
                        const CameraOverrides& ov) {
    const accel::Bounds3f bounds = scene.bounds();
    const Vec3f center = bounds.empty() ? Vec3f(0.0f) : bounds.center();
    const float diag = bounds.empty() ? 1.0f : accel::length(bounds.diagonal());
    const float aspect = float(width) / float(height);

    if (mode == CameraMode::Auto)
        mode = scene.format == scenes::SceneFormat::Collada ? CameraMode::Course : CameraMode::File;

    Vec3f pos, target, up = scene.up;
    float hfov, vfov;
    std::string what;
    // An orthographic file camera is used as written in either mode (the course's
    // framing is a perspective one's), unless a field of view is asked for.
    const bool ortho = scene.camera && scene.camera->orthographic && !ov.hfov_deg;
    float half_w = 0, half_h = 0;
    if (scene.camera && mode == CameraMode::Course && !ortho) {
        const scenes::Camera& c = *scene.camera;
        // The course's Camera::configure sets up an 800x600 window: it takes the file's
        // xfov and vfov (yfov, else from aspect_ratio) and widens whichever is too narrow
        // for 800:600. `-r W H` keeps that window's sensor distance, so a W x H render is
        // its central W x H pixels: tan(hfov'/2) = tan(hfov800/2) * W / 800.
        constexpr float kWinW = 800.0f, kWinH = 600.0f;
        float tan_x = std::tan(0.5f * c.xfov_deg * kDegToRad);
        float tan_y = c.yfov_deg > 0 ? std::tan(0.5f * c.yfov_deg * kDegToRad)
                      : c.aspect > 0  ? tan_x / c.aspect
                                      : tan_x * kWinH / kWinW;
        if (tan_x / tan_y > kWinW / kWinH)
            tan_y = tan_x * kWinH / kWinW;
        else
            tan_x = tan_y * kWinW / kWinH;
        hfov = 2.0f * deg(std::atan(tan_x * float(width) / kWinW));
        vfov = 2.0f * deg(std::atan(tan_y * float(height) / kWinH));
        Vec3f dir = c.camera_to_world.transform_point(Vec3f(0.0f, 0.0f, -1.0f));
        dir = accel::length(dir) > 0 ? accel::normalize(dir) : Vec3f(0, 0, 1);
        target = center;
        pos = center + dir * (1.5f * diag);
        what = "course framing (file camera's fov and direction, 1.5 x bounds diagonal)";
    } else if (scene.camera) {
        const scenes::Camera& c = *scene.camera;
        pos = c.camera_to_world.transform_point(Vec3f(0.0f));
        target = pos + c.camera_to_world.transform_vector(Vec3f(0.0f, 0.0f, -1.0f));
        up = c.camera_to_world.transform_vector(Vec3f(0.0f, 1.0f, 0.0f));
        what = fmt::format("file camera '{}'", c.name);
        // Keep whichever fov (orthographic: magnification) the file fixes, glTF's y and
        // COLLADA's x; derive the other from the image aspect.
        if (ortho) {
            if (c.ymag > 0 && (c.xmag <= 0 || scene.format == scenes::SceneFormat::Gltf)) {
                half_h = c.ymag;
                half_w = half_h * aspect;
            } else {
                half_w = c.xmag;
                half_h = half_w / aspect;
            }
            hfov = vfov = 0.0f;
            what += ", orthographic";
        } else if (c.yfov_deg > 0 && (c.xfov_deg <= 0 || scene.format == scenes::SceneFormat::Gltf)) {
            vfov = c.yfov_deg;
            hfov = 2.0f * deg(std::atan(std::tan(0.5f * vfov * kDegToRad) * aspect));
        } else {
            hfov = c.xfov_deg;
            vfov = 2.0f * deg(std::atan(std::tan(0.5f * hfov * kDegToRad) / aspect));
        }
    } else {
        // No camera: look at the bounds from the front (+Z for Y-up files, -Y for Z-up),
        // slightly above, far enough that the bounding sphere fits the vertical fov.
        vfov = 40.0f;
        hfov = 2.0f * deg(std::atan(std::tan(0.5f * vfov * kDegToRad) * aspect));
        Vec3f front = scene.up.z > 0.5f ? Vec3f(0, -1, 0) : Vec3f(0, 0, 1);
        Vec3f dir = accel::normalize(front + scene.up * 0.3f);
        float radius = 0.5f * diag;
        float half = 0.5f * std::min(hfov, vfov) * kDegToRad;
        target = center;
        pos = center + dir * (radius / std::sin(half) * 1.05f);
        what = "default camera framing the scene bounds (the file has no camera)";
    }
    if (ov.position) pos = *ov.position;
    if (ov.target) target = *ov.target;
    if (ov.up) up = *ov.up;
    if (ov.hfov_deg) {
        hfov = *ov.hfov_deg;
        vfov = 2.0f * deg(std::atan(std::tan(0.5f * hfov * kDegToRad) / aspect));
    }
    if (ov.position || ov.target || ov.up || ov.hfov_deg) what += ", with command-line overrides";
    CameraSetup setup{ortho ? Camera::orthographic(pos, target, up, half_w, half_h) : Camera(pos, target, up, hfov, vfov),
                      {}};
    setup.description = fmt::format(
        "[PathTracer] Camera: {}; at ({:.3g}, {:.3g}, {:.3g}) looking at ({:.3g}, {:.3g}, {:.3g}), {}", what, pos.x,
        pos.y, pos.z, target.x, target.y, target.z,
        ortho ? fmt::format("view {:.3g} x {:.3g}", 2 * half_w, 2 * half_h)
              : fmt::format("fov {:.2f} x {:.2f} deg", hfov, vfov));
    return setup;
}

}  // namespace renderer
