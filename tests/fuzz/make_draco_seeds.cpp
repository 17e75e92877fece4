// Writes the Draco seeds for the glTF fuzz target: make_draco_seeds OUT_DIR.
// Small meshes, so that mutations reach the decoder's branches quickly.
#include <cstdio>
#include <string>

#include "tests/gltf/draco_writer.h"

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: make_draco_seeds OUT_DIR\n");
        return 2;
    }
    const std::string dir = argv[1];
    const auto small = draco_writer::grid(2, 1), mid = draco_writer::grid(4, 3);
    bool ok = draco_writer::write(dir + "/draco_tri.gltf", draco_writer::draco_gltf(small, false, false)) &&
              draco_writer::write(dir + "/draco_nrm_uv.gltf", draco_writer::draco_gltf(mid, true, true)) &&
              draco_writer::write(dir + "/draco_fast.gltf", draco_writer::draco_gltf(mid, true, false, 10)) &&
              draco_writer::write(dir + "/plain_nrm_uv.gltf", draco_writer::plain_gltf(mid, true, true));
    if (!ok) std::fprintf(stderr, "make_draco_seeds: cannot write to %s\n", dir.c_str());
    return ok ? 0 : 2;
}
