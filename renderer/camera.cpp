#include "renderer/camera.h"

#include <fmt/format.h>

#include <cmath>

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

accel::Ray Camera::generate_ray(float x, float y) const {
    // Camera space: sensor at z = -1; image top (y = 0) maps to +tan_v.
    const float cx = (2.0f * x - 1.0f) * tan_h_;
    const float cy = (1.0f - 2.0f * y) * tan_v_;
    accel::Ray ray;
    ray.org = pos_;
    ray.dir = accel::normalize(right_ * cx + up_ * cy + fwd_);
    ray.t_min = 0.0f;
    ray.t_max = accel::kInfinity;
    return ray;
}

float Camera::hfov_deg() const { return 2.0f * deg(std::atan(tan_h_)); }
float Camera::vfov_deg() const { return 2.0f * deg(std::atan(tan_v_)); }

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
    if (scene.camera && mode == CameraMode::Course) {
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
        // Keep whichever fov the file fixes; derive the other from the image aspect.
        if (c.yfov_deg > 0 && (c.xfov_deg <= 0 || scene.format == scenes::SceneFormat::Gltf)) {
            vfov = c.yfov_deg;
            hfov = 2.0f * deg(std::atan(std::tan(0.5f * vfov * kDegToRad) * aspect));
        } else {
            hfov = c.xfov_deg;
            vfov = 2.0f * deg(std::atan(std::tan(0.5f * hfov * kDegToRad) / aspect));
        }
        what = fmt::format("file camera '{}'", c.name);
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
    CameraSetup setup{Camera(pos, target, up, hfov, vfov), {}};
    setup.description = fmt::format(
        "[PathTracer] Camera: {}; at ({:.3g}, {:.3g}, {:.3g}) looking at ({:.3g}, {:.3g}, "
        "{:.3g}), fov {:.2f} x {:.2f} deg",
        what, pos.x, pos.y, pos.z, target.x, target.y, target.z, hfov, vfov);
    return setup;
}

}  // namespace renderer
