/* -gui_snapshot: one preview frame drawn into an OSMesa offscreen buffer, after the
 * -gui_keys script, written with image_write. No X server needed. */
#include "rt/preview.h"

#ifdef RT_HAVE_OSMESA
#include <GL/osmesa.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "rt/diag.h"
#include "draw.h"
#include "rt/render.h"
#include "view.h"
#include "dynload.h"

bool preview_snapshot_built(void) { return true; }

static GlProc osmesa_proc(const char *name) { return (GlProc)OSMesaGetProcAddress(name); }

typedef struct Snapshot {
    const PreviewConfig *cfg;
    Diag *diag;
    GlApi gl;
    PreviewView view;
    PreviewTraced traced;
    bool have_traced;
    int w, h;
    Image frame;
    unsigned char *scratch;
} Snapshot;

static void traced_free(Snapshot *s)
{
    if (s->have_traced) {
        image_free(&s->traced.image);
        free((void *)s->traced.row_ready);
        s->have_traced = false;
    }
}

/* The exit status of a snapshot stopped by a signal, after saying so; 0 while none
 * came. Checked before each step: a step (drawing a finely tessellated scene, a
 * render) is not cut short, but nothing is written after the signal. */
static int snapshot_stopped(const Snapshot *s)
{
    int sig = s->cfg->stop ? *s->cfg->stop : 0;
    if (sig)
        fprintf(stderr, "%s: interrupted; no image written\n", diag_program());
    return sig ? 128 + sig : 0;
}

/* `r`: ray-trace the current view into the frame, then the requested files. */
static int snapshot_render(Snapshot *s)
{
    traced_free(s);
    if (!image_init(&s->traced.image, s->w, s->h)) {
        diag_error(s->diag, NULL, "out of memory for the traced preview");
        return 1;
    }
    s->traced.row_ready = calloc((size_t)s->h, sizeof *s->traced.row_ready);
    if (!s->traced.row_ready) {
        image_free(&s->traced.image);
        diag_error(s->diag, NULL, "out of memory for the traced preview");
        return 1;
    }
    s->have_traced = true;
    RenderTarget target;
    memset(&target, 0, sizeof target);
    target.width = s->w;
    target.height = s->h;
    target.color = &s->traced.image;
    if (!render_image(s->cfg->tracer, &s->view.camera, &target, s->cfg->threads, NULL, NULL,
                      NULL, s->cfg->stop)) {
        int stopped = snapshot_stopped(s);
        if (stopped)
            return stopped;
        diag_error(s->diag, NULL, "could not start the render (out of memory?)");
        return 1;
    }
    for (int y = 0; y < s->h; y++)
        atomic_store(&s->traced.row_ready[y], 1);
    if (s->cfg->render)
        return s->cfg->render(s->cfg->render_user, &s->view.camera, NULL);
    return 0;
}

/* Draws the frame and writes it to path: 0, 1 when it cannot be written, or the
 * status of a signal that came while it was drawn (nothing written). */
static int snapshot_write(Snapshot *s, const char *path)
{
    preview_draw_frame(&s->gl, &s->view, s->w, s->h, s->have_traced ? &s->traced : NULL);
    preview_read_frame(&s->gl, s->w, s->h, &s->frame, s->scratch);
    int stopped = snapshot_stopped(s);
    if (stopped)
        return stopped;
    return image_write(&s->frame, path, s->diag) ? 0 : 1;
}

static int snapshot_run(Snapshot *s, const KeyScript *script)
{
    for (int k = 0; k < script->count; k++) {
        const KeyCmd *cmd = &script->cmds[k];
        int stopped = snapshot_stopped(s);
        if (stopped)
            return stopped;
        bool ok;
        if (preview_view_apply(&s->view, cmd, s->w, s->h, &ok)) {
            if (!ok) {
                diag_error(s->diag, NULL, "out of memory tracing the ray tree");
                return 1;
            }
            /* Whatever changes the view hides the traced picture, as in the window. */
            traced_free(s);
            continue;
        }
        if (cmd->kind == KEYCMD_QUIT)
            break;
        if (cmd->kind == KEYCMD_SHOT) {
            int status = snapshot_write(s, cmd->path);
            if (status)
                return status;
            continue;
        }
        int status = snapshot_render(s);
        if (status)
            return status;
    }
    int stopped = snapshot_stopped(s);
    if (stopped)
        return stopped;
    return snapshot_write(s, s->cfg->snapshot_path);
}

/* GL clamps a viewport to GL_MAX_VIEWPORT_DIMS (16384 in Mesa): a wider or taller
 * -size drew the frame squeezed into the buffer's first 16384 columns or rows and left
 * the rest background, without a word. Said instead, before anything is drawn. */
static bool fits_viewport(const GlApi *gl, int w, int h, Diag *diag)
{
    GLint dims[2] = {0, 0};
    gl->GetIntegerv(GL_MAX_VIEWPORT_DIMS, dims);
    if (dims[0] > 0 && dims[1] > 0 && (w > dims[0] || h > dims[1])) {
        diag_error(diag, NULL, "-gui_snapshot: -size %d %d is larger than OpenGL can draw "
                   "here (at most %d x %d): give a smaller -size", w, h, (int)dims[0],
                   (int)dims[1]);
        return false;
    }
    return true;
}

int preview_snapshot(const PreviewConfig *cfg, Diag *diag)
{
    KeyScript script;
    if (!preview_keys_parse(cfg->keys, &script, diag))
        return 2;
    if (!preview_keys_check(&script, cfg->width, cfg->height, "image", diag)) {
        preview_keys_free(&script);
        return 2;
    }
    if (!preview_keys_outputs_ok(&script, diag)) {
        preview_keys_free(&script);
        return 1;
    }
    if (!preview_load_osmesa_libs(diag)) {
        preview_keys_free(&script);
        return 1;
    }
    Snapshot s;
    memset(&s, 0, sizeof s);
    s.cfg = cfg;
    s.diag = diag;
    s.w = cfg->width;
    s.h = cfg->height;
    int status = 1;
    OSMesaContext ctx = OSMesaCreateContextExt(OSMESA_RGBA, 24, 0, 0, NULL);
    unsigned char *buffer = malloc((size_t)s.w * (size_t)s.h * 4);
    s.scratch = malloc((size_t)s.w * (size_t)s.h * 3);
    const char *missing = NULL;
    if (!ctx) {
        diag_error(diag, NULL, "OSMesa could not create an offscreen GL context");
    } else if (!buffer || !s.scratch || !image_init(&s.frame, s.w, s.h)) {
        diag_error(diag, NULL, "out of memory for a %d x %d snapshot", s.w, s.h);
    } else if (!OSMesaMakeCurrent(ctx, buffer, GL_UNSIGNED_BYTE, s.w, s.h)) {
        diag_error(diag, NULL, "OSMesa cannot draw a %d x %d buffer", s.w, s.h);
    } else if (!gl_api_load(&s.gl, osmesa_proc, &missing)) {
        diag_error(diag, NULL, "OSMesa lacks the GL function %s", missing);
    } else if (!fits_viewport(&s.gl, s.w, s.h, diag)) {
        status = 2;
    } else if (preview_view_init(&s.view, cfg, diag)) {
        status = snapshot_run(&s, &script);
        preview_view_free(&s.view);
    }
    traced_free(&s);
    image_free(&s.frame);
    if (ctx)
        OSMesaDestroyContext(ctx);
    free(buffer);
    free(s.scratch);
    preview_keys_free(&script);
    return status;
}

#else /* !RT_HAVE_OSMESA */

bool preview_snapshot_built(void) { return false; }

int preview_snapshot(const PreviewConfig *cfg, Diag *diag)
{
    (void)cfg;
    diag_error(diag, NULL,
               "-gui_snapshot is not built in: %s", preview_remedy(false));
    return 2;
}

#endif
