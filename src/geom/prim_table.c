/* The flat primitive table (rt/prim.h): one depth-first walk of the scene tree collects
 * the leaves and interns the Transform chains above them. */
#include "rt/prim.h"

#include <stdlib.h>
#include <string.h>

#include "rt/bigmem.h"
#include "rt/par.h"
#include "rt/scene.h"

typedef struct Walk {
    PrimTable *t;
    uint32_t cap;
    /* The last chain interned at each depth: a depth-first walk returns to a chain of
     * depth d only after visiting deeper ones, so this finds every repeat. */
    const PrimXform *last_at_depth[RT_MAX_NESTING + 1];
    bool oom;
    bool stopped; /* a stop was requested (rt/par.h): the table is given up */
} Walk;

/* A big group's children between two looks at the stop request (a power of two): a
 * 1M-triangle mesh is flattened in ~0.1-0.2 s, so a Ctrl-C ends it within a few ms. */
enum { STOP_LEAVES = 65536 };

static bool path_equal(const XformPath *a, const XformPath *b)
{
    return a->depth == b->depth &&
           memcmp(a->xf, b->xf, (size_t)a->depth * sizeof a->xf[0]) == 0;
}

/* The interned copy of path with its composed matrices; NULL for depth 0 or when out
 * of memory (w->oom). */
static const PrimXform *intern(Walk *w, const XformPath *path)
{
    if (path->depth <= 0)
        return NULL;
    int d = path->depth > RT_MAX_NESTING ? RT_MAX_NESTING : path->depth;
    const PrimXform *last = w->last_at_depth[d];
    if (last && path_equal(&last->path, path))
        return last;
    PrimTable *t = w->t;
    if (t->num_xforms == t->cap_xforms) {
        uint32_t cap = t->cap_xforms ? 2 * t->cap_xforms : 16;
        PrimXform **p = realloc(t->xforms, cap * sizeof *p);
        if (!p) {
            w->oom = true;
            return NULL;
        }
        t->xforms = p;
        t->cap_xforms = cap;
    }
    PrimXform *x = calloc(1, sizeof *x);
    if (!x) {
        w->oom = true;
        return NULL;
    }
    x->path.depth = d;
    memcpy(x->path.xf, path->xf, (size_t)d * sizeof path->xf[0]);
    /* M = M1 * ... * Mk maps object space to world; its inverse is Mk^-1 * ... * M1^-1. */
    x->m = mat4_identity();
    x->inv = mat4_identity();
    for (int i = 0; i < d; i++) {
        x->m = mat4_mul(&x->m, transform_matrix(path->xf[i]));
        x->inv = mat4_mul(transform_inverse(path->xf[i]), &x->inv);
    }
    t->xforms[t->num_xforms++] = x;
    w->last_at_depth[d] = x;
    return x;
}

/* Whether every coordinate of b is finite and within +-PRIM_MAX_COORD (NaN fails). */
static bool box_within_limit(const BBox *b)
{
    for (int a = 0; a < 3; a++) {
        float lo = v3_comp(b->min, a), hi = v3_comp(b->max, a);
        if (!(lo >= -PRIM_MAX_COORD && lo <= PRIM_MAX_COORD && hi >= -PRIM_MAX_COORD &&
              hi <= PRIM_MAX_COORD))
            return false;
    }
    return true;
}

static void add_leaf(Walk *w, const Object3D *o, const XformPath *path)
{
    PrimTable *t = w->t;
    if (t->num_prims == w->cap) {
        uint32_t cap = w->cap ? 2 * w->cap : 256;
        Prim *p = cap > w->cap && cap < UINT32_MAX / 2 ? bigmem_resize(t->prims, (size_t)cap * sizeof *p)
                                                       : NULL;
        if (!p) {
            w->oom = true;
            return;
        }
        t->prims = p;
        w->cap = cap;
    }
    const PrimXform *xf = intern(w, path);
    if (w->oom)
        return;
    Prim *p = &t->prims[t->num_prims++];
    p->obj = o;
    p->xf = xf;
    p->id = o->id;
    p->bounded = o->bounded;
    p->bounds = o->ops->bounds(o, xf ? &xf->m : NULL);
    if (p->bounded && !box_within_limit(&p->bounds)) {
        if (t->num_kept_out++ == 0)
            t->first_kept_out = t->num_prims - 1;
        p->bounded = false;
    }
    t->num_bounded += p->bounded;
}

/* A group of many leaves (a mesh: 40k triangles) fills its run of the table in
 * chunks on the set-up threads (rt/par.h). */
enum { LEAF_CHUNK = 4096 };

/* The leaves' chunk job: each chunk writes its own slots and counts, combined in chunk
 * order afterwards, so the table and its counters are add_leaf's on any thread count. */
typedef struct LeafJob {
    const Object3D *group;
    const PrimXform *xf;
    Prim *dst;            /* the group's first slot */
    int n;
    uint32_t *bounded;    /* per chunk */
    uint32_t *kept_out;   /* per chunk */
    int *first_out;       /* per chunk: index in the group of its first kept-out leaf */
} LeafJob;

static void leaf_chunk(void *ctx, int k, int worker)
{
    (void)worker;
    const LeafJob *job = ctx;
    if (par_stop_requested())
        return; /* add_leaf_group gives the table up */
    int i0 = k * LEAF_CHUNK, i1 = job->n - i0 > LEAF_CHUNK ? i0 + LEAF_CHUNK : job->n;
    uint32_t bounded = 0, kept_out = 0;
    int first_out = -1;
    for (int i = i0; i < i1; i++) {
        const Object3D *o = group_child(job->group, i);
        Prim *p = &job->dst[i];
        p->obj = o;
        p->xf = job->xf;
        p->id = o->id;
        p->bounded = o->bounded;
        p->bounds = o->ops->bounds(o, job->xf ? &job->xf->m : NULL);
        if (p->bounded && !box_within_limit(&p->bounds)) {
            if (kept_out++ == 0)
                first_out = i;
            p->bounded = false;
        }
        bounded += p->bounded;
    }
    job->bounded[k] = bounded;
    job->kept_out[k] = kept_out;
    job->first_out[k] = first_out;
}

/* Adds group o's children when they are all leaves and many (true), as add_leaf would
 * one by one; false, with nothing done, otherwise. */
static bool add_leaf_group(Walk *w, const Object3D *o, const XformPath *path)
{
    int n = group_count(o);
    if (n < 2 * LEAF_CHUNK || par_threads() < 2)
        return false;
    for (int i = 0; i < n; i++) {
        const Object3D *c = group_child(o, i);
        ObjKind k = c ? obj_kind(c) : OBJ_GROUP;
        if (k == OBJ_GROUP || k == OBJ_TRANSFORM)
            return false;
    }
    PrimTable *t = w->t;
    if ((uint64_t)t->num_prims + (uint64_t)n > (uint64_t)w->cap) {
        uint64_t cap = (uint64_t)t->num_prims + (uint64_t)n;
        Prim *p = cap < UINT32_MAX / 2 ? bigmem_resize(t->prims, (size_t)cap * sizeof *p) : NULL;
        if (!p) {
            w->oom = true;
            return true;
        }
        t->prims = p;
        w->cap = (uint32_t)cap;
    }
    const PrimXform *xf = intern(w, path);
    if (w->oom)
        return true;
    int nchunks = n / LEAF_CHUNK + (n % LEAF_CHUNK != 0);
    uint32_t *counts = malloc((size_t)nchunks * 2 * sizeof *counts);
    int *first = malloc((size_t)nchunks * sizeof *first);
    if (!counts || !first) {
        free(counts);
        free(first);
        w->oom = true;
        return true;
    }
    LeafJob job = {o, xf, t->prims + t->num_prims, n, counts, counts + nchunks, first};
    par_for(nchunks, leaf_chunk, &job);
    if (par_stop_requested()) { /* chunks were skipped (the flag is never cleared) */
        free(counts);
        free(first);
        w->stopped = true;
        return true;
    }
    for (int k = 0; k < nchunks; k++) {
        if (job.kept_out[k] > 0 && t->num_kept_out == 0)
            t->first_kept_out = t->num_prims + (uint32_t)job.first_out[k];
        t->num_kept_out += job.kept_out[k];
        t->num_bounded += job.bounded[k];
    }
    t->num_prims += (uint32_t)n;
    free(counts);
    free(first);
    return true;
}

/* Groups recurse, Transforms push themselves onto path, leaves are added. */
static void walk(Walk *w, const Object3D *o, XformPath *path)
{
    if (!o || w->oom || w->stopped)
        return;
    switch (obj_kind(o)) {
    case OBJ_GROUP:
        if (add_leaf_group(w, o, path))
            return;
        for (int i = 0; i < group_count(o) && !w->stopped; i++) {
            if ((i & (STOP_LEAVES - 1)) == STOP_LEAVES - 1 && par_stop_requested())
                w->stopped = true;
            else
                walk(w, group_child(o, i), path);
        }
        return;
    case OBJ_TRANSFORM:
        if (path->depth >= RT_MAX_NESTING)
            return; /* the parser rejects deeper nesting */
        path->xf[path->depth++] = o;
        walk(w, transform_child(o), path);
        path->depth--;
        return;
    default:
        add_leaf(w, o, path);
        return;
    }
}

bool prim_table_build(PrimTable *t, const Scene *scene)
{
    memset(t, 0, sizeof *t);
    Walk w;
    memset(&w, 0, sizeof w);
    w.t = t;
    if (scene && scene->root && scene->num_primitives > 0 && scene->num_primitives < UINT32_MAX / 4) {
        w.cap = scene->num_primitives;
        t->prims = bigmem_calloc(w.cap, sizeof *t->prims);
        if (!t->prims)
            w.cap = 0;
    }
    XformPath path;
    path.depth = 0;
    t->scene_bounds = bbox_empty();
    if (scene) {
        t->scene_bounds = scene->bounds;
        walk(&w, scene->root, &path);
    }
    if (w.oom || w.stopped) {
        prim_table_free(t);
        return false;
    }
    /* Without the kept-out leaves, the box is that of the leaves left; so it is too when
     * the tree's box overflowed on its own (a Transform boxing a box near the limit). */
    if (t->num_kept_out > 0 || (!bbox_is_empty(&t->scene_bounds) &&
                                !box_within_limit(&t->scene_bounds))) {
        t->scene_bounds = bbox_empty();
        for (uint32_t i = 0; i < t->num_prims; i++)
            if (t->prims[i].bounded)
                t->scene_bounds = bbox_union(t->scene_bounds, t->prims[i].bounds);
    }
    return true;
}

void prim_table_free(PrimTable *t)
{
    bigmem_free(t->prims);
    for (uint32_t i = 0; i < t->num_xforms; i++)
        free(t->xforms[i]);
    free(t->xforms);
    memset(t, 0, sizeof *t);
    t->scene_bounds = bbox_empty();
}
