/* Scene: everything one scene file describes, owned by one arena. */
#ifndef RT_SCENE_H
#define RT_SCENE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "rt/arena.h"
#include "rt/camera.h"
#include "rt/diag.h"
#include "rt/light.h"
#include "rt/material.h"
#include "rt/object3d.h"
#include "rt/setup_cache.h"

/* The files a scene load reads (the scene file and its OBJ files), by the path the
 * loader tried. A recording set reads from disk and keeps a copy of each file and of
 * each failed read; a replaying set (scene_files_new(false), scene_files_unpack)
 * serves only what it holds, so another process builds the very same scene without
 * the files (raytracer-mpi: rank 0 records and broadcasts, the others replay). */
typedef struct SceneFiles SceneFiles;

/* A run of consecutive leaf ids made by one object keyword of the file (a Sphere: one
 * leaf; a TriangleMesh: all its triangles), and where that keyword stands. */
typedef struct SceneLeafRun {
    uint32_t first;             /* id of its first leaf */
    int line, col;
} SceneLeafRun;

typedef struct Scene {
    Arena arena;                /* owns everything below */
    const char *path;           /* the file as given */
    bool has_camera;
    int end_line, end_col;      /* where the text ends: a missing camera or Group is
                                   reported there (0: not parsed) */
    int lights_line, lights_col; /* the Lights keyword (0: none in the file) */
    Camera camera;
    Vec3 background;            /* default (0.5, 0.5, 0.5) */
    Vec3 ambient;               /* default 0; (1,1,1) when there are no lights */
    int num_lights;
    Light *lights;
    int num_materials;
    Material **materials;
    Object3D *root;             /* the Group; NULL when the file has none */
    uint32_t num_primitives;    /* leaves, ids 0..n-1 (group_assign_ids) */
    BBox bounds;                /* root's box; empty when nothing is bounded */
    bool no_lights;             /* the zero-lights rule fired (scene_warn_no_lights) */
    SceneFiles *files;          /* while loading: where files come from (NULL: the disk) */
    SetupCache *cache;          /* while loading: meshes from and for -cache (NULL: none) */
    bool identify;              /* while loading: key the inputs even without a cache */
    SetupKey inputs;            /* with a cache or identify: the hash of every file the
                                   load read (the scene text, then each OBJ file's bytes),
                                   in order; the same with or without the cache */
    /* Where each leaf was written, for messages about one leaf (scene_leaf_loc): leaf ids
     * are depth-first, i.e. file order, so runs in file order, by first id (malloc'd). */
    SceneLeafRun *leaf_runs;
    uint32_t num_leaf_runs, cap_leaf_runs;
    uint32_t leaves_parsed;     /* while loading: leaves made so far */
} Scene;

/* The scene path that means standard input (-input -). */
#define SCENE_STDIN "-"

/* The location in s->path of the keyword that made leaf id (a TriangleMesh for each of
 * its triangles); false (loc then names the file alone) when unknown. */
bool scene_leaf_loc(const Scene *s, uint32_t id, SrcLoc *loc);

/* Parses path (docs/scene-format.md). On error reports a located message to diag and
 * returns NULL with nothing leaked. obj_file names resolve against the scene file's
 * folder first, then the working directory. SCENE_STDIN reads standard input (named
 * "<stdin>" in messages; obj_file names then resolve in the working directory). */
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

/* Whether s can be rendered: it has a camera and a Group. A scene may parse without
 * them (the parser's tests, -render_filter alone needs none), so the program asks
 * this before it renders; false after reporting what is missing at the place where
 * the text ends. */
bool scene_check_renderable(const Scene *s, Diag *diag);

/* With the course's zero-lights rule in force (s->no_lights), the warning that says so,
 * at the Lights block (numLights 0) or, without one, where the text ends. */
void scene_warn_no_lights(const Scene *s, Diag *diag);

/* scene_load reading every file through files (NULL: the disk, as scene_load). */
Scene *scene_load_from(const char *path, SceneFiles *files, Diag *diag);

/* The same with the set-up cache (rt/setup_cache.h; NULL: none): OBJ files whose bytes
 * the cache knows are not parsed again, the others are added to it, and Scene.inputs
 * keys what is built from the scene. Same scene either way. identify: Scene.inputs is
 * computed without a cache too (a part image's render identity, rt/image.h); it costs
 * a pass over each file's bytes, so only renders that record it ask for it. */
Scene *scene_load_with(const char *path, SceneFiles *files, SetupCache *cache, bool identify,
                       Diag *diag);

SceneFiles *scene_files_new(bool record);
void scene_files_free(SceneFiles *f);   /* NULL allowed */
/* One file through the set (NULL: straight from the disk): a malloc'd buffer, or an
 * arena buffer when reusable (rt/arena.h), NUL-terminated. False with errno set. */
bool scene_files_read(SceneFiles *f, const char *path, bool reusable, char **out,
                      size_t *len);
/* The set as one malloc'd block, and back (NULL when malformed or out of memory). */
bool scene_files_pack(const SceneFiles *f, uint8_t **out, size_t *len);
SceneFiles *scene_files_unpack(const uint8_t *data, size_t len);

#endif
