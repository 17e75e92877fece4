// Command-line plumbing shared by the tools and benchmarks: the one place that decides
// how bad input ends a program (one line on stderr, exit status 2).
#pragma once

#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <string>

#include "scenes/load.h"

namespace tools {

/// Bad input or options: "PROG: error: MESSAGE" on stderr, exit status 2.
[[noreturn]] inline void fail(const char* prog, const std::string& message) {
    std::fprintf(stderr, "%s: error: %s\n", prog, message.c_str());
    std::exit(2);
}

/// Parses the command line; --help prints and exits 0, a bad option fails with status 2.
inline void parse_or_exit(CLI::App& app, int argc, char** argv, const char* prog) {
    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp& e) {
        std::exit(app.exit(e));
    } catch (const CLI::ParseError& e) {
        fail(prog, e.what());
    }
}

/// Loads a scene, or fails with status 2 and the loader's message (file and element).
inline scenes::Scene load_scene_or_exit(const std::string& path, const char* prog) {
    try {
        return scenes::load_scene(path);
    } catch (const scenes::SceneError& e) {
        fail(prog, e.what());
    }
}

}  // namespace tools
