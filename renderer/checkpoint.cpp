#include "renderer/checkpoint.h"

#include <fmt/format.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>

#include <unistd.h>

#include "renderer/whole_file.h"

namespace renderer {

namespace {

constexpr char kMagic[8] = {'P', 'T', 'C', 'K', 'P', 'T', '1', '\n'};

struct Header {
    char magic[8];
    uint32_t pixel_bytes;  ///< sizeof(PixelSums): a layout change is refused, not misread
    int32_t width, height;
    uint32_t fingerprint_bytes;
};

/// A kill -9 during a write leaves PATH.tmpPID behind (no handler runs); the next
/// successful write removes those of processes that no longer exist, so crash debris
/// does not pile up beside a long render that is killed and resumed again and again.
void remove_stale_temporaries(const std::string& path) {
    namespace fs = std::filesystem;
    const fs::path target(path);
    const std::string prefix = target.filename().string() + ".tmp";
    std::error_code ec;
    const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
    for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
        const std::string name = e.path().filename().string();
        if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
        const std::string digits = name.substr(prefix.size());
        if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) continue;
        const pid_t pid = pid_t(std::stol(digits));
        if (pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH) fs::remove(e.path(), ec);
    }
}

}  // namespace

void write_checkpoint(const std::string& path, const Accumulation& acc, const std::string& fingerprint) {
    Header h{};
    std::memcpy(h.magic, kMagic, sizeof kMagic);
    h.pixel_bytes = sizeof(PixelSums);
    h.width = acc.width;
    h.height = acc.height;
    h.fingerprint_bytes = uint32_t(fingerprint.size());
    const std::string error =
        write_file_whole(path, "checkpoint",
                         {std::as_bytes(std::span(&h, 1)), std::as_bytes(std::span(fingerprint)),
                          std::as_bytes(std::span(acc.pixels))});
    if (!error.empty()) throw CheckpointError(error);
    remove_stale_temporaries(path);
}

Accumulation read_checkpoint(const std::string& path, const std::string& fingerprint) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw CheckpointError(fmt::format("{}: cannot open checkpoint", path));
    Header h{};
    if (!in.read(reinterpret_cast<char*>(&h), sizeof h) || std::memcmp(h.magic, kMagic, sizeof kMagic) != 0)
        throw CheckpointError(fmt::format("{}: not a pathtracer checkpoint (bad magic)", path));
    if (h.pixel_bytes != sizeof(PixelSums))
        throw CheckpointError(fmt::format("{}: pixel record of {} bytes, this build uses {}", path,
                                          h.pixel_bytes, sizeof(PixelSums)));
    if (h.width < 1 || h.height < 1 || h.width > 65536 || h.height > 65536 || h.fingerprint_bytes > (1u << 24))
        throw CheckpointError(fmt::format("{}: corrupt header (size {}x{})", path, h.width, h.height));
    std::string fp(h.fingerprint_bytes, '\0');
    if (!in.read(fp.data(), std::streamsize(fp.size())))
        throw CheckpointError(fmt::format("{}: truncated header", path));
    if (fp != fingerprint)
        throw CheckpointError(fmt::format(
            "{}: written for another scene or other settings; resume needs the same scene and "
            "options (only -s, -t, -f, -q, --time-limit and the checkpoint options may change).\n"
            "  checkpoint: {}\n  this run:   {}", path, fp, fingerprint));
    Accumulation acc;
    acc.width = h.width;
    acc.height = h.height;
    acc.pixels.resize(size_t(h.width) * size_t(h.height));
    if (!in.read(reinterpret_cast<char*>(acc.pixels.data()),
                 std::streamsize(acc.pixels.size() * sizeof(PixelSums))) ||
        in.peek() != std::char_traits<char>::eof())
        throw CheckpointError(fmt::format("{}: truncated or overlong pixel data", path));
    return acc;
}

}  // namespace renderer
