/* Preview state without GL: camera controls of the course GLCanvas (docs/preview.md), the
 * `t` ray tree, the grid display mode and the -gui_keys script parser. */
#include "view.h"

#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "rt/diag.h"
#include "rt/matrix.h"
#include "rt/grid.h"
#include "rt/twolevel.h"
#include "rt/image.h"
#include "rt/raytracer.h"
#include "rt/scene.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* The course GLCanvas constants: radians and units per pixel of mouse drag. */
#define ROTATE_RAD_PER_PIXEL 0.005f
#define TRUCK_PER_PIXEL 0.05f
#define DOLLY_PER_PIXEL 0.05f
/* PerspectiveCamera::rotateCamera keeps the tilt from world up within these (radians). */
#define TILT_MIN 0.01f
#define TILT_MAX 3.13f

bool preview_view_init(PreviewView *v, const PreviewConfig *cfg, Diag *diag)
{
    memset(v, 0, sizeof *v);
    v->cfg = cfg;
    v->camera = cfg->scene->camera;
    v->world_up = v->camera.up;
    /* Rotation about the scene's centre; a scene of planes only has no centre, so a
     * point ten units ahead stands in. */
    const BBox *b = &cfg->scene->bounds;
    if (!bbox_is_empty(b))
        v->pivot = v3_scale(v3_add(b->min, b->max), 0.5f);
    else
        v->pivot = v3_madd(v->camera.center, v->camera.direction, 10.0f);
    v->mode = (cfg->visualize_grid && preview_view_grid(v)) ? PREVIEW_GRID : PREVIEW_OBJECTS;
    v->tree = malloc(sizeof *v->tree);
    if (!v->tree) {
        diag_error(diag, NULL, "out of memory for the preview's ray tree");
        return false;
    }
    ray_tree_clear(v->tree);
    return true;
}

/* The two-level grid's top level is a course Grid: what -visualize_grid draws where
 * -grid auto builds the two-level grid, and the cells its walk records in the ray tree.
 * Only the uniform grid was looked for, so with -grid auto on an uneven scene (the
 * showcase) g said "no grid to show: run with -grid nx ny nz" and -visualize_grid
 * started in the object view. */
const Grid *preview_view_grid(const PreviewView *v)
{
    const Accel *a = v->cfg->tracer->accel;
    const Grid *g = grid_of_accel(a);
    const TwoLevelGrid *t = g ? NULL : twolevel_of_accel(a);
    return t ? twolevel_top(t) : g;
}

void preview_view_free(PreviewView *v)
{
    free(v->tree);
    v->tree = NULL;
}

void preview_view_rotate(PreviewView *v, float dx, float dy)
{
    /* As GLCanvas::motion -> rotateCamera(0.005 * (oldX - x), 0.005 * (oldY - y)). */
    float rx = -ROTATE_RAD_PER_PIXEL * dx;
    float ry = -ROTATE_RAD_PER_PIXEL * dy;
    Camera c = v->camera;
    float cosine = v3_dot(v->world_up, c.direction);
    float tilt = acosf(fmaxf(-1.0f, fminf(1.0f, cosine)));
    if (tilt - ry > TILT_MAX)
        ry = tilt - TILT_MAX;
    else if (tilt - ry < TILT_MIN)
        ry = tilt - TILT_MIN;
    const float deg = (float)(180.0 / M_PI);
    Mat4 yaw = mat4_rotate_axis(v->world_up, rx * deg);
    Mat4 pitch = mat4_rotate_axis(c.horizontal, ry * deg);
    Mat4 r = mat4_mul(&yaw, &pitch);
    c.center = v3_add(v->pivot, mat4_dir(&r, v3_sub(c.center, v->pivot)));
    c.direction = mat4_dir(&r, c.direction);
    c.up = v->world_up;
    if (camera_rebasis(&c))
        v->camera = c;
}

/* Moves the eye to center. The perspective camera's rays aim at its screen
 * (lower_left, placed from the eye when the basis is made), so the screen must move
 * with the eye: moving only the centre left r and t tracing from the new eye towards
 * the old screen (one unit of dolly put the eye in the old screen's plane, and r drew
 * only background). A move that would take the camera out of float range is ignored,
 * as a rotation that would make the basis degenerate is. */
static void move_center(PreviewView *v, Vec3 center)
{
    Camera c = v->camera;
    c.center = center;
    if (v3_isfinite(center) && camera_rebasis(&c) && v3_isfinite(c.lower_left))
        v->camera = c;
}

void preview_view_truck(PreviewView *v, float dx, float dy)
{
    /* truckCamera((oldX - x) * 0.05, (y - oldY) * 0.05): the scene follows the mouse. */
    const Camera *c = &v->camera;
    Vec3 center = v3_madd(c->center, c->horizontal, -TRUCK_PER_PIXEL * dx);
    move_center(v, v3_madd(center, c->up, TRUCK_PER_PIXEL * dy));
}

void preview_view_dolly(PreviewView *v, float dx)
{
    const Camera *c = &v->camera;
    move_center(v, v3_madd(c->center, c->direction, DOLLY_PER_PIXEL * dx));
}

bool preview_view_trace(PreviewView *v, int i, int j, int w, int h)
{
    const RayTracer *rt = v->cfg->tracer;
    RenderCtx ctx;
    if (!raytracer_ctx_init(&ctx, rt))
        return false;
    ray_tree_clear(v->tree);
    ctx.tree = v->tree;
    float u, s;
    camera_pixel_to_screen(i, j, w, h, &u, &s);
    Ray ray = camera_generate_ray(&v->camera, u, s);
    /* A fresh primary ray: depth 0, weight 1, in air (index of refraction 1). */
    (void)raytracer_trace(rt, &ctx, &ray, camera_tmin(&v->camera), 0, 1.0f, 1.0f, NULL);
    raytracer_ctx_free(&ctx);
    v->has_tree = true;
    return true;
}

void preview_view_cycle_grid(PreviewView *v, FILE *out)
{
    /* Only -accel none (chosen, or the default without -grid) has no grid to draw; the
     * hint names both ways to one, since -grid with -accel none is a usage error. */
    if (!preview_view_grid(v)) {
        if (out)
            fprintf(out, "no grid to show: run with -grid nx ny nz or -grid auto (and "
                         "without -accel none)\n");
        v->mode = PREVIEW_OBJECTS;
        return;
    }
    v->mode = v->mode == PREVIEW_OBJECTS ? PREVIEW_GRID
            : v->mode == PREVIEW_GRID    ? PREVIEW_GRID_RAY
                                         : PREVIEW_OBJECTS;
    /* Like the other keys, g says what it did. */
    if (out) {
        fprintf(out, "grid view: %s\n",
                v->mode == PREVIEW_GRID       ? "occupied cells (outlined: the last ray's)"
                : v->mode == PREVIEW_GRID_RAY ? "the cells the last traced ray visited"
                                              : "objects");
        fflush(out);
    }
}

void preview_view_print_camera(const PreviewView *v, FILE *out)
{
    const Camera *c = &v->camera;
    bool ortho = c->kind == CAMERA_ORTHOGRAPHIC;
    fprintf(out, "%s {\n", ortho ? "OrthographicCamera" : "PerspectiveCamera");
    fprintf(out, "    center %g %g %g\n", (double)c->center.x, (double)c->center.y,
            (double)c->center.z);
    fprintf(out, "    direction %g %g %g\n", (double)c->direction.x,
            (double)c->direction.y, (double)c->direction.z);
    fprintf(out, "    up %g %g %g\n", (double)c->up.x, (double)c->up.y, (double)c->up.z);
    if (ortho)
        fprintf(out, "    size %g\n", (double)c->size);
    else
        fprintf(out, "    angle %g\n", (double)c->angle * 180.0 / M_PI);
    fprintf(out, "}\n");
    fflush(out);
}

/* ---- -gui_keys ---- */

/* Parses "A,B" (floats) filling both; false unless the whole text is consumed. */
static bool parse_pair(const char *text, float *a, float *b, bool want_two)
{
    char *end;
    errno = 0;
    double x = strtod(text, &end);
    /* The drags are floats: a value beyond float range (dolly:1e300) would become
     * infinite there, so it is refused like one beyond double range. */
    if (end == text || errno || !(fabs(x) <= (double)FLT_MAX))
        return false;
    *a = (float)x;
    if (!want_two)
        return *end == '\0';
    if (*end != ',')
        return false;
    const char *p = end + 1;
    double y = strtod(p, &end);
    if (end == p || errno || !(fabs(y) <= (double)FLT_MAX) || *end != '\0')
        return false;
    *b = (float)y;
    return true;
}

static bool parse_pixel(const char *text, int *i, int *j)
{
    char *end;
    errno = 0;
    long x = strtol(text, &end, 10);
    if (end == text || *end != ',' || errno || x < 0 || x > 1000000)
        return false;
    const char *p = end + 1;
    long y = strtol(p, &end, 10);
    if (end == p || *end != '\0' || errno || y < 0 || y > 1000000)
        return false;
    *i = (int)x;
    *j = (int)y;
    return true;
}

/* One command word (NUL-terminated copy) -> cmd. */
static bool parse_word(char *w, KeyCmd *cmd)
{
    memset(cmd, 0, sizeof *cmd);
    char *arg = strchr(w, ':');
    if (arg)
        *arg++ = '\0';
    for (char *p = w; *p; p++)
        *p = (char)tolower((unsigned char)*p);
    if (!arg) {
        if (!strcmp(w, "r"))
            cmd->kind = KEYCMD_RENDER;
        else if (!strcmp(w, "t"))
            cmd->kind = KEYCMD_TRACE;
        else if (!strcmp(w, "g"))
            cmd->kind = KEYCMD_GRID;
        else if (!strcmp(w, "c"))
            cmd->kind = KEYCMD_CAMERA;
        else if (!strcmp(w, "q"))
            cmd->kind = KEYCMD_QUIT;
        else
            return false;
        return true;
    }
    if (!strcmp(w, "t")) {
        cmd->kind = KEYCMD_TRACE;
        cmd->has_pixel = true;
        return parse_pixel(arg, &cmd->i, &cmd->j);
    }
    if (!strcmp(w, "rot")) {
        cmd->kind = KEYCMD_ROTATE;
        return parse_pair(arg, &cmd->a, &cmd->b, true);
    }
    if (!strcmp(w, "truck")) {
        cmd->kind = KEYCMD_TRUCK;
        return parse_pair(arg, &cmd->a, &cmd->b, true);
    }
    if (!strcmp(w, "dolly")) {
        cmd->kind = KEYCMD_DOLLY;
        return parse_pair(arg, &cmd->a, &cmd->b, false);
    }
    if (!strcmp(w, "shot")) {
        cmd->kind = KEYCMD_SHOT;
        if (!*arg)
            return false;
        cmd->path = malloc(strlen(arg) + 1);
        if (!cmd->path)
            return false;
        strcpy(cmd->path, arg);
        return true;
    }
    return false;
}

bool preview_keys_parse(const char *text, KeyScript *out, Diag *diag)
{
    out->count = 0;
    out->cmds = NULL;
    if (!text)
        return true;
    size_t len = strlen(text);
    /* At most one command per two characters (a word and a separator). */
    KeyCmd *cmds = calloc(len / 2 + 1, sizeof *cmds);
    char *word = malloc(len + 1);
    if (!cmds || !word) {
        free(cmds);
        free(word);
        diag_error(diag, NULL, "-gui_keys: out of memory");
        return false;
    }
    int n = 0;
    const char *p = text;
    for (;;) {
        while (isspace((unsigned char)*p))
            p++;
        if (!*p)
            break;
        const char *start = p;
        while (*p && !isspace((unsigned char)*p))
            p++;
        size_t wl = (size_t)(p - start);
        memcpy(word, start, wl);
        word[wl] = '\0';
        if (!parse_word(word, &cmds[n])) {
            diag_error(diag, NULL,
                       "-gui_keys: bad command '%.*s' at character %d (expected r, t, t:I,J, "
                       "g, c, q, rot:DX,DY, truck:DX,DY, dolly:D or shot:FILE)",
                       (int)wl, start, (int)(start - text) + 1);
            free(cmds[n].path);
            out->count = n;
            out->cmds = cmds;
            preview_keys_free(out);
            free(word);
            return false;
        }
        n++;
    }
    free(word);
    out->count = n;
    out->cmds = cmds;
    return true;
}

bool preview_keys_check(const KeyScript *s, int w, int h, const char *what, Diag *diag)
{
    for (int k = 0; k < s->count; k++) {
        const KeyCmd *c = &s->cmds[k];
        if (c->kind == KEYCMD_TRACE && c->has_pixel && (c->i >= w || c->j >= h)) {
            diag_error(diag, NULL, "-gui_keys: t:%d,%d is outside the %dx%d %s (I from 0 "
                       "to %d, J from 0 to %d)", c->i, c->j, w, h, what, w - 1, h - 1);
            return false;
        }
    }
    return true;
}

bool preview_keys_outputs_ok(const KeyScript *s, Diag *diag)
{
    for (int k = 0; k < s->count; k++)
        if (s->cmds[k].kind == KEYCMD_SHOT && !image_check_output(s->cmds[k].path, NULL, diag))
            return false;
    return true;
}

int preview_keys_validate(const char *keys, Diag *diag)
{
    KeyScript s;
    if (!preview_keys_parse(keys, &s, diag))
        return 2;
    int status = 0;
    for (int k = 0; k < s.count && !status; k++) {
        const char *path = s.cmds[k].path;
        if (s.cmds[k].kind != KEYCMD_SHOT)
            continue;
        /* The extension is the user's spelling, like -output x.jpg: a usage error.
         * shot:- is standard output (TGA), as it was before this check. */
        if (strcmp(path, IMAGE_STDOUT) != 0 && !image_codec_for_path(path) &&
            !image_is_null_device(path)) {
            char list[128];
            image_format_list(list, sizeof list);
            diag_error(diag, NULL, "-gui_keys: shot:%s: unknown image format (the file "
                       "name must end in one of %s)", path, list);
            status = 2;
        } else if (!image_check_output(path, NULL, diag)) {
            status = 1;
        }
    }
    preview_keys_free(&s);
    return status;
}

/* Whether the script (NULL: none; false when it is not well formed) has a command of
 * kind before its first q (the window and the snapshot run nothing after a q); for
 * shot, one naming standard output when to_stdout. */
static bool keys_have(const char *keys, KeyCmdKind kind, bool to_stdout)
{
    Diag quiet;
    diag_init(&quiet, NULL);
    KeyScript s;
    if (!preview_keys_parse(keys, &s, &quiet))
        return false;
    bool found = false;
    for (int k = 0; k < s.count && s.cmds[k].kind != KEYCMD_QUIT; k++)
        found = found || (s.cmds[k].kind == kind &&
                          (!to_stdout || strcmp(s.cmds[k].path, IMAGE_STDOUT) == 0));
    preview_keys_free(&s);
    return found;
}

FILE *preview_messages(const PreviewConfig *cfg)
{
    return cfg->messages ? cfg->messages : stdout;
}

bool preview_keys_render(const char *keys)
{
    return keys_have(keys, KEYCMD_RENDER, false);
}

bool preview_keys_shot_stdout(const char *keys)
{
    return keys_have(keys, KEYCMD_SHOT, true);
}

void preview_keys_free(KeyScript *s)
{
    for (int k = 0; k < s->count; k++)
        free(s->cmds[k].path);
    free(s->cmds);
    s->cmds = NULL;
    s->count = 0;
}

bool preview_view_apply(PreviewView *v, const KeyCmd *cmd, int w, int h, bool *ok)
{
    *ok = true;
    switch (cmd->kind) {
    case KEYCMD_TRACE: {
        int i = cmd->has_pixel ? cmd->i : w / 2, j = cmd->has_pixel ? cmd->j : h / 2;
        *ok = preview_view_trace(v, i, j, w, h);
        if (*ok) {
            const RayTree *t = v->tree;
            FILE *out = preview_messages(v->cfg);
            fprintf(out, "ray tree of pixel (%d, %d): %d segment%s, %d grid cell%s\n", i, j,
                    t->num_segments, t->num_segments == 1 ? "" : "s", t->num_cells,
                    t->num_cells == 1 ? "" : "s");
            fflush(out);
            if (ray_tree_full(t)) {
                char more[64] = "";
                if (t->dropped > 0)
                    snprintf(more, sizeof more, "; %d more ray%s not drawn", t->dropped,
                             t->dropped == 1 ? " was" : "s were");
                fprintf(stderr, "%s: warning: the ray tree of pixel (%d, %d) is cut at "
                        "%d segments (the most kept): its deeper reflected and refracted rays "
                        "were not traced%s\n", diag_program(), i, j, t->num_segments, more);
            }
        }
        return true;
    }
    case KEYCMD_GRID:
        preview_view_cycle_grid(v, preview_messages(v->cfg));
        return true;
    case KEYCMD_CAMERA:
        preview_view_print_camera(v, preview_messages(v->cfg));
        return true;
    case KEYCMD_ROTATE:
        preview_view_rotate(v, cmd->a, cmd->b);
        return true;
    case KEYCMD_TRUCK:
        preview_view_truck(v, cmd->a, cmd->b);
        return true;
    case KEYCMD_DOLLY:
        preview_view_dolly(v, cmd->a);
        return true;
    case KEYCMD_RENDER:
    case KEYCMD_SHOT:
    case KEYCMD_QUIT:
        break;
    }
    return false;
}
