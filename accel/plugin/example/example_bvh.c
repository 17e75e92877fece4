/* The example plugin: a binary BVH built by binned SAH (Wald 2007, "On fast Construction
 * of SAH-based Bounding Volume Hierarchies"), traced one ray at a time with a scalar
 * slab test and Moller-Trumbore triangles (1997). Written against accel_plugin.h alone,
 * in C, to show the smallest thing that plugs into the host: it renders, cross-checks and
 * benchmarks like a built-in backend. Options: "leaf=N" (primitives per leaf, default 4)
 * and "bins=N" (SAH bins, 2..64, default 16), separated by ':' or ','. */
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "accel_plugin.h"

typedef struct { float lo[3], hi[3]; } Box;
/* count == 0: interior node whose children are nodes[first] and nodes[first + 1]. */
typedef struct { Box box; uint32_t first, count; } Node;
typedef struct { uint32_t geom, prim; } Ref;

typedef struct {
    AccelPluginGeometry* geometry; /* a copy of the views; the arrays stay the host's */
    Node* nodes;
    Ref* refs;
    uint32_t num_nodes, num_refs, leaf_size, bins, depth;
} Bvh;

#define MAX_BINS 64
#define STACK 64

/* ---- Boxes -------------------------------------------------------------------------- */

static Box box_empty(void) {
    Box b = {{FLT_MAX, FLT_MAX, FLT_MAX}, {-FLT_MAX, -FLT_MAX, -FLT_MAX}};
    return b;
}
static void box_grow(Box* b, const Box* o) {
    for (int k = 0; k < 3; ++k) {
        b->lo[k] = fminf(b->lo[k], o->lo[k]);
        b->hi[k] = fmaxf(b->hi[k], o->hi[k]);
    }
}
static float box_area(const Box* b) {
    const float dx = b->hi[0] - b->lo[0], dy = b->hi[1] - b->lo[1], dz = b->hi[2] - b->lo[2];
    return dx < 0 ? 0 : 2.0f * (dx * dy + dy * dz + dz * dx);
}
static float centroid(const Box* b, int k) { return 0.5f * (b->lo[k] + b->hi[k]); }

static const float* vertex(const AccelPluginGeometry* g, uint32_t prim, int corner) {
    return g->positions + 3 * (size_t)g->indices[3 * (size_t)prim + corner];
}

/* Bounds of a primitive; 0 if it can never be hit (non-finite, or a sphere of radius <= 0). */
static int prim_box(const AccelPluginGeometry* g, uint32_t prim, Box* b) {
    *b = box_empty();
    if (g->type == ACCEL_PLUGIN_SPHERES) {
        const float* s = g->spheres + 4 * (size_t)prim;
        if (!(s[3] > 0) || !isfinite(s[0] + s[1] + s[2] + s[3])) return 0;
        for (int k = 0; k < 3; ++k) b->lo[k] = s[k] - s[3], b->hi[k] = s[k] + s[3];
        return 1;
    }
    for (int c = 0; c < 3; ++c) {
        const float* v = vertex(g, prim, c);
        if (!isfinite(v[0] + v[1] + v[2])) return 0;
        for (int k = 0; k < 3; ++k) b->lo[k] = fminf(b->lo[k], v[k]), b->hi[k] = fmaxf(b->hi[k], v[k]);
    }
    return 1;
}

/* ---- Build: binned SAH over primitive centroids -------------------------------------- */

static uint32_t bin_of(float c, float lo, float scale, uint32_t bins) {
    const float b = (c - lo) * scale;
    return b <= 0 ? 0 : b >= (float)(bins - 1) ? bins - 1 : (uint32_t)b;
}

/* Fills nodes[id] over refs[first, first + count); children go to two fresh slots. */
static void build_node(Bvh* t, Box* boxes, uint32_t id, uint32_t first, uint32_t count, uint32_t depth) {
    Box bounds = box_empty(), cbox = box_empty();
    for (uint32_t i = first; i < first + count; ++i) {
        box_grow(&bounds, &boxes[i]);
        for (int k = 0; k < 3; ++k) {
            const float c = centroid(&boxes[i], k);
            cbox.lo[k] = fminf(cbox.lo[k], c), cbox.hi[k] = fmaxf(cbox.hi[k], c);
        }
    }
    t->nodes[id].box = bounds;
    t->nodes[id].first = first;
    t->nodes[id].count = count;
    if (depth > t->depth) t->depth = depth;
    if (count <= t->leaf_size || depth >= STACK - 2) return;

    /* Split where A(left) N(left) + A(right) N(right) is least, if below A N (a leaf). */
    float best = box_area(&bounds) * (float)count;
    int axis = -1;
    uint32_t split = 0;
    for (int k = 0; k < 3; ++k) {
        const float extent = cbox.hi[k] - cbox.lo[k];
        if (!(extent > 0)) continue;
        const float scale = (float)t->bins / extent;
        Box bin_box[MAX_BINS];
        uint32_t bin_count[MAX_BINS] = {0};
        for (uint32_t b = 0; b < t->bins; ++b) bin_box[b] = box_empty();
        for (uint32_t i = first; i < first + count; ++i) {
            const uint32_t b = bin_of(centroid(&boxes[i], k), cbox.lo[k], scale, t->bins);
            box_grow(&bin_box[b], &boxes[i]);
            ++bin_count[b];
        }
        float right_area[MAX_BINS];
        uint32_t right_count[MAX_BINS];
        Box acc = box_empty();
        uint32_t n = 0;
        for (uint32_t b = t->bins - 1; b > 0; --b) {
            box_grow(&acc, &bin_box[b]);
            n += bin_count[b];
            right_area[b] = box_area(&acc), right_count[b] = n;
        }
        acc = box_empty();
        n = 0;
        for (uint32_t b = 1; b < t->bins; ++b) {
            box_grow(&acc, &bin_box[b - 1]);
            n += bin_count[b - 1];
            const float cost = box_area(&acc) * (float)n + right_area[b] * (float)right_count[b];
            if (n && right_count[b] && cost < best) best = cost, axis = k, split = b;
        }
    }
    if (axis < 0) return;

    const float scale = (float)t->bins / (cbox.hi[axis] - cbox.lo[axis]);
    uint32_t mid = first;
    for (uint32_t i = first; i < first + count; ++i)
        if (bin_of(centroid(&boxes[i], axis), cbox.lo[axis], scale, t->bins) < split) {
            const Box tb = boxes[i];
            boxes[i] = boxes[mid], boxes[mid] = tb;
            const Ref tr = t->refs[i];
            t->refs[i] = t->refs[mid], t->refs[mid] = tr;
            ++mid;
        }
    const uint32_t left = t->num_nodes;
    t->num_nodes += 2;
    t->nodes[id].first = left;
    t->nodes[id].count = 0;
    build_node(t, boxes, left, first, mid - first, depth + 1);
    build_node(t, boxes, left + 1, mid, first + count - mid, depth + 1);
}

static void destroy(void* handle) {
    Bvh* t = (Bvh*)handle;
    if (!t) return;
    free(t->geometry);
    free(t->nodes);
    free(t->refs);
    free(t);
}

static int parse_options(Bvh* t, const char* options, char* error, size_t error_size) {
    char buf[256];
    snprintf(buf, sizeof buf, "%s", options ? options : "");
    for (char* w = strtok(buf, ":,"); w; w = strtok(NULL, ":,")) {
        unsigned v = 0;
        if (sscanf(w, "leaf=%u", &v) == 1 && v >= 1 && v <= 64) t->leaf_size = v;
        else if (sscanf(w, "bins=%u", &v) == 1 && v >= 2 && v <= MAX_BINS) t->bins = v;
        else {
            snprintf(error, error_size, "unknown option '%s' (leaf=1..64, bins=2..64)", w);
            return ACCEL_PLUGIN_BAD_OPTIONS;
        }
    }
    return ACCEL_PLUGIN_OK;
}

static int build(const AccelPluginGeometry* geometry, uint32_t num_geometry, const char* options, void** handle,
                 AccelPluginBuildInfo* info, char* error, size_t error_size) {
    Bvh* t = (Bvh*)calloc(1, sizeof(Bvh));
    if (!t) return snprintf(error, error_size, "out of memory"), ACCEL_PLUGIN_OUT_OF_MEMORY;
    t->leaf_size = 4, t->bins = 16;
    const int rc = parse_options(t, options, error, error_size);
    if (rc != ACCEL_PLUGIN_OK) return destroy(t), rc;
    uint64_t total = 0;
    for (uint32_t g = 0; g < num_geometry; ++g) total += geometry[g].num_prims;
    if (total > 0x7FFFFFFFu) return destroy(t), snprintf(error, error_size, "more than 2^31 primitives"), ACCEL_PLUGIN_ERROR;
    t->geometry = (AccelPluginGeometry*)malloc((num_geometry + 1) * sizeof(AccelPluginGeometry));
    t->refs = (Ref*)malloc((total + 1) * sizeof(Ref));
    t->nodes = (Node*)malloc((2 * total + 1) * sizeof(Node));
    Box* boxes = (Box*)malloc((total + 1) * sizeof(Box));
    if (!t->geometry || !t->refs || !t->nodes || !boxes) {
        free(boxes), destroy(t);
        return snprintf(error, error_size, "out of memory for %llu primitives", (unsigned long long)total),
               ACCEL_PLUGIN_OUT_OF_MEMORY;
    }
    if (num_geometry) memcpy(t->geometry, geometry, num_geometry * sizeof(AccelPluginGeometry));
    for (uint32_t g = 0; g < num_geometry; ++g)
        for (uint32_t p = 0; p < geometry[g].num_prims; ++p)
            if (prim_box(&geometry[g], p, &boxes[t->num_refs])) t->refs[t->num_refs++] = (Ref){g, p};
    t->num_nodes = 1;
    build_node(t, boxes, 0, 0, t->num_refs, 1);
    free(boxes);
    info->primitives = t->num_refs;
    info->dropped = total - t->num_refs;
    info->nodes = t->num_nodes;
    info->leaves = (t->num_nodes + 1) / 2;
    info->depth = t->depth;
    snprintf(info->description, sizeof info->description, "bvh2 sah, leaf %u, %u bins", t->leaf_size, t->bins);
    *handle = t;
    return ACCEL_PLUGIN_OK;
}

static uint64_t memory_used(const void* handle) {
    const Bvh* t = (const Bvh*)handle;
    return sizeof(Bvh) + (uint64_t)t->num_nodes * sizeof(Node) + (uint64_t)t->num_refs * sizeof(Ref);
}

/* ---- Traversal ---------------------------------------------------------------------- */

typedef struct { float org[3], dir[3], inv[3], t_min; } RayData;

/* Entry distance into a box within [t_min, t_max], or +inf on a miss. fminf/fmaxf drop
 * the NaN of 0 * inf (a ray in a slab's plane), which keeps the box, conservatively. */
static float box_enter(const Box* b, const RayData* r, float t_max) {
    float lo = r->t_min, hi = t_max;
    for (int k = 0; k < 3; ++k) {
        const float t0 = (b->lo[k] - r->org[k]) * r->inv[k], t1 = (b->hi[k] - r->org[k]) * r->inv[k];
        lo = fmaxf(lo, fminf(t0, t1));
        hi = fminf(hi, fmaxf(t0, t1));
    }
    return lo <= hi ? lo : INFINITY;
}

static void sub(const float* a, const float* b, float* o) { o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2]; }
static void cross(const float* a, const float* b, float* o) {
    o[0] = a[1] * b[2] - a[2] * b[1], o[1] = a[2] * b[0] - a[0] * b[2], o[2] = a[0] * b[1] - a[1] * b[0];
}
static float dot(const float* a, const float* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Moller-Trumbore; comparisons written so that NaN fails them. */
static int hit_triangle(const AccelPluginGeometry* g, uint32_t prim, const RayData* r, float t_max, AccelPluginHit* h) {
    const float *v0 = vertex(g, prim, 0), *v1 = vertex(g, prim, 1), *v2 = vertex(g, prim, 2);
    float e1[3], e2[3], p[3], s[3], q[3];
    sub(v1, v0, e1), sub(v2, v0, e2), cross(r->dir, e2, p);
    const float det = dot(e1, p);
    if (det == 0.0f) return 0;
    const float inv_det = 1.0f / det;
    sub(r->org, v0, s);
    const float u = dot(s, p) * inv_det;
    if (!(u >= 0.0f && u <= 1.0f)) return 0;
    cross(s, e1, q);
    const float v = dot(r->dir, q) * inv_det;
    if (!(v >= 0.0f && u + v <= 1.0f)) return 0;
    const float t = dot(e2, q) * inv_det;
    if (!(t >= r->t_min && t <= t_max)) return 0;
    h->t = t, h->u = u, h->v = v;
    return 1;
}

/* Nearer root of |o + t d - c|^2 = r^2 in [t_min, t_max], in the stable form of Haines et
 * al. 2019 ("Precision Improvements for Ray/Sphere Intersection"). */
static int hit_sphere(const AccelPluginGeometry* g, uint32_t prim, const RayData* r, float t_max, AccelPluginHit* h) {
    const float* s = g->spheres + 4 * (size_t)prim;
    float f[3], perp[3];
    sub(r->org, s, f);
    const float a = dot(r->dir, r->dir), b = dot(f, r->dir), c = dot(f, f) - s[3] * s[3];
    for (int k = 0; k < 3; ++k) perp[k] = f[k] - r->dir[k] * (b / a);
    const float disc = a * (s[3] * s[3] - dot(perp, perp));
    if (!(disc >= 0.0f)) return 0;
    const float q = -(b + copysignf(sqrtf(disc), b));
    float t0 = q == 0.0f ? 0.0f : c / q, t1 = q == 0.0f ? 0.0f : q / a;
    if (t0 > t1) { const float x = t0; t0 = t1, t1 = x; }
    const float t = t0 >= r->t_min && t0 <= t_max ? t0 : t1 >= r->t_min && t1 <= t_max ? t1 : NAN;
    if (isnan(t)) return 0;
    h->t = t, h->u = h->v = 0.0f;
    return 1;
}

/* Closest hit (any_hit = 0) or the first hit found (any_hit = 1); near child first. */
static int traverse(const Bvh* t, const AccelPluginRay* ray, int any_hit, AccelPluginHit* out, AccelPluginCounters* c) {
    if (t->num_refs == 0) return ACCEL_PLUGIN_MISS;
    RayData r;
    for (int k = 0; k < 3; ++k) r.org[k] = ray->org[k], r.dir[k] = ray->dir[k], r.inv[k] = 1.0f / ray->dir[k];
    r.t_min = ray->t_min;
    float t_max = ray->t_max;
    int found = 0;
    /* Each entry: a node whose box the ray enters, and where it enters it. */
    struct { uint32_t node; float enter; } stack[STACK];
    uint32_t top = 0;
    if (c) ++c->nodes_visited;
    const float root = box_enter(&t->nodes[0].box, &r, t_max);
    if (root != INFINITY) stack[top].node = 0, stack[top++].enter = root;
    while (top) {
        --top;
        if (stack[top].enter > t_max) continue; /* a closer hit was found since the push */
        const Node* n = &t->nodes[stack[top].node];
        if (n->count) {
            for (uint32_t i = n->first; i < n->first + n->count; ++i) {
                const Ref ref = t->refs[i];
                const AccelPluginGeometry* g = &t->geometry[ref.geom];
                AccelPluginHit h;
                if (c) ++c->prim_tests;
                const int hit = g->type == ACCEL_PLUGIN_SPHERES ? hit_sphere(g, ref.prim, &r, t_max, &h)
                                                                : hit_triangle(g, ref.prim, &r, t_max, &h);
                if (!hit) continue;
                if (any_hit) return ACCEL_PLUGIN_HIT;
                found = 1, t_max = h.t;
                h.geom_id = ref.geom, h.prim_id = ref.prim;
                *out = h;
            }
            continue;
        }
        /* Test both children; push the farther first so the nearer is popped next. */
        if (c) c->nodes_visited += 2;
        const uint32_t a = n->first, b = n->first + 1;
        const float da = box_enter(&t->nodes[a].box, &r, t_max), db = box_enter(&t->nodes[b].box, &r, t_max);
        const uint32_t near = da <= db ? a : b, far = da <= db ? b : a;
        const float dn = da <= db ? da : db, df = da <= db ? db : da;
        if (df != INFINITY) stack[top].node = far, stack[top++].enter = df;
        if (dn != INFINITY) stack[top].node = near, stack[top++].enter = dn;
    }
    return found ? ACCEL_PLUGIN_HIT : ACCEL_PLUGIN_MISS;
}

static int intersect(const void* handle, const AccelPluginRay* ray, AccelPluginHit* hit, AccelPluginCounters* c,
                     char* error, size_t error_size) {
    (void)error, (void)error_size;
    return traverse((const Bvh*)handle, ray, 0, hit, c);
}

static int occluded(const void* handle, const AccelPluginRay* ray, AccelPluginCounters* c, char* error,
                    size_t error_size) {
    (void)error, (void)error_size;
    AccelPluginHit unused;
    return traverse((const Bvh*)handle, ray, 1, &unused, c);
}

/* The batched forms only loop here; a packet or SIMD tracer would earn its keep in them. */
static AccelPluginRay ray_at(const AccelPluginRaysSoA* s, uint32_t i) {
    AccelPluginRay r = {{s->org_x[i], s->org_y[i], s->org_z[i]}, {s->dir_x[i], s->dir_y[i], s->dir_z[i]}, s->t_min[i], s->t_max[i]};
    return r;
}

static int intersect_n(const void* handle, const AccelPluginRaysSoA* rays, uint32_t count, AccelPluginHitsSoA* hits,
                       AccelPluginCounters* c, char* error, size_t error_size) {
    (void)error, (void)error_size;
    for (uint32_t i = 0; i < count; ++i) {
        const AccelPluginRay r = ray_at(rays, i);
        AccelPluginHit h;
        if (traverse((const Bvh*)handle, &r, 0, &h, c) == ACCEL_PLUGIN_HIT)
            hits->t[i] = h.t, hits->u[i] = h.u, hits->v[i] = h.v, hits->geom_id[i] = h.geom_id, hits->prim_id[i] = h.prim_id;
        else
            hits->geom_id[i] = 0xFFFFFFFFu;
    }
    return ACCEL_PLUGIN_OK;
}

static int occluded_n(const void* handle, const AccelPluginRaysSoA* rays, uint32_t count, uint8_t* occluded_out,
                      AccelPluginCounters* c, char* error, size_t error_size) {
    (void)error, (void)error_size;
    for (uint32_t i = 0; i < count; ++i) {
        const AccelPluginRay r = ray_at(rays, i);
        AccelPluginHit unused;
        occluded_out[i] = (uint8_t)(traverse((const Bvh*)handle, &r, 1, &unused, c) == ACCEL_PLUGIN_HIT);
    }
    return ACCEL_PLUGIN_OK;
}

ACCEL_PLUGIN_EXPORT const AccelPluginApi* accel_plugin_entry(void) {
    static const AccelPluginApi api = {
        ACCEL_PLUGIN_ABI_VERSION, sizeof(AccelPluginApi), "example-bvh2", "1.0",
        ACCEL_PLUGIN_COUNTS_NODES | ACCEL_PLUGIN_COUNTS_PRIMS, 0,
        build, intersect, occluded, intersect_n, occluded_n, memory_used, destroy,
    };
    return &api;
}
