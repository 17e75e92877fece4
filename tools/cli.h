// Command-line plumbing shared by the tools and benchmarks: the one place that decides
// how bad input ends a program (one line on stderr, exit status 2).
#pragma once

#include <CLI/CLI.hpp>

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <unordered_map>
#include <vector>

#include "scenes/load.h"
#include "tools/memory/memory.h"

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

/// Loads a scene, or fails with status 2 and the loader's message (file and element);
/// out of memory while loading ends with status 3, also when the loader turned the
/// failed allocation into its own error.
inline scenes::Scene load_scene_or_exit(const std::string& path, const char* prog) {
    const memory::Stage stage("loading the scene");
    const uint64_t failures = memory::failures();
    try {
        return scenes::load_scene(path);
    } catch (const scenes::SceneError& e) {
        if (memory::failures() != failures) memory::out_of_memory();
        fail(prog, e.what());
    } catch (const std::bad_alloc& e) {
        memory::out_of_memory(e);
    }
}

/// Empty when a file can be created at `path`: its folder exists and takes a new file,
/// and `path` is not a folder; else why not, naming the flag and the path. The proof is
/// a probe file created in the folder and removed at once (access(2) would miss
/// read-only mounts, a full disk and ACLs that deny creation).
inline std::string check_writable(const std::string& flag, const std::string& path) {
    namespace fs = std::filesystem;
    const fs::path target(path);
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    std::error_code ec;
    if (!fs::exists(dir, ec)) return flag + " " + path + ": the folder " + dir.string() + " does not exist";
    if (!fs::is_directory(dir, ec)) return flag + " " + path + ": " + dir.string() + " is not a folder";
    if (fs::is_directory(target, ec)) return flag + " " + path + ": is a folder, not a file";
    const fs::path probe = dir / ("." + target.filename().string() + ".probe" + std::to_string(::getpid()));
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL, 0644);
    if (fd < 0) return flag + " " + path + ": cannot create a file in " + dir.string() + ": " + std::strerror(errno);
    const bool wrote = ::write(fd, "p", 1) == 1;
    const int write_errno = errno;
    ::close(fd);
    ::unlink(probe.c_str());
    if (!wrote) return flag + " " + path + ": cannot write in " + dir.string() + ": " + std::strerror(write_errno);
    return {};
}

/// Prints each distinct line once, in the order first seen, with a count when it was
/// repeated: a file that trips the same loader note 70 times gets one line, "(70 times)".
inline void print_once(const char* prefix, const std::vector<std::string>& lines) {
    std::unordered_map<std::string, size_t> count;
    std::vector<const std::string*> order;
    for (const std::string& l : lines)
        if (count[l]++ == 0) order.push_back(&l);
    for (const std::string* l : order) {
        const size_t n = count[*l];
        if (n > 1)
            std::fprintf(stderr, "%s%s (%zu times)\n", prefix, l->c_str(), n);
        else
            std::fprintf(stderr, "%s%s\n", prefix, l->c_str());
    }
}

}  // namespace tools
