// The course framing's fields of view (../shared/scenes/README.md, "How the course
// application treats these files"): an 800x600 window that widens whichever of the file's
// fovs is too narrow for 800:600, of which a W x H render is the central W x H pixels.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "renderer/camera.h"
#include "scenes/load.h"

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
