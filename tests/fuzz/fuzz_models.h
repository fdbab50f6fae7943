/* The small OBJ models the scene and keys fuzz targets load: written once into a fresh
 * temporary folder, under the names the course and project scenes use, so the seed
 * scenes find a (tiny) mesh wherever they look: <dir>/scenes is the scene's folder,
 * <dir>/models holds the project's "../models/NAME.obj". The process works inside
 * <dir>/scenes, so obj_file never reaches outside the folder by a relative name. The
 * folder is removed when the process exits (fuzz_tmp.h). */
#ifndef RT_FUZZ_MODELS_H
#define RT_FUZZ_MODELS_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "fuzz_tmp.h"

static const char fuzz_cube_obj[] =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 4 8 7\nf 4 7 3\n"
    "f 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n";
static const char fuzz_tetra_obj[] =
    "# a tetrahedron\nv 0 1 0\nv -1 -1 1\nv 1 -1 1\nv 0 -1 -1\n"
    "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";
static const char fuzz_quad_obj[] = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf -4 -3 -2\n";

static const char *const fuzz_scene_models[] = {
    "cube.obj", "bunny_200.obj", "bunny_1k.obj", "bunny_5k.obj", "bunny_40k.obj",
    "6.837.obj", "diamond.obj", "vase.obj", "m.obj",
};
static const char *const fuzz_project_models[] = {
    "ground.obj", "icosahedron.obj", "icosphere.obj", "tex_cube.obj", "torus.obj", "vase.obj",
};

static inline int fuzz_write_text(const char *dir, const char *name, const char *text)
{
    char path[8200];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    fputs(text, f);
    return fclose(f);
}

/* Makes the folder (fuzz_tmp_dir: removed at exit) and enters <dir>/scenes; returns
 * that folder (static storage) or NULL. */
static inline const char *fuzz_models_setup(void)
{
    static char scenes[4096];
    if (scenes[0])
        return scenes;
    const char *dir = fuzz_tmp_dir();
    if (!dir)
        return NULL;
    char models[4096];
    snprintf(scenes, sizeof scenes, "%s/scenes", dir);
    snprintf(models, sizeof models, "%s/models", dir);
    if (mkdir(scenes, 0700) != 0 || mkdir(models, 0700) != 0)
        return NULL;
    const char *texts[3] = {fuzz_cube_obj, fuzz_tetra_obj, fuzz_quad_obj};
    for (size_t i = 0; i < sizeof fuzz_scene_models / sizeof *fuzz_scene_models; i++)
        fuzz_write_text(scenes, fuzz_scene_models[i], texts[i % 3]);
    for (size_t i = 0; i < sizeof fuzz_project_models / sizeof *fuzz_project_models; i++)
        fuzz_write_text(models, fuzz_project_models[i], texts[(i + 1) % 3]);
    if (chdir(scenes) != 0)
        return NULL;
    return scenes;
}

#endif
