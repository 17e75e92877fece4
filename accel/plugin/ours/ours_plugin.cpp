// Our own BVH ("custom") as a plugin: the second example, and the measure of what the
// plugin ABI costs. It is the compiled-in backend's code (accel/bvh), built again
// position-independent, behind accel_plugin.h; the difference between the two in
// accel_bench is the price of the ABI (one more indirect call per ray, and our BVH's own
// virtual call behind it).
// Options, separated by ':' or ',': the words of a custom backend spec: sah | midpoint |
// sbvh, fast | watertight, auto | sse2 | avx2 | avx512, auto | float | quantized, leafN.
#include <cstdio>
#include <exception>
#include <memory>
#include <new>
#include <sstream>
#include <string>
#include <vector>

#include "accel/bvh/bvh.h"
#include "accel_plugin.h"

namespace {

struct Handle {
    std::vector<accel::GeometryView> views;
    std::unique_ptr<accel::Accelerator> bvh;
};

int say(char* error, size_t size, int rc, const std::string& msg) {
    std::snprintf(error, size, "%s", msg.c_str());
    return rc;
}

bool parse(const char* options, accel::AccelOptions& o, std::string& bad) {
    std::string text = options ? options : "";
    for (char& ch : text)
        if (ch == ',') ch = ':';
    std::stringstream ss(text);
    for (std::string w; std::getline(ss, w, ':');) {
        if (w.empty() || w == "auto") continue;
        if (w == "sah") o.split = accel::BvhSplit::Sah;
        else if (w == "midpoint") o.split = accel::BvhSplit::Midpoint;
        else if (w == "sbvh") o.split = accel::BvhSplit::Sbvh;
        else if (w == "fast") o.triangle = accel::TriangleTest::Fast;
        else if (w == "watertight") o.triangle = accel::TriangleTest::Watertight;
        else if (accel::parse_isa(w, o.isa) || accel::parse_layout(w, o.nodes)) {
        } else if (w.rfind("leaf", 0) == 0 && w.size() > 4 && w.find_first_not_of("0123456789", 4) == std::string::npos) {
            o.leaf_size = unsigned(std::stoul(w.substr(4)));
            if (o.leaf_size < 1 || o.leaf_size > 255) return bad = w, false;
        } else {
            return bad = w, false;
        }
    }
    return true;
}

int build(const AccelPluginGeometry* geometry, uint32_t num_geometry, const char* options, void** handle,
          AccelPluginBuildInfo* info, char* error, size_t error_size) {
    accel::AccelOptions o;
    std::string bad;
    if (!parse(options, o, bad))
        return say(error, error_size, ACCEL_PLUGIN_BAD_OPTIONS,
                   "unknown option '" + bad + "' (the words of a custom spec: sah, sbvh, watertight, avx2, leaf4, ...)");
    // No exception may cross the C boundary (accel_plugin.h, "Errors").
    try {
        auto h = std::make_unique<Handle>();
        for (uint32_t g = 0; g < num_geometry; ++g) {
            const AccelPluginGeometry& v = geometry[g];
            h->views.push_back(v.type == ACCEL_PLUGIN_SPHERES
                                   ? accel::GeometryView::sphere_list(v.spheres, v.num_prims)
                                   : accel::GeometryView::triangles(reinterpret_cast<const accel::Vec3f*>(v.positions),
                                                                    v.num_vertices, v.indices, v.num_prims));
        }
        h->bvh = accel::make_bvh(h->views, o);
        const accel::BuildInfo& bi = h->bvh->info();
        info->primitives = bi.primitives;
        info->dropped = bi.dropped;
        info->nodes = bi.nodes;
        info->leaves = bi.leaves;
        info->depth = bi.depth;
        info->sah_cost = bi.sah_cost;
        std::snprintf(info->description, sizeof info->description, "%s", bi.backend.c_str());
        *handle = h.release();
        return ACCEL_PLUGIN_OK;
    } catch (const std::bad_alloc&) {
        return say(error, error_size, ACCEL_PLUGIN_OUT_OF_MEMORY, "out of memory building the BVH");
    } catch (const std::exception& e) {
        return say(error, error_size, ACCEL_PLUGIN_ERROR, e.what());
    }
}

// The ABI's ray and hit have our own layouts (accel/plugin/host.cpp asserts it), so the
// kernel reads and writes them in place.
const accel::Ray& as_ray(const AccelPluginRay* ray) { return *reinterpret_cast<const accel::Ray*>(ray); }

int intersect(const void* handle, const AccelPluginRay* ray, AccelPluginHit* hit, AccelPluginCounters* c, char*,
              size_t) {
    accel::TraceStats st;
    st.counting = c != nullptr;
    const bool found =
        static_cast<const Handle*>(handle)->bvh->intersect(as_ray(ray), *reinterpret_cast<accel::Hit*>(hit), st);
    if (c) c->nodes_visited += st.nodes_visited, c->prim_tests += st.prim_tests;
    return found ? ACCEL_PLUGIN_HIT : ACCEL_PLUGIN_MISS;
}

int occluded(const void* handle, const AccelPluginRay* ray, AccelPluginCounters* c, char*, size_t) {
    accel::TraceStats st;
    st.counting = c != nullptr;
    const bool hit = static_cast<const Handle*>(handle)->bvh->occluded(as_ray(ray), st);
    if (c) c->nodes_visited += st.nodes_visited, c->prim_tests += st.prim_tests;
    return hit ? ACCEL_PLUGIN_HIT : ACCEL_PLUGIN_MISS;
}

uint64_t memory_used(const void* handle) { return static_cast<const Handle*>(handle)->bvh->info().bytes; }

void destroy(void* handle) { delete static_cast<Handle*>(handle); }

}  // namespace

extern "C" ACCEL_PLUGIN_EXPORT const AccelPluginApi* accel_plugin_entry(void) {
    static const AccelPluginApi api = {
        ACCEL_PLUGIN_ABI_VERSION, sizeof(AccelPluginApi), "ours", "1.0",
        ACCEL_PLUGIN_COUNTS_NODES | ACCEL_PLUGIN_COUNTS_PRIMS | ACCEL_PLUGIN_REPORTS_NORMALS, 0,
        build, intersect, occluded, nullptr, nullptr, memory_used, destroy,
    };
    return &api;
}
