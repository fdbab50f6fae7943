/* Scene: everything one scene file describes, owned by one arena. */
#ifndef RT_SCENE_H
#define RT_SCENE_H

#include <stdbool.h>
#include "rt/arena.h"
#include "rt/camera.h"
#include "rt/diag.h"
#include "rt/light.h"
#include "rt/material.h"
#include "rt/object3d.h"

typedef struct Scene {
    Arena arena;                /* owns everything below */
    const char *path;           /* the file as given */
    bool has_camera;
    Camera camera;
    Vec3 background;            /* default (0.5, 0.5, 0.5) */
    Vec3 ambient;               /* default 0; (1,1,1) when there are no lights */
    int num_lights;
    Light *lights;
    int num_materials;
    Material **materials;
    Object3D *root;             /* the Group; NULL when the file has none */
    uint32_t num_primitives;    /* leaves, ids 0..n-1 (object_assign_ids) */
    BBox bounds;                /* root's box; empty when nothing is bounded */
    bool no_lights;             /* the zero-lights rule fired (WARNING printed by main) */
} Scene;

/* Parses path (scene-format.md). On error reports a located message to diag and
 * returns NULL with nothing leaked. obj_file names resolve against the scene file's
 * folder first, then the working directory. */
Scene *scene_load(const char *path, Diag *diag);
/* The same from a string (tests); name is used in messages and base_dir for obj_file
 * (NULL = working directory only). */
Scene *scene_load_string(const char *text, const char *name, const char *base_dir,
                         Diag *diag);
/* The same from len bytes of buf, which may hold any bytes (NUL included; it need not
 * be NUL-terminated): the fuzz target's entry. */
Scene *scene_load_buffer(const char *buf, size_t len, const char *name, const char *base_dir,
                         Diag *diag);
void scene_free(Scene *s);

#endif
