/* Private to src/scene: the OBJ reader behind TriangleMesh (docs/scene-format.md).
 * Line-oriented; v and f records only, everything else ignored. Its functions are
 * objfile_*: the prefix obj_ belongs to Object3D (rt/object3d.h). */
#ifndef RT_SCENE_OBJ_LOADER_H
#define RT_SCENE_OBJ_LOADER_H

#include <stdbool.h>
#include <stddef.h>
#include "rt/diag.h"
#include "rt/object3d.h"
#include "rt/vec.h"

typedef struct ObjMesh {
    Vec3 *verts;        /* rt/bigmem.h memory; nverts entries */
    int nverts;
    int (*tris)[3];     /* rt/bigmem.h memory; 0-based vertex indices, ntris entries */
    int ntris;
} ObjMesh;

/* Parses an OBJ text of len bytes; buf[len] must be '\0' (file_read_all, rt/file.h,
 * provides it: the scanners use it as the end sentinel). name is used in located
 * messages. Faces with n > 3 vertices become the fan (v0, vi, vi+1); negative
 * indices count back from the last vertex read so far. False after reporting an error,
 * or with nothing reported when a stop was requested (par_stop_requested, rt/par.h:
 * looked at every so many lines); nothing is left allocated either way. */
bool objfile_parse(const char *buf, size_t len, const char *name, ObjMesh *out, Diag *diag);
void objfile_mesh_free(ObjMesh *m);
/* Whether the text has a CR followed by anything but LF (classic Mac OS line ends),
 * which ends no line for objfile_parse: a file of them that begins with a comment
 * reads as that one comment, with no faces. */
bool objfile_has_lone_cr(const char *buf, size_t len);
/* Said where a record runs on after such a CR, and when such a file has no faces. */
#define OBJ_LONE_CR_HINT "a lone CR ends no line: give the file LF or CR LF line ends"
/* For tests: how many files objfile_parse has read in parallel pieces so far (the
 * others went through the serial reader). */
unsigned long objfile_pieces_read(void);
/* For tests: how many v and f records the general readers (read_vertex, read_face) have
 * taken so far; the common forms go through the quick ones (read_vertex_simple,
 * read_face_simple), about half the instructions a record. */
unsigned long objfile_general_records(void);

/* A Group of one Triangle per face, all with material m, from arena a. block: NULL, or
 * the file's arena buffer (file_read_reusable), no longer needed, which is taken over
 * (triangle_mesh_new_in) in every case. NULL when out of memory. */
Object3D *objfile_build_group(Arena *a, const ObjMesh *mesh, const Material *m, void *block);

/* The float conversion used for OBJ numbers: exactly strtof's result, with a fast path
 * for short decimals. *p advances past the number; false if none starts at *p. The text
 * must be NUL-terminated at or before end. */
bool objfile_parse_float(const char **p, const char *end, float *out);

#endif
