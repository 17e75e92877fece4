// Binary files written whole or not at all: a temporary file beside the target
// (PATH.tmpPID), flushed to the disk, then renamed over it (rename(2) is atomic within a
// folder), so a crash, a kill or a full disk leaves the previous file or none, never half
// of one. The checkpoint and the ray record write through it.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <span>
#include <string>

namespace renderer {

/// Writes `parts` one after another to `path` as above. Returns "" on success, else
/// "FILE: cannot write WHAT: REASON" (FILE the temporary when it could not be created,
/// else `path`); a failed write leaves no temporary behind.
std::string write_file_whole(const std::string& path, const char* what,
                             std::initializer_list<std::span<const std::byte>> parts);

}  // namespace renderer
