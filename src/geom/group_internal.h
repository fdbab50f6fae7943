/* Private to src/geom: the Group layout, shared by group.c and mesh.c (which fills a
 * mesh's Group and its box in the pass that builds the triangles). */
#ifndef RT_GEOM_GROUP_INTERNAL_H
#define RT_GEOM_GROUP_INTERNAL_H

#include "rt/object3d.h"

typedef struct Group {
    Object3D base;
    int count;
    Object3D **children;
} Group;

/* group_new with its children array given (capacity entries, filled by the caller; it
 * may set children later, before any use): mesh.c puts the array in the triangles'
 * block. NULL when out of memory. */
Object3D *group_new_with(Arena *a, int capacity, Object3D **children);

#endif
