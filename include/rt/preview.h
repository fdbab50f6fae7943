/* The OpenGL preview (A3-A5 GLCanvas): a GLUT window (-gui) and the same drawing into
 * an OSMesa offscreen buffer (-gui_snapshot). Built only when the libraries exist;
 * otherwise the functions report how to enable them and return exit status 2. */
#ifndef RT_PREVIEW_H
#define RT_PREVIEW_H

#include <stdbool.h>
#include <stdio.h>
#include "rt/raytracer.h"

/* Full render of the requested files with the (possibly moved) camera: the `r` key.
 * cancel: the window's stop flag (q, a moved camera: the render stops within a tile and
 * nothing is written, status 0), or NULL for the program's own (signals). Returns an
 * exit status (0 ok). */
typedef int (*PreviewRenderFn)(void *user, const Camera *camera, volatile int *cancel);

typedef struct PreviewConfig {
    const Scene *scene;
    const RayTracer *tracer;    /* its grid may be NULL */
    int width, height;          /* -size: the ray-traced view */
    int tess_theta, tess_phi;
    bool gouraud;
    bool visualize_grid;        /* start in grid view */
    int threads;
    PreviewRenderFn render;     /* may be NULL */
    void *render_user;
    const char *snapshot_path;  /* -gui_snapshot */
    const char *keys;           /* -gui_keys script, may be NULL */
    /* The program's stop flag (the signal that asked it to stop: SIGINT, SIGTERM,
     * SIGHUP), or NULL. Once set, the window closes and the snapshot writes nothing
     * more; either prints why on stderr and returns 128 + the signal. */
    volatile int *stop;
    /* Where the keys' lines go (the c key's camera block, t's and g's lines, r's
     * "Rendering scene..."): stdout, or stderr when an image goes to standard output
     * (-gui_snapshot -, -output -, shot:-), which then carries the image alone, as it
     * does the -stats block. NULL: stdout. */
    FILE *messages;
} PreviewConfig;

bool preview_window_built(void);
bool preview_snapshot_built(void);
/* What a user does to get a preview this build lacks: the packages to install and
 * rebuild, or, in a build made without the preview on purpose (PREVIEW=0, as
 * raytracer-static is), the binary to use instead. One phrase, no full stop. */
const char *preview_remedy(bool window);
/* Opens the window; returns the exit status when the user quits. */
int preview_run_window(const PreviewConfig *cfg, Diag *diag);
/* Draws one frame (after the scripted keys) offscreen and writes snapshot_path. */
int preview_snapshot(const PreviewConfig *cfg, Diag *diag);
/* The -gui_keys script checked before the scene is read, as the other outputs are: 0
 * when every command is well formed and every shot:FILE can be written; 2 (a usage
 * error, "-gui_keys: ..." reported) for a bad command or a shot:FILE without a known
 * image extension; 1 for a shot:FILE that cannot be written (a missing folder). */
int preview_keys_validate(const char *keys, Diag *diag);
/* Whether the -gui_keys script (NULL: none) is well formed and has an r command: with
 * -gui_snapshot only r renders the images and the statistics asked for. */
bool preview_keys_render(const char *keys);
/* Whether the script has a shot:- (the frame to standard output). */
bool preview_keys_shot_stdout(const char *keys);
/* cfg->messages, or stdout when it is NULL. */
FILE *preview_messages(const PreviewConfig *cfg);

#endif
