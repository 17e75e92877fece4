// Replays every input the fuzzer once crashed on (tests/fuzz/regressions/collada/):
// each must now load or throw SceneError naming the file, nothing else.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "scenes/collada/collada.h"

namespace {

TEST(ColladaRegressions, EveryFuzzFindingLoadsOrThrowsSceneError) {
    const std::filesystem::path dir =
        std::filesystem::path(PT_SOURCE_DIR) / "tests/fuzz/regressions/collada";
    ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;
    size_t replayed = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir)) {
        if (!entry.is_regular_file() || entry.path().filename() == "README") continue;
        SCOPED_TRACE(entry.path().string());
        std::ifstream in(entry.path(), std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        const std::string name = entry.path().filename().string();
        try {
            scenes::load_collada_memory(bytes.data(), bytes.size(), name);
        } catch (const scenes::SceneError& e) {
            EXPECT_EQ(std::string(e.what()).rfind(name, 0), 0u) << e.what();
        }
        ++replayed;
    }
    // The folder always holds at least its seed; an empty replay would test nothing.
    EXPECT_GE(replayed, 1u);
}

}  // namespace
