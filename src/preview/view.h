/* The preview's state without any GL: the moved camera, the mouse controls of the
 * course GLCanvas (docs/preview.md), the traced ray tree, the grid display mode and the
 * -gui_keys script. Shared by the GLUT window and the OSMesa snapshot. */
#ifndef RT_PREVIEW_VIEW_H
#define RT_PREVIEW_VIEW_H

#include <stdbool.h>
#include <stdio.h>
#include "rt/camera.h"
#include "rt/diag.h"
#include "rt/grid.h"
#include "rt/preview.h"
#include "rt/ray_tree.h"

/* What is drawn; `g` cycles OBJECTS -> GRID -> GRID_RAY -> OBJECTS when a grid exists. */
typedef enum PreviewMode {
    PREVIEW_OBJECTS,    /* the scene's objects */
    PREVIEW_GRID,       /* occupied cells; cells the last traced ray visited outlined */
    PREVIEW_GRID_RAY    /* only the visited cells, with the faces the ray entered through */
} PreviewMode;

typedef struct PreviewView {
    const PreviewConfig *cfg;
    Camera camera;          /* the moved copy of the scene's camera */
    Vec3 world_up;          /* yaw axis and pole of the tilt clamp */
    Vec3 pivot;             /* rotation centre: centre of the scene's bounding box */
    PreviewMode mode;
    bool has_tree;          /* a `t` trace happened */
    RayTree *tree;          /* heap (large) */
} PreviewView;

/* False (reported to diag) when out of memory. */
bool preview_view_init(PreviewView *v, const PreviewConfig *cfg, Diag *diag);
void preview_view_free(PreviewView *v);
/* The grid g and -visualize_grid show: the uniform grid, or the two-level grid's top
 * level; NULL without either. */
const Grid *preview_view_grid(const PreviewView *v);

/* Mouse drags in window pixels (dx right, dy DOWN, like the mouse), as the course GLCanvas:
 * rotate 0.005 rad/pixel about the pivot (tilt kept away from the poles), truck 0.05
 * units/pixel across the view, dolly 0.05 units/pixel along it. */
void preview_view_rotate(PreviewView *v, float dx, float dy);
void preview_view_truck(PreviewView *v, float dx, float dy);
void preview_view_dolly(PreviewView *v, float dx);

/* Traces the ray tree of pixel (i, j), j from the BOTTOM, of a w x h view (the render
 * loop's pixel -> screen mapping). False when the tracer context cannot be allocated. */
bool preview_view_trace(PreviewView *v, int i, int j, int w, int h);
/* `g`: next display mode; prints a hint to out and stays when there is no grid. */
void preview_view_cycle_grid(PreviewView *v, FILE *out);
/* `c`: the current camera as a scene-file block. */
void preview_view_print_camera(const PreviewView *v, FILE *out);

/* -gui_keys: whitespace-separated commands (docs/preview.md). */
typedef enum KeyCmdKind {
    KEYCMD_RENDER,      /* r */
    KEYCMD_TRACE,       /* t (view centre) or t:I,J */
    KEYCMD_GRID,        /* g */
    KEYCMD_CAMERA,      /* c */
    KEYCMD_ROTATE,      /* rot:DX,DY */
    KEYCMD_TRUCK,       /* truck:DX,DY */
    KEYCMD_DOLLY,       /* dolly:D */
    KEYCMD_SHOT,        /* shot:FILE */
    KEYCMD_QUIT         /* q */
} KeyCmdKind;

typedef struct KeyCmd {
    KeyCmdKind kind;
    bool has_pixel;     /* t:I,J given */
    int i, j;
    float a, b;         /* drag amounts */
    char *path;         /* shot:FILE, malloc'd */
} KeyCmd;

typedef struct KeyScript {
    int count;
    KeyCmd *cmds;
} KeyScript;

/* Parses text (NULL = empty script). On error reports "-gui_keys: ..." to diag and
 * returns false with nothing allocated. */
bool preview_keys_parse(const char *text, KeyScript *out, Diag *diag);
/* Every t:I,J of the script names a pixel of the w x h view (`what`: "image" for
 * -gui_snapshot, whose view is -size; "window" for -gui, whose window is the course's
 * 400 pixels on its long side): false, with "-gui_keys: ..." reported, for the first
 * that does not. */
bool preview_keys_check(const KeyScript *s, int w, int h, const char *what, Diag *diag);
/* Every shot:FILE of the script can be written (image_check_output: its format, its
 * folder): false, with the reason reported, for the first that cannot. Checked before
 * anything is drawn, so that a script failing on its last shot has not already written
 * its r render's images (exit status 1 with some images written). */
bool preview_keys_outputs_ok(const KeyScript *s, Diag *diag);
void preview_keys_free(KeyScript *s);

/* Applies the backend-independent commands (t, g, c, rot, truck, dolly) for a w x h
 * view; returns false for r, shot and q, which the backend handles. *ok is set false
 * when a trace could not allocate its context. */
bool preview_view_apply(PreviewView *v, const KeyCmd *cmd, int w, int h, bool *ok);

#endif
