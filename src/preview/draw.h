/* Fixed-function GL drawing of one preview frame (course GLCanvas::display): the scene
 * or the grid, the last ray tree and a (partly) ray-traced picture over it. No GLUT:
 * the same code draws into the window and into the OSMesa buffer. */
#ifndef RT_PREVIEW_DRAW_H
#define RT_PREVIEW_DRAW_H

#include <stdatomic.h>
#include "gl_api.h"
#include "rt/image.h"
#include "view.h"

/* A ray-traced picture filled row by row by render workers (the `r` key). */
typedef struct PreviewTraced {
    Image image;                    /* the view's size */
    _Atomic unsigned char *row_ready; /* one flag per row, set after the row is final */
} PreviewTraced;

/* Draws the frame into the current context's w x h buffer. traced may be NULL; only
 * its finished rows are drawn (and only when its size is w x h). */
void preview_draw_frame(const GlApi *gl, const PreviewView *v, int w, int h,
                        const PreviewTraced *traced);

/* Reads the current w x h colour buffer (bottom row first, like Image) into img,
 * which must be allocated at that size; each byte b becomes (b + 0.5) / 255 so the
 * writer's quantisation gives b back. */
void preview_read_frame(const GlApi *gl, int w, int h, Image *img, unsigned char *scratch);

#endif
