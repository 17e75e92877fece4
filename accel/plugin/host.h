// The host side of accel/plugin/accel_plugin.h: loads a plugin library and puts its
// structure behind the same Accelerator edge as the built-in backends.
#pragma once

#include <memory>
#include <span>
#include <string>

#include "accel/accelerator.h"

namespace accel {

/// `spec` is what follows "plugin:" in a backend name: PATH, or PATH:OPTIONS (the text
/// after the first ':' goes to the plugin's build unchanged). Loads PATH with dlopen,
/// checks its ABI version and builds. Throws AccelError naming the path and the reason
/// (no such file, not a loadable library, no entry point, wrong ABI version, a failed
/// build). AccelOptions do not reach a plugin: its options string is its own.
std::unique_ptr<Accelerator> make_plugin(const std::string& spec, std::span<const GeometryView> geometry);

}  // namespace accel
