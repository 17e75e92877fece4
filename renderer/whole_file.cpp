#include "renderer/whole_file.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <fmt/format.h>

namespace renderer {

std::string write_file_whole(const std::string& path, const char* what,
                             std::initializer_list<std::span<const std::byte>> parts) {
    const std::string tmp = fmt::format("{}.tmp{}", path, ::getpid());
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) return fmt::format("{}: cannot write {}: {}", tmp, what, std::strerror(errno));
    bool ok = true;
    for (const std::span<const std::byte> p : parts) ok = ok && std::fwrite(p.data(), 1, p.size(), f) == p.size();
    ok = std::fflush(f) == 0 && ::fsync(::fileno(f)) == 0 && ok;
    ok = std::fclose(f) == 0 && ok;
    if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
        const std::string why = std::strerror(errno);
        std::remove(tmp.c_str());
        return fmt::format("{}: cannot write {}: {}", path, what, why);
    }
    return {};
}

}  // namespace renderer
