/* -gui: the course GLCanvas as a freeglut window: mouse camera controls, `r` traces
 * the view into the window progressively on a background thread, `t` ray tree, `g`
 * grid display, `c` camera block, `q`/Esc quit; -gui_keys runs the same keys from a
 * script (then `shot:FILE` saves the window). */
#include "rt/preview.h"

#ifdef RT_HAVE_GLUT
#include <GL/freeglut.h>
#include <GL/glx.h>
#include <X11/Xlib.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include "rt/diag.h"
#include "draw.h"
#include "rt/render.h"
#include "view.h"
#include "dynload.h"

bool preview_window_built(void) { return true; }

/* The course window is 400 x 400; other -size shapes keep their aspect. */
#define WINDOW_LONG_SIDE 400
#define RENDER_POLL_MS 40
#define SCRIPT_STEP_MS 60
/* How often the window is checked for having been destroyed by another client. */
#define WATCH_MS 50

/* GLUT callbacks carry no user pointer: the one window's state. */
static struct PreviewWindow {
    const PreviewConfig *cfg;
    Diag *diag;
    GlApi gl;
    PreviewView view;
    int win;
    int w, h;
    int status;
    /* mouse */
    int button;             /* GLUT_*_BUTTON held, -1 none */
    int mouse_x, mouse_y;   /* last position, window coordinates (y down) */
    /* the `r` render */
    PreviewTraced traced;
    bool have_traced;
    bool thread_running;
    pthread_t thread;
    Camera render_camera;
    volatile int cancel;
    atomic_int rows_done;
    atomic_int thread_done;
    atomic_int thread_status;
    int rows_shown;
    /* -gui_keys */
    KeyScript script;
    int script_pos;
    /* A second X connection that hears of the window's destruction (DestroyNotify):
     * freeglut ignores that event, and would run on without a window. */
    Display *watch;
    Window xwin;
    volatile int destroyed;   /* the window is gone: X errors about it are expected */
    int stopped;              /* the signal that closed the window (cfg->stop), or 0 */
} W;

static GlProc glut_proc(const char *name) { return (GlProc)glutGetProcAddress(name); }

static void render_row_done(void *user, int y)
{
    (void)user;
    atomic_store_explicit(&W.traced.row_ready[y], 1, memory_order_release);
    atomic_fetch_add(&W.rows_done, 1);
}

static void *render_thread(void *arg)
{
    (void)arg;
    RenderTarget target;
    memset(&target, 0, sizeof target);
    target.width = W.traced.image.width;
    target.height = W.traced.image.height;
    target.color = &W.traced.image;
    int status = 0;
    if (!render_image(W.cfg->tracer, &W.render_camera, &target, W.cfg->threads, NULL,
                      render_row_done, NULL, &W.cancel)) {
        if (!W.cancel) {
            fprintf(stderr, "%s: could not start the render (out of memory?)\n", diag_program());
            status = 1;
        }
    } else if (W.cfg->render && !W.cancel) {
        /* The requested files (-output, -depth, -normals, -stats), as the course `r`. */
        status = W.cfg->render(W.cfg->render_user, &W.render_camera, &W.cancel);
    }
    atomic_store(&W.thread_status, status);
    atomic_store(&W.thread_done, 1);
    return NULL;
}

static void join_render(void)
{
    if (!W.thread_running)
        return;
    pthread_join(W.thread, NULL);
    W.thread_running = false;
    int status = atomic_load(&W.thread_status);
    if (status && !W.status)
        W.status = status;
    FILE *out = preview_messages(W.cfg);
    fputs(W.cancel ? "Rendering stopped.\n" : "Rendering done.\n", out);
    fflush(out);
}

/* Stops a running render and forgets the traced picture (the view changed). */
static void drop_traced(void)
{
    if (W.thread_running) {
        W.cancel = 1;
        join_render();
    }
    if (W.have_traced) {
        image_free(&W.traced.image);
        free((void *)W.traced.row_ready);
        W.have_traced = false;
    }
}

static void poll_render(int value)
{
    (void)value;
    if (!W.thread_running)
        return;
    int rows = atomic_load(&W.rows_done);
    bool done = atomic_load(&W.thread_done);
    if (rows != W.rows_shown || done) {
        W.rows_shown = rows;
        glutPostRedisplay();
    }
    if (done)
        join_render();
    else
        glutTimerFunc(RENDER_POLL_MS, poll_render, 0);
}

static void start_render(void)
{
    if (W.thread_running) {
        fprintf(preview_messages(W.cfg), "still rendering the previous view\n");
        return;
    }
    drop_traced();
    if (!image_init(&W.traced.image, W.w, W.h))
        return;
    W.traced.row_ready = calloc((size_t)W.h, sizeof *W.traced.row_ready);
    if (!W.traced.row_ready) {
        image_free(&W.traced.image);
        return;
    }
    W.have_traced = true;
    W.render_camera = W.view.camera;
    W.cancel = 0;
    atomic_store(&W.rows_done, 0);
    atomic_store(&W.thread_done, 0);
    atomic_store(&W.thread_status, 0);
    W.rows_shown = 0;
    /* A line of its own: the -stats block (printed by the render) starts on the next. */
    fprintf(preview_messages(W.cfg), "Rendering scene...\n");
    fflush(preview_messages(W.cfg));
    if (pthread_create(&W.thread, NULL, render_thread, NULL) != 0) {
        fprintf(preview_messages(W.cfg), "could not start a thread\n");
        drop_traced();
        return;
    }
    W.thread_running = true;
    glutTimerFunc(RENDER_POLL_MS, poll_render, 0);
}

static void draw(void)
{
    preview_draw_frame(&W.gl, &W.view, W.w, W.h, W.have_traced ? &W.traced : NULL);
}

static void display(void)
{
    draw();
    glutSwapBuffers();
}

static void reshape(int w, int h)
{
    W.w = w > 0 ? w : 1;
    W.h = h > 0 ? h : 1;
    if (W.have_traced && (W.traced.image.width != W.w || W.traced.image.height != W.h))
        drop_traced();
    glutPostRedisplay();
}

/* `shot:FILE`: the frame as it is now, read back from the drawing buffer. */
static bool save_window(const char *path)
{
    Image img;
    unsigned char *scratch = malloc((size_t)W.w * (size_t)W.h * 3);
    if (!scratch || !image_init(&img, W.w, W.h)) {
        free(scratch);
        diag_error(W.diag, NULL, "out of memory for a %d x %d screenshot", W.w, W.h);
        return false;
    }
    draw();
    W.gl.ReadBuffer(GL_BACK);
    preview_read_frame(&W.gl, W.w, W.h, &img, scratch);
    bool ok = image_write(&img, path, W.diag);
    image_free(&img);
    free(scratch);
    return ok;
}

static void quit(void)
{
    drop_traced();
    glutLeaveMainLoop();
}

/* Closed by the window manager (its close button): freeglut returns from its loop
 * (GLUT_ACTION_GLUTMAINLOOP_RETURNS); a render still running is stopped at once. */
static void on_close(void)
{
    W.cancel = 1;
}

/* Once the window is gone, freeglut's own clean-up and any frame still queued refer
 * to it: those errors are expected and must not end the process through Xlib's
 * default handler (which exits). Any other error is reported and ignored, as GLUT
 * programs usually do. */
static int on_x_error(Display *dpy, XErrorEvent *e)
{
    (void)dpy;
    if (!W.destroyed)
        fprintf(stderr, "%s: X error %d (request %d)\n", diag_program(), e->error_code,
                e->request_code);
    return 0;
}

static void watch_window(int value)
{
    (void)value;
    XEvent ev;
    if (W.watch && XCheckTypedWindowEvent(W.watch, W.xwin, DestroyNotify, &ev)) {
        fprintf(stderr, "%s: the preview window was destroyed; quitting\n", diag_program());
        W.destroyed = 1;
        quit();
        return;
    }
    glutTimerFunc(WATCH_MS, watch_window, 0);
}

/* Ctrl-C in the terminal, kill and a closed terminal end the program as they end a
 * render: the signal handler only sets cfg->stop, which this timer polls (GLUT's loop
 * cannot be woken from a handler), then a running render stops and the window closes. */
static void watch_stop(int value)
{
    (void)value;
    if (W.cfg->stop && *W.cfg->stop) {
        W.stopped = *W.cfg->stop;
        W.cancel = 1;
        quit();
        return;
    }
    glutTimerFunc(WATCH_MS, watch_stop, 0);
}

static void keyboard(unsigned char key, int x, int y)
{
    W.mouse_x = x;
    W.mouse_y = y;
    KeyCmd cmd;
    memset(&cmd, 0, sizeof cmd);
    switch (key) {
    case 'r': case 'R':
        start_render();
        return;
    case 't': case 'T':
        cmd.kind = KEYCMD_TRACE;
        cmd.has_pixel = true;
        cmd.i = x;
        cmd.j = W.h - 1 - y;   /* GLUT counts rows from the top */
        break;
    case 'g': case 'G':
        cmd.kind = KEYCMD_GRID;
        break;
    case 'c': case 'C':
        cmd.kind = KEYCMD_CAMERA;
        break;
    case 'q': case 'Q': case 27:
        quit();
        return;
    default:
        fprintf(preview_messages(W.cfg), "UNKNOWN KEYBOARD INPUT  '%c'\n", key);
        fflush(preview_messages(W.cfg));
        return;
    }
    if (cmd.kind != KEYCMD_CAMERA)
        drop_traced();
    bool ok;
    preview_view_apply(&W.view, &cmd, W.w, W.h, &ok);
    if (!ok)
        fprintf(stderr, "%s: out of memory tracing the ray tree\n", diag_program());
    glutPostRedisplay();
}

static void mouse(int button, int state, int x, int y)
{
    W.button = state == GLUT_DOWN ? button : -1;
    W.mouse_x = x;
    W.mouse_y = y;
}

static void motion(int x, int y)
{
    float dx = (float)(x - W.mouse_x), dy = (float)(y - W.mouse_y);
    W.mouse_x = x;
    W.mouse_y = y;
    if (dx == 0.0f && dy == 0.0f)
        return;
    if (W.button == GLUT_LEFT_BUTTON)
        preview_view_rotate(&W.view, dx, dy);
    else if (W.button == GLUT_MIDDLE_BUTTON)
        preview_view_truck(&W.view, dx, dy);
    else if (W.button == GLUT_RIGHT_BUTTON)
        preview_view_dolly(&W.view, dx);
    else
        return;
    drop_traced();
    glutPostRedisplay();
}

static void passive_motion(int x, int y)
{
    W.mouse_x = x;
    W.mouse_y = y;
}

/* One -gui_keys command per step; a running render is waited for first, so
 * "r shot:x.tga q" saves the finished picture. */
static void script_step(int value)
{
    (void)value;
    if (W.thread_running) {
        glutTimerFunc(SCRIPT_STEP_MS, script_step, 0);
        return;
    }
    if (W.script_pos >= W.script.count)
        return;
    const KeyCmd *cmd = &W.script.cmds[W.script_pos++];
    glutSetWindow(W.win);
    bool ok = true;
    if (preview_view_apply(&W.view, cmd, W.w, W.h, &ok)) {
        if (cmd->kind != KEYCMD_CAMERA)
            drop_traced();
        if (!ok) {
            fprintf(stderr, "%s: out of memory tracing the ray tree\n", diag_program());
            W.status = 1;
        }
        glutPostRedisplay();
    } else if (cmd->kind == KEYCMD_RENDER) {
        start_render();
    } else if (cmd->kind == KEYCMD_SHOT) {
        if (!save_window(cmd->path))
            W.status = 1;
    } else {
        quit();
        return;
    }
    glutTimerFunc(SCRIPT_STEP_MS, script_step, 0);
}

/* freeglut exit()s when it cannot open the display or find a GL visual; ask first, so the
 * failure is reported like any other (a message, exit status 1 from main, no exit below
 * it). Returns the connection (NULL on failure), to be closed only after glutInit has
 * made its own: an X server may reset when its last client leaves (Xvfb does), refusing
 * the next one meanwhile. */
static Display *display_open(Diag *diag)
{
    const char *name = getenv("DISPLAY");
    if (!name || !*name) {
        diag_error(diag, NULL, "-gui needs an X display (DISPLAY is not set); "
                               "-gui_snapshot FILE draws the preview without one");
        return NULL;
    }
    Display *dpy = XOpenDisplay(NULL);
    if (!dpy) {
        diag_error(diag, NULL, "-gui cannot open the X display '%s'; "
                               "-gui_snapshot FILE draws the preview without one", name);
        return NULL;
    }
    int error_base, event_base;
    if (!glXQueryExtension(dpy, &error_base, &event_base)) {
        diag_error(diag, NULL, "the X display '%s' has no OpenGL (GLX) support; "
                               "-gui_snapshot FILE draws the preview without one", name);
        XCloseDisplay(dpy);
        return NULL;
    }
    return dpy;
}

int preview_run_window(const PreviewConfig *cfg, Diag *diag)
{
    memset(&W, 0, sizeof W);
    W.cfg = cfg;
    W.diag = diag;
    W.button = -1;
    /* A bad script is a usage error (2), reported before the display is looked at. */
    if (!preview_keys_parse(cfg->keys, &W.script, diag))
        return 2;
    /* The window's size (below) is known before the display is looked at. */
    int long_side = cfg->width > cfg->height ? cfg->width : cfg->height;
    if (long_side < 1)
        long_side = 1;
    W.w = (int)((long)cfg->width * WINDOW_LONG_SIDE / long_side);
    W.h = (int)((long)cfg->height * WINDOW_LONG_SIDE / long_side);
    if (W.w < 1)
        W.w = 1;
    if (W.h < 1)
        W.h = 1;
    if (!preview_keys_check(&W.script, W.w, W.h, "window", diag)) {
        preview_keys_free(&W.script);
        return 2;
    }
    if (!preview_keys_outputs_ok(&W.script, diag)) {
        preview_keys_free(&W.script);
        return 1;
    }
    if (!preview_load_window_libs(diag)) {
        preview_keys_free(&W.script);
        return 1;
    }
    Display *probe = display_open(diag);
    if (!probe) {
        preview_keys_free(&W.script);
        return 1;
    }
    if (!preview_view_init(&W.view, cfg, diag)) {
        preview_keys_free(&W.script);
        XCloseDisplay(probe);
        return 1;
    }
    int argc = 1;
    char name[] = "raytracer";
    char *argv[] = {name, NULL};
    glutInit(&argc, argv);
    XCloseDisplay(probe);
    glutSetOption(GLUT_ACTION_ON_WINDOW_CLOSE, GLUT_ACTION_GLUTMAINLOOP_RETURNS);
    glutInitDisplayMode(GLUT_RGBA | GLUT_DOUBLE | GLUT_DEPTH);
    glutInitWindowSize(W.w, W.h);
    glutInitWindowPosition(100, 100);
    W.win = glutCreateWindow("OpenGL Viewer");
    const char *missing = NULL;
    if (!gl_api_load(&W.gl, glut_proc, &missing)) {
        diag_error(diag, NULL, "the GL library lacks %s", missing);
        glutDestroyWindow(W.win);
        preview_view_free(&W.view);
        preview_keys_free(&W.script);
        return 1;
    }
    /* The X window behind the GLUT one (its drawable, current after creation), watched
     * on a connection of our own. */
    W.xwin = (Window)glXGetCurrentDrawable();
    W.watch = W.xwin ? XOpenDisplay(NULL) : NULL;
    if (W.watch) {
        XSelectInput(W.watch, W.xwin, StructureNotifyMask);
        XFlush(W.watch);
        glutTimerFunc(WATCH_MS, watch_window, 0);
    }
    XErrorHandler old_handler = XSetErrorHandler(on_x_error);
    glutCloseFunc(on_close);
    glutDisplayFunc(display);
    glutReshapeFunc(reshape);
    glutKeyboardFunc(keyboard);
    glutMouseFunc(mouse);
    glutMotionFunc(motion);
    glutPassiveMotionFunc(passive_motion);
    if (W.script.count)
        glutTimerFunc(SCRIPT_STEP_MS, script_step, 0);
    glutTimerFunc(WATCH_MS, watch_stop, 0);
    glutMainLoop();   /* returns after glutLeaveMainLoop or a closed window */

    drop_traced();
    if (W.watch)
        XCloseDisplay(W.watch);
    XSetErrorHandler(old_handler);
    preview_view_free(&W.view);
    preview_keys_free(&W.script);
    if (W.stopped) {
        fprintf(stderr, "%s: interrupted; the preview closed\n", diag_program());
        return 128 + W.stopped;
    }
    return W.status;
}

#else /* !RT_HAVE_GLUT */

bool preview_window_built(void) { return false; }

int preview_run_window(const PreviewConfig *cfg, Diag *diag)
{
    (void)cfg;
    diag_error(diag, NULL,
               "-gui is not built in: %s", preview_remedy(true));
    return 2;
}

#endif

const char *preview_remedy(bool window)
{
#ifdef RT_PREVIEW_LEFT_OUT
    (void)window;
    return "this build leaves it out on purpose, PREVIEW=0 as in raytracer-static: use "
           "./raytracer from make";
#else
    return window ? "apt-get install libglut-dev, then rebuild (make)"
                  : "apt-get install libosmesa6-dev, then rebuild (make)";
#endif
}
