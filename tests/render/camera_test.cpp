// The course framing's fields of view (../shared/scenes/README.md, "How the course
// application treats these files"): an 800x600 window that widens whichever of the file's
// fovs is too narrow for 800:600, of which a W x H render is the central W x H pixels.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "renderer/camera.h"
#include "scenes/load.h"

using accel::Vec3f;

namespace {

constexpr double kPi = 3.14159265358979323846;
double tan_half(double deg) { return std::tan(deg * kPi / 360.0); }
double fov_of(double tan_half_fov) { return 2.0 * std::atan(tan_half_fov) * 180.0 / kPi; }

scenes::Scene scene_with_camera(float xfov, float yfov, float aspect) {
    scenes::Scene s;
    s.format = scenes::SceneFormat::Collada;
    scenes::Camera c;
    c.name = "cam";
    c.xfov_deg = xfov;
    c.yfov_deg = yfov;
    c.aspect = aspect;
    s.camera = c;
    return s;
}

struct Fovs {
    double h, v;
};
Fovs course_fovs(const scenes::Scene& s, int w, int h) {
    const renderer::Camera cam = renderer::make_camera(s, renderer::CameraMode::Course, w, h).camera;
    return {cam.hfov_deg(), cam.vfov_deg()};
}

}  // namespace

// A 16:9 file (wider than the window): the window keeps xfov; the vertical fov follows
// from 800:600, not from the file's aspect_ratio.
TEST(CourseFraming, WideFileKeepsXfov) {
    const scenes::Scene s = scene_with_camera(49.13434f, 0.0f, 16.0f / 9.0f);
    const Fovs full = course_fovs(s, 800, 600);
    EXPECT_NEAR(full.h, 49.13434, 1e-3);
    EXPECT_NEAR(full.v, fov_of(tan_half(49.13434) * 600.0 / 800.0), 1e-3);
    // 480x360 is the central 60 % of the window.
    const Fovs part = course_fovs(s, 480, 360);
    EXPECT_NEAR(part.h, fov_of(tan_half(49.13434) * 480.0 / 800.0), 1e-3);
    EXPECT_NEAR(part.h, 30.67, 0.01);
    EXPECT_NEAR(part.v, fov_of(tan_half(49.13434) * 360.0 / 800.0), 1e-3);
}

// A 4:3 file (the window's own ratio): both fovs are kept as written.
TEST(CourseFraming, FourThreeFileKeepsBoth) {
    const scenes::Scene s = scene_with_camera(49.13434f, 0.0f, 4.0f / 3.0f);
    const Fovs full = course_fovs(s, 800, 600);
    EXPECT_NEAR(full.h, 49.13434, 1e-3);
    EXPECT_NEAR(full.v, fov_of(tan_half(49.13434) * 0.75), 1e-3);
    // Same xfov, same framing as the 16:9 file: the file's aspect only matters when narrower.
    const Fovs wide = course_fovs(scene_with_camera(49.13434f, 0.0f, 16.0f / 9.0f), 480, 360);
    const Fovs part = course_fovs(s, 480, 360);
    EXPECT_NEAR(part.h, wide.h, 1e-4);
    EXPECT_NEAR(part.v, wide.v, 1e-4);
}

// A file narrower than 800:600 (square, or yfov given wide): the window keeps vfov and
// widens the horizontal fov.
TEST(CourseFraming, NarrowFileKeepsVfov) {
    const Fovs square = course_fovs(scene_with_camera(40.0f, 0.0f, 1.0f), 800, 600);
    EXPECT_NEAR(square.v, 40.0, 1e-3);
    EXPECT_NEAR(square.h, fov_of(tan_half(40.0) * 800.0 / 600.0), 1e-3);
    const Fovs yfov = course_fovs(scene_with_camera(30.0f, 35.0f, 0.0f), 400, 300);
    EXPECT_NEAR(yfov.v, fov_of(tan_half(35.0) * 300.0 / 600.0), 1e-3);
    EXPECT_NEAR(yfov.h, fov_of(tan_half(35.0) * 400.0 / 600.0), 1e-3);
    // yfov given and wider than 800:600 allows: xfov wins over it.
    const Fovs flat = course_fovs(scene_with_camera(60.0f, 20.0f, 0.0f), 800, 600);
    EXPECT_NEAR(flat.h, 60.0, 1e-3);
    EXPECT_NEAR(flat.v, fov_of(tan_half(60.0) * 0.75), 1e-3);
}

// The real files: CBbunny (16:9) and CBspheres_lambertian (4:3) share xfov 49.13 and so
// the write-ups' 480x360 framing, hfov 30.67 degrees.
TEST(CourseFraming, SharedFilesOfBothAspects) {
    if (!std::filesystem::exists(PT_SHARED_SCENES))
        GTEST_SKIP() << "shared scene corpus not found at " << PT_SHARED_SCENES;
    for (const char* name : {"cs184/CBbunny.dae", "cs184/CBspheres_lambertian.dae"}) {
        SCOPED_TRACE(name);
        const scenes::Scene s = scenes::load_scene(std::string(PT_SHARED_SCENES) + "/" + name);
        const renderer::Camera cam = renderer::make_camera(s, renderer::CameraMode::Auto, 480, 360).camera;
        EXPECT_NEAR(cam.hfov_deg(), 30.67, 0.01);
        EXPECT_NEAR(cam.vfov_deg(), fov_of(tan_half(49.13434) * 360.0 / 800.0), 0.01);
    }
}

// An orthographic file camera (glTF or COLLADA), in either camera mode: parallel rays
// along the view direction from a plane through the camera's position, over the file's
// half extents, the one the format fixes kept and the other following the image.
TEST(OrthographicCamera, RaysAreParallelOverTheFilesExtents) {
    for (const scenes::SceneFormat format : {scenes::SceneFormat::Gltf, scenes::SceneFormat::Collada}) {
        scenes::Scene s;
        s.format = format;
        scenes::Camera c;
        c.name = "ortho";
        c.orthographic = true;
        c.xmag = 3.0f;
        c.ymag = 1.0f;
        c.camera_to_world = accel::Mat4f::translate({1, 2, 10});
        s.camera = c;
        for (const renderer::CameraMode mode : {renderer::CameraMode::Course, renderer::CameraMode::File}) {
            const renderer::CameraSetup setup = renderer::make_camera(s, mode, 200, 100);
            const renderer::Camera& cam = setup.camera;
            ASSERT_TRUE(cam.is_orthographic()) << setup.description;
            // glTF keeps ymag (1, so 2 wide at 2:1), COLLADA xmag (3, so 1.5 high).
            const float hw = format == scenes::SceneFormat::Gltf ? 2.0f : 3.0f, hh = hw / 2.0f;
            EXPECT_FLOAT_EQ(cam.half_width(), hw);
            EXPECT_FLOAT_EQ(cam.half_height(), hh);
            EXPECT_EQ(cam.hfov_deg(), 0.0f);
            const accel::Ray centre = cam.generate_ray(0.5f, 0.5f), corner = cam.generate_ray(0.0f, 0.0f, 0.3f, 0.9f);
            EXPECT_NEAR(accel::length(centre.org - Vec3f(1, 2, 10)), 0.0f, 1e-5f);
            EXPECT_NEAR(accel::length(centre.dir - Vec3f(0, 0, -1)), 0.0f, 1e-6f);
            EXPECT_EQ(corner.dir, centre.dir) << "parallel rays, no lens";
            EXPECT_NEAR(accel::length(corner.org - Vec3f(1 - hw, 2 + hh, 10)), 0.0f, 1e-5f) << "top left";
            EXPECT_NE(setup.description.find("orthographic"), std::string::npos) << setup.description;
            // A pixel's footprint is the same at every distance along the view.
            const renderer::PixelSpread sp = cam.pixel_spread(200, 100, 1);
            Vec3f near_x, near_y, far_x, far_y;
            renderer::camera_dpdxy(sp, centre.dir, Vec3f(1, 2, 5), Vec3f(0, 0, 1), near_x, near_y);
            renderer::approximate_dpdxy(sp, Vec3f(1, 2, -500), Vec3f(0, 0, 1), far_x, far_y);
            EXPECT_NEAR(near_x.x, 2.0f * hw / 200.0f, 1e-6f);
            EXPECT_NEAR(near_y.y, 2.0f * hh / 100.0f, 1e-6f);
            EXPECT_NEAR(accel::length(far_x - near_x), 0.0f, 1e-7f);
            EXPECT_NEAR(accel::length(far_y - near_y), 0.0f, 1e-7f);
        }
        // Asking for a field of view makes it a perspective camera.
        renderer::CameraOverrides ov;
        ov.hfov_deg = 40.0f;
        EXPECT_FALSE(renderer::make_camera(s, renderer::CameraMode::File, 200, 100, ov).camera.is_orthographic());
    }
}
