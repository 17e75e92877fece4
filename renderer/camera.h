// Pinhole camera in the course's convention: the sensor plane lies one unit down -Z in
// camera space, spanning [-tan(hfov/2), tan(hfov/2)] x [-tan(vfov/2), tan(vfov/2)].
#pragma once

#include <optional>
#include <string>

#include "accel/ray.h"
#include "renderer/texture.h"
#include "scenes/scene.h"

namespace renderer {

using accel::Vec3f;

enum class CameraMode { Auto, Course, File };

/// Command-line overrides; unset fields keep what the mode chose.
struct CameraOverrides {
    std::optional<Vec3f> position, target, up;
    std::optional<float> hfov_deg;
};

class Camera {
public:
    Camera() = default;
    /// Looks from `position` at `target`; fovs in degrees.
    Camera(const Vec3f& position, const Vec3f& target, const Vec3f& up, float hfov_deg,
           float vfov_deg);
    /// Orthographic (pbrt-v4 OrthographicCamera, without its lens): rays along the view
    /// direction from the plane through `position`, over +-half_w along right and +-half_h
    /// along up.
    static Camera orthographic(const Vec3f& position, const Vec3f& target, const Vec3f& up, float half_w,
                               float half_h);
    bool is_orthographic() const { return ortho_; }
    /// Half extents of an orthographic view (world units); 0 for a perspective camera.
    float half_width() const { return ortho_ ? tan_h_ : 0.0f; }
    float half_height() const { return ortho_ ? tan_v_ : 0.0f; }

    /// Ray through image point (x, y) in [0,1]^2, y = 0 at the TOP row. The direction is
    /// normalised so that t is a distance.
    accel::Ray generate_ray(float x, float y) const;
    /// Thin lens (pbrt-v4 PerspectiveCamera; the CS184 3-2 camera): the pinhole ray's
    /// point at `focal_distance` along the view axis stays in focus; the origin moves to
    /// a point of the lens disc chosen by (u1, u2). A pinhole when the radius is 0, and for
    /// an orthographic camera.
    accel::Ray generate_ray(float x, float y, float u1, float u2) const;
    void set_lens(float radius, float focal_distance) {
        lens_radius_ = radius;
        focal_distance_ = focal_distance;
    }
    float lens_radius() const { return lens_radius_; }
    float focal_distance() const { return focal_distance_; }

    /// The per-pixel spread of a width x height image at `spp` samples per pixel, for
    /// texture footprints (renderer/texture.h).
    PixelSpread pixel_spread(int width, int height, int spp) const;

    Vec3f position() const { return pos_; }
    Vec3f forward() const { return fwd_; }
    /// Fields of view (degrees); 0 for an orthographic camera.
    float hfov_deg() const;
    float vfov_deg() const;

private:
    Vec3f pos_, right_, up_, fwd_;
    float tan_h_ = 1, tan_v_ = 1;  ///< orthographic: the half extents
    bool ortho_ = false;
    float lens_radius_ = 0, focal_distance_ = 1;
};

/// The course application's camera settings file (CS184 Camera::save_settings): hFov vFov
/// ar nClip fClip; position (3); target (3); phi theta r minR maxR; camera-to-world (9,
/// row by row); screenW screenH screenDist; and, in the 3-2 version, focalDistance
/// lensRadius (absent: a pinhole).
struct CameraSettings {
    float hfov_deg = 0, vfov_deg = 0, aspect = 0;
    Vec3f position, target, up;
    bool has_lens = false;
    float focal_distance = 0, lens_radius = 0;
};
/// Throws std::invalid_argument naming the file and the field that is missing or bad.
CameraSettings read_camera_settings(const std::string& path);

struct CameraSetup {
    Camera camera;
    std::string description;  ///< one line for stderr: which camera was used and why
};

/// Chooses the camera for a W x H image:
///  - Course (default for CS184 .dae): the course application's framing (see
///    ../shared/scenes/README.md): look at the bounds' centre from 1.5 x the diagonal,
///    along the camera node's transform applied to (0,0,-1); an 800x600 window that
///    keeps the file's wider fov (xfov, or vfov from yfov/aspect_ratio) and widens the
///    other to 800:600, whose sensor distance is kept, so W x H is its central W x H pixels.
///  - File (default for glTF): the camera node as written.
///  - No camera in the file: frame the scene's bounds from the front.
CameraSetup make_camera(const scenes::Scene& scene, CameraMode mode, int width, int height,
                        const CameraOverrides& overrides = {});

}  // namespace renderer
