/* TriangleMesh construction in bulk: every Triangle of a mesh in one arena block and the
 * Group with its box in the same pass (the per-triangle path costs an allocation each
 * and a second walk for the box), big meshes in parallel. The objects are exactly
 * triangle_new's. */
#include "rt/geom.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rt/arena.h"
#include "rt/par.h"

#include "group_internal.h"
#include "triangle_internal.h"

Object3D *triangle_mesh_new(Arena *a, const Vec3 *verts, const int (*faces)[3], int n,
                            const Material *m)
{
    return triangle_mesh_new_in(a, NULL, verts, faces, n, m);
}

/* Chunks of MESH_CHUNK faces are built in parallel (rt/par.h); each keeps its box, and
 * the boxes are folded in chunk order afterwards. That is the fold over all triangles:
 * rt_minf/rt_maxf keep the first of equal values (-0 and +0) and ignore NaN, so folding
 * the chunks' folds picks the same value, the first minimum, as one fold does. */
enum { MESH_CHUNK = 2048 };

typedef struct MeshJob {
    Triangle *tris;
    const Vec3 *verts;
    const int (*faces)[3];
    int n, chunk;         /* faces, faces per chunk */
    const Material *m;
    bool clear;           /* the memory holds old bytes (an adopted block) */
    Group *g;
    BBox *box;            /* per chunk */
} MeshJob;

static void mesh_chunk(void *ctx, int c, int worker)
{
    (void)worker;
    const MeshJob *job = ctx;
    const Vec3 *verts = job->verts;
    const int(*faces)[3] = job->faces;
    int i0 = c * job->chunk, n = job->n - i0 > job->chunk ? i0 + job->chunk : job->n;
    /* group_finish's fold, bbox_union in child order, written out: min/max by the same
     * compares (v3_min/v3_max), so the box is the same to the bit. */
    BBox box = bbox_empty();
    for (int i = i0; i < n; i++) {
        Triangle *t = &job->tris[i];
        /* Faces index the vertex array out of order: ask for the vertices of a face a
         * few iterations ahead (measured: ~0.2 ms of 2 on the 40k bunny). */
        if (i + 16 < n) {
            __builtin_prefetch(&verts[faces[i + 16][0]]);
            __builtin_prefetch(&verts[faces[i + 16][1]]);
            __builtin_prefetch(&verts[faces[i + 16][2]]);
        }
        Vec3 v0 = verts[faces[i][0]], v1 = verts[faces[i][1]], v2 = verts[faces[i][2]];
        if (job->clear)
            memset(t, 0, sizeof *t);
        triangle_init(t, v0, v1, v2, job->m);
        job->g->children[i] = &t->base;
        box.min = v3_min(box.min, t->base.bbox.min);
        box.max = v3_max(box.max, t->base.bbox.max);
    }
    job->box[c] = box;
}

Object3D *triangle_mesh_new_in(Arena *a, void *block, const Vec3 *verts,
                               const int (*faces)[3], int n, const Material *m)
{
    if (n <= 0 || (size_t)n > SIZE_MAX / 2 / (sizeof(Triangle) + sizeof(Object3D *))) {
        arena_buffer_free(block);
        return n == 0 ? group_new(a, 0) : NULL;
    }
    /* The Group first (small: from the arena's current block), then one block for the
     * triangles and, behind them, the Group's children: a children array of its own
     * (320 KB for 40k triangles) was a mapping of its own, with a 2 MB page zeroed for
     * it, while the triangles' block ends in a page that is mostly unused. */
    Object3D *go = group_new_with(a, n, NULL);
    if (!go) {
        arena_buffer_free(block);
        return NULL;
    }
    /* The children start right behind the triangles: aligned for any n. */
    _Static_assert(sizeof(Triangle) % _Alignof(Object3D *) == 0, "children aligned");
    size_t tri_bytes = (size_t)n * sizeof(Triangle);
    size_t bytes = tri_bytes + (size_t)n * sizeof(Object3D *);
    /* An adopted block may hold old bytes (the OBJ text): every triangle is then
     * cleared before it is filled, so padding is zero as from arena_calloc (every child
     * pointer is written). */
    bool zeroed = true;
    char *mem = block ? arena_adopt_buffer(a, block, bytes, &zeroed) : arena_calloc(a, 1, bytes);
    if (!mem)
        return NULL;
    Triangle *tris = (Triangle *)(void *)mem;
    ((Group *)go)->children = (Object3D **)(void *)(mem + tri_bytes);
    int nchunks = par_threads() > 1 ? n / MESH_CHUNK + (n % MESH_CHUNK != 0) : 1;
    BBox one;
    MeshJob job = {tris, verts, faces, n, n, m, !zeroed, (Group *)go, &one};
    if (nchunks > 1) {
        job.box = malloc((size_t)nchunks * sizeof *job.box);
        job.chunk = MESH_CHUNK;
    }
    if (!job.box) {
        job.box = &one;
        job.chunk = n;
        nchunks = 1;
    }
    par_for(nchunks, mesh_chunk, &job);
    BBox box = job.box[0];
    for (int c = 1; c < nchunks; c++) {
        box.min = v3_min(box.min, job.box[c].min);
        box.max = v3_max(box.max, job.box[c].max);
    }
    if (job.box != &one)
        free(job.box);
    Group *g = (Group *)go;
    g->base.bbox = box;
    g->base.bounded = n > 0;
    return go;
}
