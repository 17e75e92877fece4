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
    for (const char* kind : {"sphere", "terrain", "field", "sliver", "forest"}) {
        for (uint64_t n : {1000ull, 20000ull}) {
            const scenegen::Document doc = scenegen::generate(kind, n, 7);
            const std::string path = temp_path(std::string(kind) + ".glb");
            scenegen::write_glb(path, doc);
            scenes::Scene scene = scenes::load_scene(path);
            std::filesystem::remove(path);
            const uint64_t placed_triangles = scene.world_triangles() + scene.instanced_triangles();
            EXPECT_EQ(placed_triangles, doc.instanced_triangles()) << kind << " " << n;
            EXPECT_GE(placed_triangles, n) << kind;
            // "At least N" is cheap to honour closely; the sphere's 12 n^2 steps are the coarsest.
            EXPECT_LE(placed_triangles, n + n / 4 + 12) << kind;
            for (const std::string& note : scene.notes)
                EXPECT_TRUE(note.rfind("instancing: ", 0) == 0 || note.rfind("EXT_mesh_gpu_instancing: ", 0) == 0 ||
                            note == "glTF material features ignored: alphaMode MASK")
                    << kind << ": " << note;
            // Meshes placed more than once are prototypes; flattened, one mesh per primitive
            // and placement, as the loader made before it kept instances.
            scenes::flatten_instances(scene);
            uint64_t placed = 0;
            for (const scenegen::Node& nd : doc.nodes)
                placed += doc.placements(nd) * (1 + doc.meshes[size_t(nd.mesh)].parts.size());
            EXPECT_EQ(scene.meshes.size(), placed) << kind;
            EXPECT_EQ(scene.num_triangles(), doc.instanced_triangles()) << kind << " " << n;
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
    EXPECT_THROW(scenegen::generate("sphere", 60'000'001, 1), std::invalid_argument);
    EXPECT_THROW(scenegen::generate("forest", 100'000'000'001ull, 1), std::invalid_argument);
}

// The forest is the production-scale kind: 10^11 triangles after instancing from at most
// 10^7 placements of a few hundred prototypes, in a file of a few hundred MB instead of
// terabytes. Only the document's sizes are checked here (writing 10^7 placements takes
// seconds); the loader test above reads small forests.
TEST(Scenegen, ForestScalesByInstancesNotBytes) {
    const scenegen::Document doc = scenegen::generate("forest", 100'000'000'000ull, 2);
    EXPECT_GE(doc.instanced_triangles(), 100'000'000'000ull);
    EXPECT_LE(doc.instanced_triangles(), 100'000'000'000ull + 20'000);
    EXPECT_EQ(doc.instances(), 10'000'001u);  // the trees and the ground
    EXPECT_LE(doc.unique_triangles(), 20'000'000u);
    EXPECT_EQ(doc.instance_sets.size(), 256u);
    // Placements are 40 bytes each; the prototypes' triangles are what else there is.
    size_t placements = 0;
    for (const auto& set : doc.instance_sets) placements += set.size();
    EXPECT_EQ(placements, 10'000'000u);
    // Every leaf card has uvs over the leaf texture, whose alpha cuts the leaf out.
    ASSERT_EQ(doc.meshes[1].parts.size(), 1u);  // a tree: its trunk, then its leaves
    const scenegen::MeshData& leaves = doc.meshes[1].parts[0];
    ASSERT_EQ(leaves.material, 2);
    EXPECT_EQ(leaves.uvs.size(), 2 * leaves.positions.size());
    EXPECT_TRUE(doc.materials[2].mask);
    ASSERT_EQ(doc.images.size(), 1u);
    EXPECT_EQ(doc.images[0].compare(0, 8, "\x89PNG\r\n\x1a\n"), 0);
}

// --opaque-cutouts writes the same forest with its leaf cards OPAQUE: the loader sees the
// same triangles and materials, the leaf material still double-sided, and no mask.
TEST(Scenegen, OpaqueCutoutsKeepTheForestButDropTheMask) {
    for (bool opaque : {false, true}) {
        scenegen::Document doc = scenegen::generate("forest", 20000, 5);
        if (opaque) scenegen::opaque_cutouts(doc);
        const std::string path = temp_path(opaque ? "opaque.glb" : "masked.glb");
        scenegen::write_glb(path, doc);
        const scenes::Scene scene = scenes::load_scene(path);
        std::filesystem::remove(path);
        EXPECT_EQ(scene.world_triangles() + scene.instanced_triangles(), doc.instanced_triangles());
        int masked = 0, leaf = 0;
        for (const scenes::Material& m : scene.materials) {
            masked += m.alpha_mode == scenes::AlphaMode::Mask;
            if (m.name == "leaf") {
                ++leaf;
                EXPECT_TRUE(m.double_sided);
                EXPECT_EQ(m.alpha_mode, opaque ? scenes::AlphaMode::Opaque : scenes::AlphaMode::Mask);
            }
        }
        EXPECT_EQ(leaf, 1);
        EXPECT_EQ(masked, opaque ? 0 : 1);
    }
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
    scenes::flatten_instances(scene);  // the shapes are the world-space triangles'
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
