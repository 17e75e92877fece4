/* Plugins that misbehave in one way each (compiled once per BAD_* macro, tests/CMakeLists.txt),
 * so the tests can check that the host refuses or stops each with the documented outcome
 * (accel/plugin/accel_plugin.h, "Errors"). Each traces a scene as if it had no geometry,
 * unless its fault is in tracing. */
#include <stdio.h>
#include <stdlib.h>

#include "accel_plugin.h"

static int dummy_handle;

static int build(const AccelPluginGeometry* g, uint32_t n, const char* options, void** handle,
                 AccelPluginBuildInfo* info, char* error, size_t error_size) {
    (void)g, (void)n, (void)options, (void)info;
#ifdef BAD_BUILD_FAILS
    snprintf(error, error_size, "this plugin refuses every scene");
    (void)handle;
    return ACCEL_PLUGIN_ERROR;
#else
    (void)error, (void)error_size;
    *handle = &dummy_handle;
    return ACCEL_PLUGIN_OK;
#endif
}

static int intersect(const void* h, const AccelPluginRay* ray, AccelPluginHit* hit, AccelPluginCounters* c,
                     char* error, size_t error_size) {
    (void)h, (void)ray, (void)hit, (void)c, (void)error, (void)error_size;
#if defined(BAD_TRACE_FAILS)
    snprintf(error, error_size, "lost track of the ray");
    return ACCEL_PLUGIN_ERROR;
#elif defined(BAD_CRASHES)
    volatile int* null = NULL;
    return *null;
#elif defined(BAD_WRONG_IDS)
    hit->t = 1.0f, hit->u = hit->v = 0.0f, hit->geom_id = 7777, hit->prim_id = 0;
    return ACCEL_PLUGIN_HIT;
#else
    return ACCEL_PLUGIN_MISS;
#endif
}

static int occluded(const void* h, const AccelPluginRay* ray, AccelPluginCounters* c, char* error, size_t error_size) {
    (void)h, (void)ray, (void)c, (void)error, (void)error_size;
    return ACCEL_PLUGIN_MISS;
}

static uint64_t memory_used(const void* h) { (void)h; return 0; }
static void destroy(void* h) { (void)h; }

#ifndef BAD_NO_ENTRY
ACCEL_PLUGIN_EXPORT const AccelPluginApi* accel_plugin_entry(void) {
    static const AccelPluginApi api = {
#ifdef BAD_WRONG_ABI
        ACCEL_PLUGIN_ABI_VERSION + 41,
#else
        ACCEL_PLUGIN_ABI_VERSION,
#endif
        sizeof(AccelPluginApi), "bad", "0", 0, 0,
        build, intersect, occluded, NULL, NULL, memory_used, destroy,
    };
    return &api;
}
#else
/* Exports something, just not the entry point. */
ACCEL_PLUGIN_EXPORT int not_the_entry_point(void) { return 0; }
#endif
