// Skinned and morphed meshes (<instance_controller>) load as their geometry stands before
// the controller acts, as the glTF loader loads skins and morph targets: a skin in its
// bind pose (the source geometry times the bind_shape_matrix, in world space), a morph
// as its base geometry under the node's transform, each named in a note. Before, a
// controller was skipped, and a file of skinned characters loaded as an empty scene.
#include <gtest/gtest.h>

#include <string>

#include "scenes/collada/collada.h"

namespace {

using scenes::Scene;
using scenes::Vec3f;

/// A unit quad at z = 0 placed through `controllers` by one node translated by (100, 0, 0).
std::string document(const std::string& controllers, const std::string& url = "#skin") {
    return "<?xml version=\"1.0\"?><COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">"
           "<library_geometries><geometry id=\"quad\" name=\"Quad\"><mesh>"
           "<source id=\"pos\"><float_array id=\"pos-a\" count=\"12\">0 0 0 1 0 0 1 1 0 0 1 0</float_array>"
           "<technique_common><accessor source=\"#pos-a\" count=\"4\" stride=\"3\"/></technique_common></source>"
           "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#pos\"/></vertices>"
           "<triangles count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>0 1 2 0 2 3</p></triangles>"
           "</mesh></geometry></library_geometries>"
           "<library_controllers>" + controllers + "</library_controllers>"
           "<library_visual_scenes><visual_scene id=\"s\"><node id=\"rig\"><translate>100 0 0</translate>"
           "<instance_controller url=\"" + url + "\"/></node></visual_scene></library_visual_scenes>"
           "<scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>";
}

Scene load(const std::string& doc) { return scenes::load_collada_memory(doc.data(), doc.size(), "rig.dae"); }

bool noted(const Scene& s, const std::string& what) {
    for (const std::string& n : s.notes)
        if (n.find(what) != std::string::npos) return true;
    return false;
}

const std::string kSkin =
    "<controller id=\"skin\"><skin source=\"#quad\"><bind_shape_matrix>1 0 0 5 0 2 0 0 0 0 1 0 0 0 0 1"
    "</bind_shape_matrix></skin></controller>";
const std::string kMorph = "<controller id=\"morph\"><morph source=\"#quad\"/></controller>";

TEST(ColladaControllers, SkinLoadsInItsBindPose) {
    const Scene s = load(document(kSkin));
    ASSERT_EQ(s.meshes.size(), 1u);
    // The bind shape matrix (row-major: x + 5, y x 2), not the node's translation.
    EXPECT_EQ(s.meshes[0].positions[0], Vec3f(5, 0, 0));
    EXPECT_EQ(s.meshes[0].positions[2], Vec3f(6, 2, 0));
    EXPECT_TRUE(noted(s, "skinned geometry 'Quad' placed in its bind pose")) << testing::PrintToString(s.notes);
}

TEST(ColladaControllers, MorphLoadsItsBaseShapeUnderTheNode) {
    const Scene s = load(document(kMorph, "#morph"));
    ASSERT_EQ(s.meshes.size(), 1u);
    EXPECT_EQ(s.meshes[0].positions[2], Vec3f(101, 1, 0));
    EXPECT_TRUE(noted(s, "morphed geometry 'Quad' placed in its base shape"));
    // A skin over a morph: the base shape in the skin's bind pose.
    const std::string skin_over_morph =
        kMorph + "<controller id=\"skin\"><skin source=\"#morph\"><bind_shape_matrix>1 0 0 5 0 1 0 0 0 0 1 0 0 0 0 1"
                 "</bind_shape_matrix></skin></controller>";
    EXPECT_EQ(load(document(skin_over_morph)).meshes[0].positions[2], Vec3f(6, 1, 0));
}

TEST(ColladaControllers, BadControllersFailNamingTheElement) {
    const auto fails = [](const std::string& doc, const std::string& what) {
        try {
            load(doc);
            ADD_FAILURE() << "accepted; expected " << what;
        } catch (const scenes::SceneError& e) {
            EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
        }
    };
    fails(document("<controller id=\"skin\"><skin source=\"#skin\"/></controller>"), "nested more than 4 deep");
    fails(document("<controller id=\"skin\"/>"), "has neither <skin> nor <morph>");
    fails(document("<controller id=\"skin\"><skin source=\"#v\"/></controller>"),
          "refers to a <vertices>, expected a <geometry> or <controller>");
    fails(document("<controller id=\"skin\"><skin source=\"#quad\"><bind_shape_matrix>1 2 3</bind_shape_matrix>"
                   "</skin></controller>"),
          "needs 16 numbers");
}

}  // namespace
