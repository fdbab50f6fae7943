/* Recording of one traced ray tree and the grid cells it visited, for the GUI `t` key
 * (course RayTree). Recording happens only when RenderCtx.tree is non-NULL. */
#ifndef RT_RAY_TREE_H
#define RT_RAY_TREE_H

#include <stdbool.h>

#include "rt/vec.h"
#include "rt/ray.h"

enum { RT_RAYTREE_MAX_SEGMENTS = 1024, RT_RAYTREE_MAX_CELLS = 8192 };

typedef enum RaySegKind {
    RAYSEG_MAIN,        /* gray in the preview */
    RAYSEG_SHADOW,      /* green */
    RAYSEG_REFLECTED,   /* red */
    RAYSEG_TRANSMITTED  /* blue */
} RaySegKind;

typedef struct RaySegment {
    RaySegKind kind;
    Vec3 a, b;          /* world-space end points; t clamped to [-100, 100] */
} RaySegment;

typedef struct RayTreeCell {
    int i, j, k;
    Vec3 entered_normal; /* normal of the face the ray entered through (0 if started inside) */
} RayTreeCell;

typedef struct RayTree {
    int num_segments;
    int dropped;        /* segments that came when the tree was full (not kept) */
    RaySegment segments[RT_RAYTREE_MAX_SEGMENTS];
    int num_cells;
    RayTreeCell cells[RT_RAYTREE_MAX_CELLS];
} RayTree;

void ray_tree_clear(RayTree *t);
/* Adds the segment ray(t0)..ray(t1); when the tree is full, counts it in dropped
 * instead. The tracer spawns no reflected or refracted ray into a full tree (a deep
 * pixel's tree would otherwise take as long as rendering it all). */
void ray_tree_add_segment(RayTree *t, RaySegKind kind, const Ray *ray, float t0, float t1);
void ray_tree_add_cell(RayTree *t, int i, int j, int k, Vec3 entered_normal);
static inline bool ray_tree_full(const RayTree *t)
{
    return t->num_segments >= RT_RAYTREE_MAX_SEGMENTS;
}

#endif
