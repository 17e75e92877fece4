// The course's extras (spheres, BSDFs, emission, lights) are read under <technique
// profile="CGL"> and under "CMU462", the profile of the course's CMU 15-462 predecessor.
// A CMU462 file loads exactly like its CGL twin; CGL wins where an element has both.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "scenes/collada/collada.h"

namespace {

using scenes::LightType;
using scenes::Scene;
using scenes::Vec3f;

const std::string kFile = std::string(PT_SOURCE_DIR) + "/tests/collada/data/cmu462_spheres.dae";

std::string read_text(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
    for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
        s.replace(at, from.size(), to);
    return s;
}

Scene load(const std::string& doc) { return scenes::load_collada_memory(doc.data(), doc.size(), "test.dae"); }

void expect_same(const Scene& a, const Scene& b) {
    ASSERT_EQ(a.spheres.size(), b.spheres.size());
    for (size_t i = 0; i < a.spheres.size(); ++i) {
        EXPECT_EQ(a.spheres[i].center, b.spheres[i].center);
        EXPECT_EQ(a.spheres[i].radius, b.spheres[i].radius);
        EXPECT_EQ(a.spheres[i].material, b.spheres[i].material);
    }
    ASSERT_EQ(a.meshes.size(), b.meshes.size());
    for (size_t i = 0; i < a.meshes.size(); ++i) EXPECT_EQ(a.meshes[i].material, b.meshes[i].material);
    ASSERT_EQ(a.materials.size(), b.materials.size());
    for (size_t i = 0; i < a.materials.size(); ++i) {
        SCOPED_TRACE(a.materials[i].name);
        EXPECT_EQ(a.materials[i].name, b.materials[i].name);
        EXPECT_EQ(a.materials[i].albedo, b.materials[i].albedo);
        EXPECT_EQ(a.materials[i].emission, b.materials[i].emission);
        EXPECT_EQ(a.materials[i].replaced, b.materials[i].replaced);
    }
    ASSERT_EQ(a.lights.size(), b.lights.size());
    for (size_t i = 0; i < a.lights.size(); ++i) {
        EXPECT_EQ(a.lights[i].type, b.lights[i].type);
        EXPECT_EQ(a.lights[i].radiance, b.lights[i].radiance);
        EXPECT_EQ(a.lights[i].position, b.lights[i].position);
        EXPECT_EQ(a.lights[i].direction, b.lights[i].direction);
        EXPECT_EQ(a.lights[i].edge_u, b.lights[i].edge_u);
        EXPECT_EQ(a.lights[i].edge_v, b.lights[i].edge_v);
    }
}

const scenes::Material* material_named(const Scene& s, const std::string& name) {
    for (const auto& m : s.materials)
        if (m.name == name) return &m;
    return nullptr;
}

}  // namespace

// The CMU462 file on its own: spheres, an area light, emission and BSDFs are all read.
TEST(ColladaProfiles, Cmu462SpheresLightEmissionAndBsdfs) {
    const std::string doc = read_text(kFile);
    ASSERT_NE(doc.find("profile=\"CMU462\""), std::string::npos) << kFile;
    ASSERT_EQ(doc.find("profile=\"CGL\""), std::string::npos) << kFile;
    const Scene s = scenes::load_collada(kFile);
    ASSERT_EQ(s.spheres.size(), 2u) << "CMU462 spheres are geometry, not an empty scene";
    EXPECT_FLOAT_EQ(s.spheres[0].radius, 0.3f);
    EXPECT_FLOAT_EQ(s.spheres[1].radius, 0.25f);
    ASSERT_EQ(s.lights.size(), 1u);
    EXPECT_EQ(s.lights[0].type, LightType::Area) << "CMU462 <area> wins over technique_common <point>";
    EXPECT_EQ(s.lights[0].radiance, Vec3f(6, 5, 4));
    const scenes::Material* light = material_named(s, "light");
    ASSERT_NE(light, nullptr);
    EXPECT_EQ(light->emission, Vec3f(10, 9, 8));
    const scenes::Material* floor = material_named(s, "floor");
    ASSERT_NE(floor, nullptr);
    EXPECT_EQ(floor->albedo, Vec3f(0.2f, 0.4f, 0.6f)) << "CMU462 <diffuse> albedo, not profile_COMMON's";
    const scenes::Material* mirror = material_named(s, "mirror");
    ASSERT_NE(mirror, nullptr);
    EXPECT_EQ(s.materials[s.spheres[0].material].name, "mirror");
    // The mirror was read from the CMU462 technique as a mirror, not rendered as diffuse;
    // with the extra ignored it is the plain profile_COMMON lambert.
    EXPECT_EQ(mirror->bsdf, scenes::BsdfKind::Mirror);
    EXPECT_TRUE(mirror->replaced.empty());
    const Scene ignored = load(replace_all(doc, "profile=\"CMU462\"", "profile=\"other\""));
    const scenes::Material* plain = material_named(ignored, "mirror");
    ASSERT_NE(plain, nullptr);
    EXPECT_EQ(plain->bsdf, scenes::BsdfKind::Diffuse);
}

// The issue's case: a scene of CMU462 spheres alone was refused as "empty scene".
TEST(ColladaProfiles, SpheresOnlyCmu462SceneIsNotEmpty) {
    const std::string doc = R"(<?xml version="1.0"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1"><asset/>
<library_geometries><geometry id="ball"><extra><technique profile="CMU462"><sphere>
  <radius>2</radius></sphere></technique></extra></geometry></library_geometries>
<library_visual_scenes><visual_scene id="S"><node id="n"><translate>1 0 0</translate>
  <instance_geometry url="#ball"/></node></visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#S"/></scene></COLLADA>)";
    const Scene s = load(doc);
    ASSERT_EQ(s.spheres.size(), 1u);
    EXPECT_EQ(s.spheres[0].center, Vec3f(1, 0, 0));
    EXPECT_FLOAT_EQ(s.spheres[0].radius, 2.0f);
}

// The same file with the profile renamed to CGL loads to the same scene.
TEST(ColladaProfiles, Cmu462LoadsLikeItsCglTwin) {
    const std::string doc = read_text(kFile);
    const Scene cmu = load(doc);
    const Scene cgl = load(replace_all(doc, "profile=\"CMU462\"", "profile=\"CGL\""));
    expect_same(cmu, cgl);
    // Under an unknown profile the extras are ignored: the twins really exercise them.
    const Scene other = load(replace_all(doc, "profile=\"CMU462\"", "profile=\"other\""));
    EXPECT_TRUE(other.spheres.empty());
    ASSERT_EQ(other.lights.size(), 1u);
    EXPECT_EQ(other.lights[0].type, LightType::Point);
}

// An element with both profiles uses CGL's values, whichever comes first.
TEST(ColladaProfiles, CglWinsOverCmu462OnTheSameElement) {
    const std::string doc = read_text(kFile);
    const std::string cmu_area = "<extra><technique profile=\"CMU462\"><area><color>6 5 4</color></area></technique></extra>";
    ASSERT_NE(doc.find(cmu_area), std::string::npos);
    const std::string cgl_area = "<extra><technique profile=\"CGL\"><area><color>1 2 3</color></area></technique></extra>";
    for (const std::string& both : {cmu_area + cgl_area, cgl_area + cmu_area}) {
        const Scene s = load(replace_all(doc, cmu_area, both));
        ASSERT_EQ(s.lights.size(), 1u);
        EXPECT_EQ(s.lights[0].radiance, Vec3f(1, 2, 3));
    }
    // One extra holding both techniques, CMU462 first, and a sphere radius in both.
    const std::string cmu_sphere = "<extra><technique profile=\"CMU462\"><sphere><radius>0.3</radius></sphere></technique></extra>";
    ASSERT_NE(doc.find(cmu_sphere), std::string::npos);
    const Scene s = load(replace_all(doc, cmu_sphere,
                                     "<extra><technique profile=\"CMU462\"><sphere><radius>0.3</radius></sphere>"
                                     "</technique><technique profile=\"CGL\"><sphere><radius>0.7</radius>"
                                     "</sphere></technique></extra>"));
    ASSERT_EQ(s.spheres.size(), 2u);
    EXPECT_FLOAT_EQ(s.spheres[0].radius, 0.7f);
}
