/* Recording of one traced ray tree and the grid cells it visited, for the GUI `t` key
 * (course RayTree). Recording happens only when RenderCtx.tree is non-NULL. */
#ifndef RT_RAY_TREE_H
#define RT_RAY_TREE_H

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
    RaySegment segments[RT_RAYTREE_MAX_SEGMENTS];
    int num_cells;
    RayTreeCell cells[RT_RAYTREE_MAX_CELLS];
} RayTree;

void ray_tree_clear(RayTree *t);
/* Adds the segment ray(t0)..ray(t1); silently drops it when the tree is full. */
void ray_tree_add_segment(RayTree *t, RaySegKind kind, const Ray *ray, float t0, float t1);
void ray_tree_add_cell(RayTree *t, int i, int j, int k, Vec3 entered_normal);

#endif
