// scenegen's GLB writer and shapes, checked through the project's own loader: every kind
// loads with exactly the triangle count the generator reports, and at least the count
// asked for. The generator is compiled in-process (SCENEGEN_NO_MAIN) so the test does
// not depend on the tool's binary being built first.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <unistd.h>
#include <string>

#define SCENEGEN_NO_MAIN
#include "tools/scenegen.cpp"
#include "scenes/load.h"

namespace {

std::string temp_path(const std::string& name) {
    return (std::filesystem::temp_directory_path() / ("scenegen_test_" + std::to_string(::getpid()) + "_" + name))
        .string();
}

}  // namespace

TEST(Scenegen, EveryKindLoadsWithTheReportedTriangleCount) {
    for (const char* kind : {"sphere", "terrain", "field", "sliver"}) {
        for (uint64_t n : {1000ull, 20000ull}) {
            const scenegen::Document doc = scenegen::generate(kind, n, 7);
            const std::string path = temp_path(std::string(kind) + ".glb");
            scenegen::write_glb(path, doc);
            scenes::Scene scene = scenes::load_scene(path);
            std::filesystem::remove(path);
            EXPECT_EQ(scene.num_triangles(), doc.instanced_triangles()) << kind << " " << n;
            EXPECT_GE(scene.num_triangles(), n) << kind;
            // "At least N" is cheap to honour closely; the sphere's 12 n^2 steps are the coarsest.
            EXPECT_LE(scene.num_triangles(), n + n / 4 + 12) << kind;
            EXPECT_EQ(scene.meshes.size(), doc.nodes.size()) << kind;
            EXPECT_TRUE(scene.notes.empty()) << kind << ": " << (scene.notes.empty() ? "" : scene.notes[0]);
        }
    }
}

TEST(Scenegen, PositionsRoundTripBitForBitAndBoundsMatch) {
    scenegen::Document doc = scenegen::generate("sphere", 1000, 3);
    const std::string path = temp_path("rt.glb");
    scenegen::write_glb(path, doc);
    scenes::Scene scene = scenes::load_scene(path);
    std::filesystem::remove(path);
    ASSERT_EQ(scene.meshes.size(), 1u);
    const auto& m = scene.meshes[0];
    ASSERT_EQ(m.num_vertices(), doc.meshes[0].positions.size());
    for (size_t i = 0; i < doc.meshes[0].positions.size(); ++i) {
        EXPECT_EQ(m.positions[i].x, doc.meshes[0].positions[i].x);
        EXPECT_EQ(m.positions[i].y, doc.meshes[0].positions[i].y);
        EXPECT_EQ(m.positions[i].z, doc.meshes[0].positions[i].z);
    }
    EXPECT_EQ(m.indices, doc.meshes[0].indices);
}

TEST(Scenegen, GlbLayoutIsAlignedAndSized) {
    const std::string bytes = scenegen::to_glb(scenegen::generate("terrain", 500, 1));
    ASSERT_GE(bytes.size(), 28u);
    uint32_t h[5];
    std::memcpy(h, bytes.data(), sizeof h);
    EXPECT_EQ(h[0], 0x46546C67u);
    EXPECT_EQ(h[1], 2u);
    EXPECT_EQ(h[2], bytes.size());
    EXPECT_EQ(h[3] % 4, 0u);  // JSON chunk padded to 4 bytes
    EXPECT_EQ(h[4], 0x4E4F534Au);
    uint32_t bin[2];
    std::memcpy(bin, bytes.data() + 20 + h[3], sizeof bin);
    EXPECT_EQ(bin[1], 0x004E4942u);
    EXPECT_EQ(20u + h[3] + 8u + bin[0], bytes.size());
    EXPECT_NE(bytes.find("\"min\":["), std::string::npos);
}

TEST(Scenegen, RejectsUnknownKindAndTinyCounts) {
    EXPECT_THROW(scenegen::generate("teapot", 1000, 1), std::invalid_argument);
    EXPECT_THROW(scenegen::generate("sphere", 3, 1), std::invalid_argument);
}

namespace {

/// Smallest and largest triangle area and the largest edge-length ratio (longest edge over
/// the height on it) over the loaded scene: the properties each kind exists to provide.
struct Shape {
    double min_area = 1e300, max_area = 0, max_aspect = 0;
};

Shape shape_of(const scenes::Scene& scene) {
    Shape s;
    for (const auto& m : scene.meshes)
        for (uint32_t t = 0; t < m.num_triangles(); ++t) {
            const accel::Vec3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
                               c = m.positions[m.indices[3 * t + 2]];
            const double area = 0.5 * double(accel::length(accel::cross(b - a, c - a)));
            const double longest =
                std::max({double(accel::length(b - a)), double(accel::length(c - b)), double(accel::length(a - c))});
            s.min_area = std::min(s.min_area, area);
            s.max_area = std::max(s.max_area, area);
            if (area > 0) s.max_aspect = std::max(s.max_aspect, longest * longest / (2.0 * area));
        }
    return s;
}

scenes::Scene load_generated(const std::string& kind, uint64_t n) {
    const std::string path = temp_path(kind + "_shape.glb");
    scenegen::write_glb(path, scenegen::generate(kind, n, 5));
    scenes::Scene scene = scenes::load_scene(path);
    std::filesystem::remove(path);
    return scene;
}

}  // namespace

// The field exists to have very uneven triangle sizes, the sliver mesh needle-thin
// triangles, the sphere even ones: check each kind delivers what it is benchmarked for.
TEST(Scenegen, KindsHaveTheTriangleShapesTheyArePromised) {
    const Shape field = shape_of(load_generated("field", 20000));
    EXPECT_GT(field.max_area / field.min_area, 1e6);  // 100 m ground vs centimetre rock facets
    const Shape sliver = shape_of(load_generated("sliver", 20000));
    EXPECT_GT(sliver.max_aspect, 300.0);  // ~1000:1 needles
    const Shape sphere = shape_of(load_generated("sphere", 20000));
    EXPECT_LT(sphere.max_area / sphere.min_area, 20.0);  // cube-map cells vary ~3x, displacement a bit more
    EXPECT_LT(sphere.max_aspect, 20.0);
}
