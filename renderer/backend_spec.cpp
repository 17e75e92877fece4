#include "renderer/backend_spec.h"

#include "accel/bvh/bvh.h"

#include <sstream>
#include <stdexcept>

namespace renderer {

BackendSpec parse_backend_spec(const std::string& spec) {
    std::vector<std::string> words;
    std::stringstream ss(spec);
    for (std::string w; std::getline(ss, w, ':');)
        if (!w.empty()) words.push_back(w);
    if (words.empty()) throw std::invalid_argument("empty backend spec");
    BackendSpec b;
    // A plugin takes the rest of the spec, path and options, as its own (accel/plugin).
    if (words[0] == "plugin") {
        if (words.size() < 2) throw std::invalid_argument("backend spec '" + spec + "': plugin:PATH[:OPTIONS] names no path");
        // Labelled by the file's name (and options), so tables stay readable.
        b.backend = spec;
        const std::string rest = spec.substr(spec.find(':') + 1);
        const size_t colon = rest.find(':');
        const std::string path = rest.substr(0, colon);
        b.label = "plugin:" + path.substr(path.find_last_of('/') + 1) +
                  (colon == std::string::npos ? "" : rest.substr(colon));
        return b;
    }
    b.backend = words[0];
    if (b.backend != "naive" && b.backend != "custom" && b.backend != "embree")
        throw std::invalid_argument("backend spec '" + spec + "': unknown backend '" + b.backend +
                                    "' (naive, custom, embree, plugin:PATH[:OPTIONS])");
    std::string tri = "fast", split = "sah", quality = "high";
    bool robust = false, count = false;
    accel::Isa isa = accel::Isa::Auto;
    accel::NodeLayout layout = accel::NodeLayout::Auto;
    unsigned leaf = 0;
    for (size_t i = 1; i < words.size(); ++i) {
        const std::string& w = words[i];
        if (w == "fast" || w == "watertight") tri = w;
        else if (b.backend == "custom" && (w == "sah" || w == "midpoint" || w == "sbvh")) split = w;
        else if (b.backend == "custom" && w.rfind("leaf", 0) == 0 && w.size() > 4) {
            leaf = unsigned(std::stoul(w.substr(4)));
            if (leaf < 1 || leaf > 255) throw std::invalid_argument("backend spec '" + spec + "': leaf size 1..255");
        } else if (b.backend == "custom" && w != "auto" && accel::parse_isa(w, isa)) {
        } else if (b.backend == "custom" && w != "auto" && accel::parse_layout(w, layout)) {
        } else if (b.backend == "embree" && (w == "low" || w == "medium" || w == "high")) quality = w;
        else if (b.backend == "embree" && w == "robust") robust = true;
        else if (b.backend == "embree" && w == "count") count = true;
        else
            throw std::invalid_argument("backend spec '" + spec + "': unknown word '" + w + "'");
    }
    b.options.triangle = tri == "watertight" ? accel::TriangleTest::Watertight : accel::TriangleTest::Fast;
    b.options.split = split == "midpoint" ? accel::BvhSplit::Midpoint
                      : split == "sbvh"   ? accel::BvhSplit::Sbvh
                                          : accel::BvhSplit::Sah;
    if (leaf) b.options.leaf_size = leaf;
    b.options.embree_quality = quality == "low"      ? accel::EmbreeQuality::Low
                               : quality == "medium" ? accel::EmbreeQuality::Medium
                                                     : accel::EmbreeQuality::High;
    b.options.embree_robust = robust;
    b.options.isa = isa;
    b.options.nodes = layout;
    b.options.embree_count = count;
    // Normalised label: embree's triangle test only matters in counting mode.
    b.label = b.backend;
    if (b.backend == "custom") b.label += ":" + split + (leaf ? ":leaf" + std::to_string(leaf) : "");
    if (isa != accel::Isa::Auto) b.label += std::string(":") + accel::isa_name(isa);
    if (layout != accel::NodeLayout::Auto) b.label += std::string(":") + accel::layout_name(layout);
    if (b.backend == "embree") b.label += ":" + quality + (robust ? ":robust" : "") + (count ? ":count" : "");
    if (b.backend != "embree" || count) b.label += ":" + tri;
    return b;
}

namespace {
/// Sets a custom option that a spec left at Auto (value 0 of both enums), marking the label.
template <class T>
void apply_custom(std::vector<BackendSpec>& specs, T accel::AccelOptions::*field, T value, const char* name) {
    if (value == T{}) return;
    for (BackendSpec& s : specs)
        if (s.backend == "custom" && s.options.*field == T{}) {
            s.options.*field = value;
            s.label += std::string(":") + name;
        }
}
}  // namespace

void apply_isa(std::vector<BackendSpec>& specs, accel::Isa isa) {
    apply_custom(specs, &accel::AccelOptions::isa, isa, accel::isa_name(isa));
}

void apply_layout(std::vector<BackendSpec>& specs, accel::NodeLayout layout) {
    apply_custom(specs, &accel::AccelOptions::nodes, layout, accel::layout_name(layout));
}

std::string kernel_name(const BackendSpec& spec, const accel::BuildInfo& built) {
    if (spec.backend.rfind("plugin:", 0) == 0) {  // the plugin's name: "plugin NAME VERSION (...)"
        const size_t from = built.backend.find(' ') + 1, to = built.backend.find(' ', from);
        return from == 0 ? "plugin" : built.backend.substr(from, to - from);
    }
    if (spec.backend != "custom") return spec.backend;
    // The layout as built (auto decides by the scene's size).
    const bool quantized = built.backend.find(accel::layout_name(accel::NodeLayout::Quantized)) != std::string::npos;
    return std::string(accel::isa_name(accel::resolve_isa(spec.options.isa))) + "/" +
           accel::layout_name(quantized ? accel::NodeLayout::Quantized : accel::NodeLayout::Float);
}

std::vector<BackendSpec> parse_backend_specs(const std::string& list) {
    std::vector<BackendSpec> out;
    std::stringstream ss(list);
    for (std::string s; std::getline(ss, s, ',');)
        if (!s.empty()) out.push_back(parse_backend_spec(s));
    if (out.empty()) throw std::invalid_argument("no backends given");
    return out;
}

std::vector<BackendSpec> parse_backend_specs(const std::string& list, const std::string& isa,
                                             const std::string& nodes) {
    std::vector<BackendSpec> specs = parse_backend_specs(list);
    accel::Isa i = accel::Isa::Auto;
    if (!accel::parse_isa(isa, i)) throw std::invalid_argument("unknown kernel '" + isa + "'");
    apply_isa(specs, i);
    accel::NodeLayout l = accel::NodeLayout::Auto;
    if (!accel::parse_layout(nodes, l)) throw std::invalid_argument("unknown node layout '" + nodes + "'");
    apply_layout(specs, l);
    return specs;
}

}  // namespace renderer
