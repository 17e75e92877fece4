// Checkpoints of a render: the accumulated per-pixel sums and sample counts, written
// atomically (a temporary file beside the target, then rename(2)), so a crash or a kill
// during the write leaves the previous checkpoint intact. A fingerprint of the scene and
// the settings that shape the samples is stored in the header; resuming with anything
// else is refused, since the result would silently differ from an uninterrupted render.
#pragma once

#include <stdexcept>
#include <string>

#include "renderer/render.h"

namespace renderer {

struct CheckpointError : std::runtime_error {
    using std::runtime_error::runtime_error;
};

/// Writes `acc` to `path` atomically; throws CheckpointError naming the file on failure.
void write_checkpoint(const std::string& path, const Accumulation& acc, const std::string& fingerprint);

/// Reads a checkpoint; throws CheckpointError naming the file and the field that is wrong
/// (not a checkpoint, truncated, or written for another scene/settings).
Accumulation read_checkpoint(const std::string& path, const std::string& fingerprint);

}  // namespace renderer
