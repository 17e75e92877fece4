/* accel_plugin.h: the C ABI through which an outside acceleration structure plugs into
 * the path tracer, its cross-check (xcheck) and its benchmarks (accel_bench, extremes).
 *
 * One header, plain C99, no other include of this project: a plugin written in C, C++,
 * Rust or Zig implements it by exporting one function,
 *
 *     const AccelPluginApi* accel_plugin_entry(void);
 *
 * that returns a table of functions, filled once and valid until the library is
 * unloaded. The host loads the library with dlopen, calls the entry point, checks
 * abi_version == ACCEL_PLUGIN_ABI_VERSION (and that struct_size covers the fields it
 * reads), then calls build once and intersect/occluded many times.
 * accel/plugin/README.md walks through writing, building, cross-checking and
 * benchmarking a plugin; accel/plugin/example/ is a complete one in about 350 lines.
 *
 * Invariants every plugin must keep:
 *   - Rays: the segment org + t * dir, t in [t_min, t_max]. dir is not normalised; t is in
 *     units of |dir|. t_max may be +infinity. dir components may be 0 (or -0).
 *   - Closest hit: the hit with the smallest t in [t_min, t_max], inclusive at both ends.
 *     Triangles report barycentrics (u, v): the point is (1-u-v)*v0 + u*v1 + v*v2.
 *     Spheres report u = v = 0. The host computes the geometric normal itself unless
 *     the plugin reports it (ACCEL_PLUGIN_REPORTS_NORMALS).
 *   - Both faces of a triangle are hit (no culling); degenerate triangles (zero area,
 *     non-finite vertices) and spheres of radius <= 0 are never hit.
 *   - Watertightness: the host expects hits on a shared edge not to leak through; a
 *     plugin that uses a non-watertight test (as the example's Moller-Trumbore) is still
 *     usable, and xcheck classifies its edge misses as "numerical", not "real".
 *   - Thread safety: build and destroy are never called concurrently with anything on the
 *     same handle. intersect, occluded and their batched forms ARE called from many
 *     threads at once on the same handle: they must only read the structure. Counters are
 *     per call (the host owns one per thread), so a plugin never needs atomics for them.
 *   - Errors: every function that can fail returns ACCEL_PLUGIN_OK (0) or a negative
 *     code, and writes a NUL-terminated message of at most `error_size` bytes into
 *     `error`. A plugin never aborts, exits or throws across this boundary.
 *     The host's answer: a failed build is refused like bad input (the tool exits with
 *     status 2, naming the plugin's path and the message). A failed intersect or
 *     occluded is fatal to the render (a wrong hit would be a silently wrong image): the
 *     host prints one line naming the plugin and the message and exits with status 2,
 *     writing no image. A plugin that crashes takes the process down: the host prints one
 *     line naming the plugin and the signal, then dies by that signal.
 */
#ifndef ACCEL_PLUGIN_H
#define ACCEL_PLUGIN_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Bumped on any change to the layout or meaning of the structs below. */
#define ACCEL_PLUGIN_ABI_VERSION 1u

/* The one symbol a plugin exports:
 *     ACCEL_PLUGIN_EXPORT const AccelPluginApi* accel_plugin_entry(void) { ... }   */
#define ACCEL_PLUGIN_ENTRY_NAME "accel_plugin_entry"
#if defined(_WIN32)
#define ACCEL_PLUGIN_EXPORT __declspec(dllexport)
#else
#define ACCEL_PLUGIN_EXPORT __attribute__((visibility("default")))
#endif

/* Return codes. */
#define ACCEL_PLUGIN_OK 0
#define ACCEL_PLUGIN_ERROR (-1)          /* anything else; the message says what */
#define ACCEL_PLUGIN_BAD_OPTIONS (-2)    /* the options string was not understood */
#define ACCEL_PLUGIN_OUT_OF_MEMORY (-3)

/* What intersect/occluded return besides errors. */
#define ACCEL_PLUGIN_MISS 0
#define ACCEL_PLUGIN_HIT 1

/* ---- Geometry ------------------------------------------------------------------------ */

#define ACCEL_PLUGIN_TRIANGLES 0u
#define ACCEL_PLUGIN_SPHERES 1u

/* A read-only view of one geometry, owned by the host and valid until destroy: a plugin
 * may keep pointers into it instead of copying. The index of a geometry in the array
 * given to build is the geom_id of its hits.
 *   TRIANGLES: `positions` holds num_vertices xyz triples (3 floats each, packed), plus 4
 *              readable bytes after the last one; `indices` holds 3 * num_prims vertex
 *              indices, all < num_vertices. `spheres` is NULL.
 *   SPHERES:   `spheres` holds num_prims (x, y, z, radius) quadruples. `positions` and
 *              `indices` are NULL.
 * Instances (one prototype placed under many transforms) are flattened by the host into
 * world-space triangles before they reach a plugin; a later ABI version may pass them. */
typedef struct AccelPluginGeometry {
    uint32_t type;          /* ACCEL_PLUGIN_TRIANGLES or ACCEL_PLUGIN_SPHERES */
    uint32_t num_prims;     /* triangles or spheres */
    const float* positions;
    uint32_t num_vertices;
    uint32_t reserved;      /* 0 */
    const uint32_t* indices;
    const float* spheres;
} AccelPluginGeometry;

/* ---- Rays and hits ------------------------------------------------------------------ */

/* 32 bytes; the host's own ray has this layout. */
typedef struct AccelPluginRay {
    float org[3];
    float dir[3];
    float t_min;
    float t_max;
} AccelPluginRay;

typedef struct AccelPluginHit {
    float t;
    float u, v;
    uint32_t geom_id;  /* index into the geometry array given to build */
    uint32_t prim_id;  /* triangle or sphere index inside that geometry */
    /* Only read with ACCEL_PLUGIN_REPORTS_NORMALS: the unnormalised geometric normal,
     * cross(v1 - v0, v2 - v0) for triangles (it follows the winding), hit point minus
     * centre for spheres. Without that bit the host computes it from the geometry, which
     * costs a few loads per hit that may miss the cache. */
    float ng[3];
} AccelPluginHit;

/* Per-thread counters. The host passes NULL when it is not counting (timed benchmark
 * runs): a plugin should then skip its counting. Add to the fields; never reset them. */
typedef struct AccelPluginCounters {
    uint64_t nodes_visited;  /* nodes whose bounds were tested */
    uint64_t prim_tests;     /* ray-primitive tests */
} AccelPluginCounters;

/* Batched rays in structure-of-arrays form: element i of each array is ray i. */
typedef struct AccelPluginRaysSoA {
    const float* org_x;
    const float* org_y;
    const float* org_z;
    const float* dir_x;
    const float* dir_y;
    const float* dir_z;
    const float* t_min;
    const float* t_max;
} AccelPluginRaysSoA;

/* Batched closest hits; on a miss `geom_id[i]` is 0xFFFFFFFF and the rest is unspecified.
 * ng_x, ng_y, ng_z as AccelPluginHit's ng (written only with ACCEL_PLUGIN_REPORTS_NORMALS). */
typedef struct AccelPluginHitsSoA {
    float* t;
    float* u;
    float* v;
    uint32_t* geom_id;
    uint32_t* prim_id;
    float* ng_x;
    float* ng_y;
    float* ng_z;
} AccelPluginHitsSoA;

/* ---- Build -------------------------------------------------------------------------- */

/* What build reports about the structure, for the accelerator summary line. Zero what you
 * do not know; the host zeroes the struct before the call. */
typedef struct AccelPluginBuildInfo {
    uint64_t primitives;  /* primitives inserted */
    uint64_t dropped;     /* degenerate primitives left out */
    uint64_t nodes;       /* interior + leaf nodes */
    uint64_t leaves;
    uint32_t depth;
    uint32_t reserved;
    double sah_cost;
    char description[64]; /* e.g. "bvh2(sah, leaf 4)": shown in the summary line */
} AccelPluginBuildInfo;

/* Capability bits. */
#define ACCEL_PLUGIN_COUNTS_NODES (1u << 0)  /* intersect/occluded add to nodes_visited */
#define ACCEL_PLUGIN_COUNTS_PRIMS (1u << 1)  /* ... and to prim_tests */
#define ACCEL_PLUGIN_REPORTS_NORMALS (1u << 2) /* hits carry their geometric normal (ng) */

typedef struct AccelPluginApi {
    uint32_t abi_version;  /* ACCEL_PLUGIN_ABI_VERSION */
    uint32_t struct_size;  /* sizeof(AccelPluginApi) as the plugin was compiled */
    const char* name;      /* short, printable, e.g. "example-bvh2" */
    const char* version;   /* the plugin's own version, e.g. "1.0" */
    uint32_t capabilities; /* ACCEL_PLUGIN_COUNTS_*, ACCEL_PLUGIN_REPORTS_NORMALS */
    uint32_t reserved;

    /* Builds a structure over geometry[0 .. num_geometry). `options` is the text after
     * the plugin's path in "plugin:PATH:OPTIONS" ("" when none). On success stores an
     * opaque handle in *handle and returns ACCEL_PLUGIN_OK. */
    int (*build)(const AccelPluginGeometry* geometry, uint32_t num_geometry, const char* options,
                 void** handle, AccelPluginBuildInfo* info, char* error, size_t error_size);

    /* Closest hit of one ray. Returns ACCEL_PLUGIN_HIT and fills *hit, ACCEL_PLUGIN_MISS
     * (leaving *hit as it was), or a negative error code with a message. `ray` and `hit`
     * point into the caller's memory for this call only. */
    int (*intersect)(const void* handle, const AccelPluginRay* ray, AccelPluginHit* hit,
                     AccelPluginCounters* counters, char* error, size_t error_size);

    /* Whether anything lies on the ray in [t_min, t_max]; may stop at the first hit
     * found. Returns ACCEL_PLUGIN_HIT, ACCEL_PLUGIN_MISS or a negative error code. */
    int (*occluded)(const void* handle, const AccelPluginRay* ray, AccelPluginCounters* counters,
                    char* error, size_t error_size);

    /* Optional (may be NULL): `count` rays at once. The host uses them, when present,
     * for the ray sets of xcheck and accel_bench (chunks of up to 1024 rays); the
     * renderer's paths trace one ray at a time. occluded_n writes 1 or 0 per ray. */
    int (*intersect_n)(const void* handle, const AccelPluginRaysSoA* rays, uint32_t count,
                       AccelPluginHitsSoA* hits, AccelPluginCounters* counters, char* error,
                       size_t error_size);
    int (*occluded_n)(const void* handle, const AccelPluginRaysSoA* rays, uint32_t count,
                      uint8_t* occluded, AccelPluginCounters* counters, char* error,
                      size_t error_size);

    /* Bytes the structure holds (not the host's geometry). */
    uint64_t (*memory_used)(const void* handle);

    /* Frees everything build allocated. */
    void (*destroy)(void* handle);
} AccelPluginApi;

typedef const AccelPluginApi* (*AccelPluginEntryFn)(void);

#ifdef __cplusplus
}
#endif

#endif /* ACCEL_PLUGIN_H */
