/* Fuzz target: the OBJ reader behind TriangleMesh on raw bytes, then the mesh built as
 * the parser builds it. */
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "../../src/scene/obj_loader.h"
#include "rt/arena.h"
#include "rt/material.h"

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    return 0;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* objfile_parse wants buf[len] == '\0' (file_read_all's contract). */
    char *buf = malloc(size + 1);
    if (!buf)
        return 0;
    memcpy(buf, data, size);
    buf[size] = '\0';
    Diag d;
    diag_init(&d, NULL);
    ObjMesh mesh;
    if (objfile_parse(buf, size, "fuzz.obj", &mesh, &d)) {
        Arena a;
        arena_init(&a);
        PhongParams p = phong_defaults();
        const Material *m = phong_new(&a, &p);
        if (m)
            objfile_build_group(&a, &mesh, m, NULL);
        objfile_mesh_free(&mesh);
        arena_free(&a);
    }
    free(buf);
    return 0;
}
