// "custom:sah:watertight", "embree:high:robust", "embree:count", "naive": one string
// names a backend and its options, for tools that compare several side by side.
#pragma once

#include <string>
#include <vector>

#include "accel/accelerator.h"

namespace renderer {

struct BackendSpec {
    std::string label;    ///< the string as normalised, e.g. "custom:sah:fast"
    std::string backend;  ///< naive | custom | embree | plugin:PATH[:OPTIONS] (the whole spec)
    accel::AccelOptions options;
};

/// Parses one spec; throws std::invalid_argument naming the bad word. Words after the
/// backend name, in any order: fast|watertight, sah|midpoint|sbvh, leafN,
/// auto|sse2|avx2|avx512 (custom's kernel), float|quantized (custom's node layout),
/// low|medium|high, robust, count. "plugin:PATH[:OPTIONS]" is taken whole: its words
/// are the plugin's.
BackendSpec parse_backend_spec(const std::string& spec);

/// A tool's --isa: the kernel of every custom spec that did not name one (label gets
/// ":ISA"). Auto changes nothing.
void apply_isa(std::vector<BackendSpec>& specs, accel::Isa isa);

/// A tool's --nodes: the node layout of every custom spec that did not name one (label
/// gets ":LAYOUT"). Auto changes nothing.
void apply_layout(std::vector<BackendSpec>& specs, accel::NodeLayout layout);

/// The kernel a spec runs, given what its build reported: custom's resolved ISA and
/// node layout ("avx2/float", "sse2/quantized") or the backend's name.
std::string kernel_name(const BackendSpec& spec, const accel::BuildInfo& built);

/// Comma-separated list of specs.
std::vector<BackendSpec> parse_backend_specs(const std::string& list);

/// A tool's backend list with its --isa and --nodes words (auto|sse2|avx2|avx512,
/// auto|float|quantized) applied to every custom spec that names none: parse_backend_specs,
/// apply_isa, apply_layout. Throws std::invalid_argument naming a bad word.
std::vector<BackendSpec> parse_backend_specs(const std::string& list, const std::string& isa,
                                             const std::string& nodes);

}  // namespace renderer
