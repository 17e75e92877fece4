// Embree failures must reach the caller as accel::AccelError naming Embree's error,
// through the same path a real failure takes (device error callback or rtcNewDevice's
// null device), and must leave the process able to build again.
#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "accel/accelerator.h"
#include "accel/embree/embree.h"

using namespace accel;

namespace {

struct Quad {
    // Two triangles, plus the one element of padding Embree's vertex loads need.
    std::vector<Vec3f> positions{{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}, {0, 0, 0}};
    std::vector<uint32_t> indices{0, 1, 2, 0, 2, 3};
    std::vector<float> spheres{0, 0, 3, 0.5f};
    std::vector<GeometryView> views() const {
        return {GeometryView::triangles(positions.data(), 4, indices.data(), 2),
                GeometryView::sphere_list(spheres.data(), 1)};
    }
};

std::string build_error(const std::vector<GeometryView>& views, const AccelOptions& o,
                        const std::string& config) {
    try {
        make_embree(views, o, config);
    } catch (const AccelError& e) {
        return e.what();
    }
    return "";
}

void expect_builds_and_hits(const std::vector<GeometryView>& views, const AccelOptions& o) {
    auto e = make_embree(views, o);
    Hit h;
    TraceStats st;
    ASSERT_TRUE(e->intersect(Ray{{0.2f, 0.3f, -1.0f}, {0.0f, 0.0f, 1.0f}}, h, st));
    EXPECT_EQ(h.geom_id, 0u);
    ASSERT_TRUE(e->intersect(Ray{{0.0f, 0.0f, 5.0f}, {0.0f, 0.0f, -1.0f}}, h, st));
    EXPECT_EQ(h.geom_id, 1u);
    EXPECT_NEAR(h.t, 1.5f, 1e-6f);
}

}  // namespace

// A device config Embree cannot parse: rtcNewDevice returns null, so there is no
// callback yet and only rtcGetDeviceError(nullptr)'s code can be reported.
TEST(EmbreeErrors, DeviceCreationFailureIsAccelError) {
    Quad q;
    const std::string msg = build_error(q.views(), AccelOptions{}, "threads=abc");
    ASSERT_FALSE(msg.empty()) << "expected an AccelError";
    std::printf("message: %s\n", msg.c_str());
    EXPECT_NE(msg.find("Embree error RTC_ERROR_"), std::string::npos) << msg;
    EXPECT_NE(msg.find("rtcNewDevice"), std::string::npos) << msg;
    EXPECT_NE(msg.find("threads=abc"), std::string::npos) << msg;
    expect_builds_and_hits(q.views(), AccelOptions{});
}

// An unknown triangle acceleration structure is only noticed when the scene is
// committed: Embree reports it through the device error callback, which we record and
// turn into an exception after rtcCommitScene.
TEST(EmbreeErrors, CallbackErrorDuringCommitIsAccelError) {
    Quad q;
    const std::string msg = build_error(q.views(), AccelOptions{}, "tri_accel=no_such_accel");
    ASSERT_FALSE(msg.empty()) << "expected an AccelError";
    std::printf("message: %s\n", msg.c_str());
    EXPECT_NE(msg.find("Embree error RTC_ERROR_INVALID_ARGUMENT: "), std::string::npos) << msg;
    EXPECT_NE(msg.find("no_such_accel"), std::string::npos) << "Embree's own text: " << msg;
    EXPECT_NE(msg.find("rtcCommitScene"), std::string::npos) << msg;
    expect_builds_and_hits(q.views(), AccelOptions{});
}

// Counting mode has no Embree triangles, so the same bogus triangle structure is never
// consulted: the error path must not fire spuriously.
TEST(EmbreeErrors, CountingModeIgnoresTriangleAccelConfig) {
    Quad q;
    AccelOptions o;
    o.embree_count = true;
    EXPECT_EQ(build_error(q.views(), o, "tri_accel=no_such_accel"), "");
}
