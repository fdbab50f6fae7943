/* Recursive-descent parser of the A1-A6 scene format (docs/scene-format.md), building the
 * scene through the geom/material/camera constructors. Stops at the first error with a
 * located message; where the course parser asserted or trusted the input, we check. */
#include "parser.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "lexer.h"
#include "obj_loader.h"
#include "rt/file.h"
#include "rt/geom.h"
#include "rt/par.h"
#include "rt/suggest.h"

/* Counts above this are typos or attacks, not scenes (numLights/numMaterials/numObjects). */
enum { MAX_COUNT = 10000000 };
/* Noise sums this many octaves per shading call: beyond it rendering would crawl. */
enum { MAX_OCTAVES = 32 };

/* The kinds of top-level block, for the warning on a second one of a kind (either
 * camera counts as the camera). */
typedef enum TopKind {
    TOP_CAMERA,
    TOP_BACKGROUND,
    TOP_LIGHTS,
    TOP_MATERIALS,
    TOP_GROUP,
    TOP_KINDS
} TopKind;

typedef struct Parser {
    Lexer lx;
    Scene *s;
    Diag *diag;
    const char *base_dir;
    const Material *current;   /* MaterialIndex state: global, ignores the hierarchy (7) */
    int depth;                 /* Groups/Transforms/meshes currently open */
    /* Scratch (malloc'd, freed after the parse): children of the open groups as one
     * stack, so memory follows the actual content, never the declared counts. */
    Object3D **stack;
    size_t stack_len, stack_cap;
    /* The first top-level block of each kind (line 0: none yet), for the warning on a
     * second one; indexed by TopKind. */
    int first_line[TOP_KINDS];
    const char *first_name[TOP_KINDS];
} Parser;

/* ---- error helpers ---------------------------------------------------------------- */

static bool fail(Parser *p, const SrcLoc *loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static bool fail(Parser *p, const SrcLoc *loc, const char *fmt, ...)
{
    char msg[768];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(msg, sizeof msg, fmt, ap);
    va_end(ap);
    diag_error(p->diag, loc, "%s", msg);
    return false;
}

/* ---- hints: what the writer probably meant ------------------------------------------ */

/* The keywords that may stand where each kind of fail_unknown is reported; a misspelt
 * one is answered with the nearest of its own kind (rt/suggest.h). */
/* The object keywords with their parsers, the procedural materials with their
 * numbers and constructors (parse_procedural), and the transformation keywords: each
 * list is written once, here, and the keyword tests (is_object, is_material,
 * is_transformation), the dispatch and the names the messages offer are made from it,
 * so a new kind of object or texture is one row (docs/architecture.md). */
#define OBJECT_KEYWORDS(X)                                                                 \
    X("Group", parse_group)                                                                \
    X("Sphere", parse_sphere)                                                              \
    X("Plane", parse_plane)                                                                \
    X("Triangle", parse_triangle)                                                          \
    X("TriangleMesh", parse_mesh)                                                          \
    X("Transform", parse_transform)
/* numbers: 0 none, 1 octaves, 3 octaves frequency amplitude (docs/textures.md). */
#define PROCEDURAL_KEYWORDS(X)                                                             \
    X("Checkerboard", 0, make_checkerboard)                                                \
    X("Noise", 1, make_noise)                                                              \
    X("Marble", 3, marble_new)                                                             \
    X("Wood", 3, wood_new)
#define TRANSFORMATION_KEYWORDS(X)                                                         \
    X("Scale") X("UniformScale") X("Translate") X("XRotate") X("YRotate") X("ZRotate")     \
    X("Rotate") X("Matrix")
#define KEYWORD_NAME(name, ...) name,
#define TRANSFORMATION_NAME(name) name,

static const char *const k_objects[] = {OBJECT_KEYWORDS(KEYWORD_NAME) "MaterialIndex", NULL};
static const char *const k_lights[] = {"DirectionalLight", "PointLight", NULL};
static const char *const k_materials[] = {"PhongMaterial", "Material",
                                          PROCEDURAL_KEYWORDS(KEYWORD_NAME) NULL};
static const char *const k_transformations[] = {TRANSFORMATION_KEYWORDS(TRANSFORMATION_NAME) NULL};
static const char *const k_phong_fields[] = {"diffuseColor", "specularColor", "exponent",
                                             "reflectiveColor", "transparentColor",
                                             "indexOfRefraction", NULL};
static const char *const k_background_fields[] = {"color", "ambientLight", NULL};
static const char *const k_top_level[] = {"OrthographicCamera", "PerspectiveCamera",
                                          "Background", "Lights", "Materials", "Group", NULL};
/* What may stand in a Transform before its object: a transformation or an object (no
 * MaterialIndex: only a Group takes one). */
static const char *const k_transform_items[] = {TRANSFORMATION_KEYWORDS(TRANSFORMATION_NAME)
                                                OBJECT_KEYWORDS(KEYWORD_NAME) NULL};

static size_t name_count(const char *const *names)
{
    size_t n = 0;
    while (names[n])
        n++;
    return n;
}

/* A keyword of any kind that shown (a token, NUL-terminated) starts with, followed by a
 * brace: "Sphere{" is the keyword Sphere written without its space. */
static const char *glued_keyword(const char *shown)
{
    static const char *const *const lists[] = {k_objects, k_lights, k_materials,
                                               k_transformations, k_top_level};
    for (size_t l = 0; l < sizeof lists / sizeof lists[0]; l++)
        for (const char *const *k = lists[l]; *k; k++) {
            size_t n = strlen(*k);
            if (!strncmp(shown, *k, n) && (shown[n] == '{' || shown[n] == '}'))
                return *k;
        }
    return NULL;
}

/* Into buf: a hint for token shown, or "". Tokens are separated by white space only,
 * so a brace touching a word makes one token with it ("Sphere{", "0}"): that is said
 * first; then the nearest names of the list (NULL: none). */
static void token_hint(char *buf, size_t size, const char *shown, const char *const *names)
{
    buf[0] = '\0';
    size_t len = strlen(shown);
    if (len > 1 && strpbrk(shown, "{}")) {
        const char *kw = glued_keyword(shown);
        if (kw)
            snprintf(buf, size, " (missing space: write '%s %c', braces are tokens of their "
                     "own)", kw, shown[strlen(kw)]);
        else
            snprintf(buf, size, " (braces are tokens of their own: put white space around "
                     "them)");
        return;
    }
    /* The format has no comments: a writer who tries one sees the first word of it
     * refused, so name the cause rather than that word. */
    if (shown[0] == '#' || !strncmp(shown, "//", 2) || !strncmp(shown, "/*", 2)) {
        snprintf(buf, size, " (scene files have no comments)");
        return;
    }
    /* A keyword of the list itself is not misspelt, only misplaced: the caller says
     * where it belongs; "did you mean" the very word would only puzzle. */
    for (const char *const *k = names; k && *k; k++)
        if (!strcmp(*k, shown))
            return;
    if (names)
        suggest_format(buf, size, shown, names, name_count(names));
}

/* "expected WHAT, found 'tok'", or "unexpected end of file, expected WHAT". When WHAT
 * is one quoted keyword, a token close to it is named as the likely misspelling. */
static bool fail_expected(Parser *p, const Token *t, const char *what)
{
    char shown[256];
    if (lex_eof(t))
        return fail(p, &t->loc, "unexpected end of file, expected %s", what);
    lex_show(t, shown, sizeof shown);
    char kw[64] = "", hint[160];
    size_t n = strlen(what);
    if (n > 2 && n < sizeof kw + 2 && what[0] == '\'' && what[n - 1] == '\'' &&
        !memchr(what + 1, '\'', n - 2))
        snprintf(kw, sizeof kw, "%.*s", (int)(n - 2), what + 1);
    const char *one[] = {kw, NULL};
    token_hint(hint, sizeof hint, shown, kw[0] && kw[0] != '{' && kw[0] != '}' ? one : NULL);
    return fail(p, &t->loc, "expected %s, found '%s'%s", what, shown, hint);
}

/* "expected WHAT, found 'tok'" where WHAT is one of several names (names), the nearest
 * of which is offered when the token looks like a misspelling of one. */
static bool fail_expected_among(Parser *p, const Token *t, const char *what,
                                const char *const *names)
{
    char shown[256], hint[160];
    if (lex_eof(t))
        return fail(p, &t->loc, "unexpected end of file, expected %s", what);
    lex_show(t, shown, sizeof shown);
    token_hint(hint, sizeof hint, shown, names);
    return fail(p, &t->loc, "expected %s, found '%s'%s", what, shown, hint);
}

/* "unknown KIND 'tok'" with the nearest names of the kind when the token looks like a
 * misspelling of one, or the end-of-file message when the file just stops. */
static bool fail_unknown(Parser *p, const Token *t, const char *kind, const char *eof_what)
{
    static const struct {
        const char *kind;
        const char *const *names;
    } kinds[] = {
        {"object", k_objects},
        {"light", k_lights},
        {"material", k_materials},
        {"transformation", k_transformations},
        {"PhongMaterial field", k_phong_fields},
        {"Background field", k_background_fields},
        {"top-level block", k_top_level},
        {"transformation or object", k_transform_items},
    };
    char shown[256], hint[192];
    if (lex_eof(t))
        return fail(p, &t->loc, "unexpected end of file, expected %s", eof_what);
    lex_show(t, shown, sizeof shown);
    const char *const *names = NULL;
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0] && !names; i++)
        if (!strcmp(kinds[i].kind, kind))
            names = kinds[i].names;
    token_hint(hint, sizeof hint, shown, names);
    /* Nothing close enough to offer ("DirLight", "Camera"): a short list is named
     * whole, so the writer need not look the grammar up. A keyword of the list itself
     * (misplaced, not misspelt) is left to the callers' own wording. */
    bool listed = false;
    for (const char *const *k = names; k && *k && !listed; k++)
        listed = !strcmp(*k, shown);
    size_t count = names ? name_count(names) : 0;
    if (!hint[0] && !listed && count >= 2 && count <= 8) {
        size_t used = (size_t)snprintf(hint, sizeof hint, " (expected %s",
                                       count > 2 ? "one of " : "");
        for (size_t i = 0; i < count && used < sizeof hint; i++)
            used += (size_t)snprintf(hint + used, sizeof hint - used, "%s%s", names[i],
                                     i == count - 1 ? ")" : i == count - 2 ? " or " : ", ");
    }
    return fail(p, &t->loc, "unknown %s '%s'%s", kind, shown, hint);
}

static bool next(Parser *p, Token *t) { return lex_next(&p->lx, t); }

/* A counted block: "numLights n" (or numMaterials), then exactly n items, then "}". */
typedef struct CountedBlock {
    const char *count_kw;            /* "numLights" */
    const char *block;               /* "Lights" */
    const char *noun;                /* "light" (plural: + "s") */
    bool (*is_item)(const Token *t); /* t starts an item */
} CountedBlock;

typedef enum { COUNTED_ITEM, COUNTED_END, COUNTED_ERROR } CountedStep;

/* What token t, read after count of the block's n items, is: the start of the next
 * item, the block's proper end, or an error (reported here). */
static CountedStep counted_step(Parser *p, const Token *t, int count, int n,
                                const CountedBlock *b)
{
    if (lex_is(t, "}")) {
        if (count == n)
            return COUNTED_END;
        fail(p, &t->loc, "%s is %d but the %s block ends after %d %s%s", b->count_kw, n,
             b->block, count, b->noun, count == 1 ? "" : "s");
        return COUNTED_ERROR;
    }
    if (count == n) {
        if (b->is_item(t))
            fail(p, &t->loc, "%s is %d but more %ss follow", b->count_kw, n, b->noun);
        else
            fail_expected(p, t, "'}'");
        return COUNTED_ERROR;
    }
    if (!b->is_item(t)) {
        fail_unknown(p, t, b->noun, "'}'");
        return COUNTED_ERROR;
    }
    return COUNTED_ITEM;
}

static bool expect(Parser *p, const char *kw, Token *out)
{
    Token t;
    if (!next(p, &t))
        return false;
    if (!lex_is(&t, kw)) {
        char what[64];
        snprintf(what, sizeof what, "'%s'", kw);
        return fail_expected(p, &t, what);
    }
    if (out)
        *out = t;
    return true;
}

static bool num_error(Parser *p, const Token *t, NumResult r, bool want_int)
{
    char shown[256];
    if (lex_eof(t))
        return fail(p, &t->loc, "unexpected end of file, expected %s",
                    want_int ? "an integer" : "a number");
    lex_show(t, shown, sizeof shown);
    if (r == NUM_RANGE)
        return fail(p, &t->loc, "number out of range: '%s'", shown);
    char hint[160];
    token_hint(hint, sizeof hint, shown, NULL);
    /* "0,5" or "1,0,0": a decimal comma or commas between the numbers. */
    if (!hint[0] && strchr(shown, ',') && strpbrk(shown, "0123456789") == shown + strspn(shown, "+-"))
        snprintf(hint, sizeof hint, " (numbers are separated by white space, and their "
                 "decimal point is '.')");
    return fail(p, &t->loc, "expected %s, found '%s'%s", want_int ? "an integer" : "a number",
                shown, hint);
}

static bool read_float(Parser *p, float *out)
{
    Token t;
    if (!next(p, &t))
        return false;
    NumResult r = lex_eof(&t) ? NUM_NOT_A_NUMBER : lex_to_float(&t, out);
    return r == NUM_OK || num_error(p, &t, r, false);
}

static bool read_int_tok(Parser *p, int *out, Token *tok)
{
    Token t;
    if (!next(p, &t))
        return false;
    NumResult r = lex_eof(&t) ? NUM_NOT_A_NUMBER : lex_to_int(&t, out);
    if (tok)
        *tok = t;
    return r == NUM_OK || num_error(p, &t, r, true);
}

static bool read_vec3(Parser *p, Vec3 *v)
{
    return read_float(p, &v->x) && read_float(p, &v->y) && read_float(p, &v->z);
}

/* `kw` then a Vec3 / a float: the fixed-order fields of most blocks. */
static bool field_vec3(Parser *p, const char *kw, Vec3 *v, SrcLoc *at)
{
    Token t;
    if (!expect(p, kw, &t))
        return false;
    if (at)
        *at = t.loc;
    return read_vec3(p, v);
}

static bool field_float(Parser *p, const char *kw, float *f, SrcLoc *at)
{
    Token t;
    if (!expect(p, kw, &t))
        return false;
    if (at)
        *at = t.loc;
    return read_float(p, f);
}

static bool field_int(Parser *p, const char *kw, int *v, Token *num)
{
    return expect(p, kw, NULL) && read_int_tok(p, v, num);
}

static bool read_count(Parser *p, const char *kw, int *n)
{
    Token num;
    if (!field_int(p, kw, n, &num))
        return false;
    if (*n < 0 || *n > MAX_COUNT)
        return fail(p, &num.loc, "%s must be between 0 and %d, found %d", kw, MAX_COUNT, *n);
    return true;
}

static bool out_of_memory(Parser *p, const SrcLoc *loc)
{
    return fail(p, loc, "out of memory");
}

/* ---- transformations (8) ------------------------------------------------------------ */

/* Whether t is one of names (NULL-terminated). */
static bool is_among(const Token *t, const char *const *names)
{
    for (size_t i = 0; names[i]; i++)
        if (lex_is(t, names[i]))
            return true;
    return false;
}

static bool is_transformation(const Token *t) { return is_among(t, k_transformations); }

/* Applies one transformation keyword t (already read) to *m in the course's order:
 * M <- M * T for all but Matrix, M <- T * M for Matrix (8, "Composition order"). */
static bool parse_transformation(Parser *p, const Token *t, Mat4 *m)
{
    Mat4 x;
    bool left = false;
    if (lex_is(t, "Scale")) {
        Vec3 s;
        if (!read_vec3(p, &s))
            return false;
        x = mat4_scale(s);
    } else if (lex_is(t, "UniformScale")) {
        float s;
        if (!read_float(p, &s))
            return false;
        x = mat4_scale(v3(s, s, s));
    } else if (lex_is(t, "Translate")) {
        Vec3 d;
        if (!read_vec3(p, &d))
            return false;
        x = mat4_translate(d);
    } else if (lex_is(t, "XRotate") || lex_is(t, "YRotate") || lex_is(t, "ZRotate")) {
        float deg;
        if (!read_float(p, &deg))
            return false;
        x = t->text[0] == 'X' ? mat4_rotate_x(deg)
            : t->text[0] == 'Y' ? mat4_rotate_y(deg) : mat4_rotate_z(deg);
    } else if (lex_is(t, "Rotate")) {
        Vec3 axis;
        float deg;
        Token at;
        if (!expect(p, "{", NULL) || !lex_peek(&p->lx, &at) || !read_vec3(p, &axis) ||
            !read_float(p, &deg) || !expect(p, "}", NULL))
            return false;
        if (v3_is_zero(axis))
            return fail(p, &at.loc, "Rotate axis is zero");
        /* The course's Rodrigues matrix takes the axis as written (so do we: the same
         * picture), but an axis of another length stretches the object along it and
         * across it as well as turning it, which nobody writing "Rotate { 1 1 0 35 }"
         * means. Said once here, where it can be fixed. In double: squares of large
         * components would overflow a float. */
        double ax = (double)axis.x, ay = (double)axis.y, az = (double)axis.z;
        double len = sqrt(ax * ax + ay * ay + az * az);
        if (fabs(len - 1.0) > 1e-3)
            diag_warning(p->diag, &at.loc,
                         "Rotate axis %g %g %g has length %g, not 1: it is used as given "
                         "(the course's rule), which stretches the object as well as "
                         "turning it; for a pure rotation write the unit axis %g %g %g",
                         ax, ay, az, len, ax / len, ay / len, az / len);
        x = mat4_rotate_axis(axis, deg);
    } else if (lex_is(t, "Matrix")) {
        float v[16];
        if (!expect(p, "{", NULL))
            return false;
        for (int i = 0; i < 16; i++)
            if (!read_float(p, &v[i]))
                return false;
        if (!expect(p, "}", NULL))
            return false;
        /* Our objects are affine (rays stay rays); a projective row would be silently
         * ignored downstream, so it is refused here. */
        if (v[12] != 0.0f || v[13] != 0.0f || v[14] != 0.0f || v[15] != 1.0f)
            return fail(p, &t->loc, "Matrix must be affine: its last row must be 0 0 0 1");
        x = mat4_from_rows(v);
        left = true;
    } else {
        return fail_unknown(p, t, "transformation", "a transformation");
    }
    *m = left ? mat4_mul(&x, m) : mat4_mul(m, &x);
    if (!mat4_isfinite(m))
        return fail(p, &t->loc, "transformation overflows (matrix is not finite)");
    return true;
}

/* ---- objects (7) -------------------------------------------------------------------- */

static bool parse_object(Parser *p, const Token *kw, Object3D **out);

/* Records that the object at kw made count leaves (scene_leaf_loc). */
static bool note_leaves(Parser *p, const Token *kw, uint32_t count)
{
    Scene *s = p->s;
    if (s->num_leaf_runs == s->cap_leaf_runs) {
        uint32_t cap = s->cap_leaf_runs ? 2 * s->cap_leaf_runs : 64;
        SceneLeafRun *r = cap > s->cap_leaf_runs ? realloc(s->leaf_runs, (size_t)cap * sizeof *r)
                                                 : NULL;
        if (!r)
            return out_of_memory(p, &kw->loc);
        s->leaf_runs = r;
        s->cap_leaf_runs = cap;
    }
    SceneLeafRun *run = &s->leaf_runs[s->num_leaf_runs++];
    run->first = s->leaves_parsed;
    run->line = kw->loc.line;
    run->col = kw->loc.col;
    s->leaves_parsed += count;
    return true;
}

/* Tells a truly singular transformation (a zero scale, a flattened Matrix) from one that
 * float merely cannot invert (Scale 1e30: its inverse is fine in exact arithmetic). The
 * rows of the 3x3 part are normalised first, so the test does not depend on the scale:
 * their determinant is the volume of three unit vectors (1 for any rotation and
 * scale). lo..hi: the shortest and longest row, the scale factors' span. */
static bool linear_part_singular(const Mat4 *m, double *lo, double *hi)
{
    double r[3][3];
    *lo = (double)INFINITY;
    *hi = 0.0;
    for (int i = 0; i < 3; i++) {
        double len = 0.0;
        for (int j = 0; j < 3; j++)
            len = hypot(len, (double)m->m[i][j]);
        *lo = fmin(*lo, len);
        *hi = fmax(*hi, len);
        if (!(len > 0.0) || !isfinite(len))
            return true;
        for (int j = 0; j < 3; j++)
            r[i][j] = (double)m->m[i][j] / len;
    }
    double det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) -
                 r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
                 r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    return !(fabs(det) > 1e-6);
}

/* The rows of OBJECT_KEYWORDS (k_objects also offers MaterialIndex, which is no object:
 * it sets the next ones' material). */
#define OBJECT_IS(name, parse) lex_is(t, name) ||
static bool is_object(const Token *t) { return OBJECT_KEYWORDS(OBJECT_IS) false; }
#undef OBJECT_IS

static bool enter(Parser *p, const Token *kw)
{
    if (p->depth >= RT_MAX_NESTING)
        return fail(p, &kw->loc, "objects nested deeper than %d levels", RT_MAX_NESTING);
    p->depth++;
    return true;
}

static bool need_material(Parser *p, const Token *kw)
{
    if (p->current)
        return true;
    char shown[64];
    return fail(p, &kw->loc, "no material selected for %s (MaterialIndex missing)",
                lex_show(kw, shown, sizeof shown));
}

static bool stack_push(Parser *p, Object3D *o)
{
    if (p->stack_len == p->stack_cap) {
        size_t nc = p->stack_cap ? p->stack_cap * 2 : 256;
        Object3D **ns = realloc(p->stack, nc * sizeof *ns);
        if (!ns)
            return false;
        p->stack = ns;
        p->stack_cap = nc;
    }
    p->stack[p->stack_len++] = o;
    return true;
}

static bool parse_group(Parser *p, const Token *kw, Object3D **out)
{
    int n;
    if (!enter(p, kw) || !expect(p, "{", NULL) || !read_count(p, "numObjects", &n))
        return false;
    size_t base = p->stack_len;
    int count = 0;
    for (;;) {
        Token t;
        if (!next(p, &t))
            return false;
        if (lex_is(&t, "}")) {
            if (count < n)
                return fail(p, &t.loc, "numObjects is %d but the group ends after %d object%s",
                            n, count, count == 1 ? "" : "s");
            break;
        }
        if (count == n) {
            if (is_object(&t))
                return fail(p, &t.loc, "numObjects is %d but the group has more objects", n);
            char what[64];
            snprintf(what, sizeof what, "'}' after %d object%s", n, n == 1 ? "" : "s");
            return fail_expected(p, &t, what);
        }
        if (lex_is(&t, "MaterialIndex")) {
            Token num;
            int i;
            if (!read_int_tok(p, &i, &num))
                return false;
            /* Indices resolve as they are read, so a Materials block after the Group
             * comes too late for it: say so when no block came before. */
            if (i < 0 || i >= p->s->num_materials)
                return fail(p, &num.loc, "MaterialIndex %d out of range (%d material%s%s)", i,
                            p->s->num_materials, p->s->num_materials == 1 ? "" : "s",
                            p->first_line[TOP_MATERIALS] ? ""
                                             : ": a Materials block must come before the Group");
            p->current = p->s->materials[i];
            continue;
        }
        if (!is_object(&t))
            return fail_unknown(p, &t, "object", "'}'");
        Object3D *child;
        if (!parse_object(p, &t, &child))
            return false;
        if (!stack_push(p, child))
            return out_of_memory(p, &t.loc);
        count++;
    }
    Object3D *g = group_new(&p->s->arena, n);
    if (!g)
        return out_of_memory(p, &kw->loc);
    for (int i = 0; i < n; i++)
        group_set_child(g, i, p->stack[base + (size_t)i]);
    group_finish(g);
    p->stack_len = base;
    p->depth--;
    *out = g;
    return true;
}

static bool parse_transform(Parser *p, const Token *kw, Object3D **out)
{
    if (!enter(p, kw) || !expect(p, "{", NULL))
        return false;
    Mat4 m = mat4_identity();
    Token t;
    for (;;) {
        if (!next(p, &t))
            return false;
        if (!is_transformation(&t))
            break;
        if (!parse_transformation(p, &t, &m))
            return false;
    }
    if (lex_is(&t, "}"))
        return fail(p, &t.loc, "Transform has no object (expected an object before '}')");
    if (lex_is(&t, "MaterialIndex"))
        return fail(p, &t.loc, "MaterialIndex is not allowed in a Transform (it holds "
                    "transformations and one object): put it before the Transform, in the "
                    "Group");
    if (!is_object(&t))
        return fail_unknown(p, &t, "transformation or object", "an object");
    Object3D *child;
    if (!parse_object(p, &t, &child))
        return false;
    if (!next(p, &t))
        return false;
    if (!lex_is(&t, "}")) {
        if (is_object(&t))
            return fail(p, &t.loc, "a Transform holds exactly one object; expected '}'");
        if (is_transformation(&t))
            return fail(p, &t.loc, "a Transform's transformations come before its object; "
                        "expected '}'");
        return fail_expected(p, &t, "'}'");
    }
    Object3D *x = transform_new(&p->s->arena, &m, child);
    if (!x) {
        Mat4 inv;
        if (!mat4_inverse(&m, &inv)) {
            double lo, hi;
            if (linear_part_singular(&m, &lo, &hi))
                return fail(p, &kw->loc, "singular transformation (the matrix has no inverse)");
            /* mat4_inverse judges the pivots against the largest entry of the linear
             * part and of the row 0 0 0 1: each factor must exceed 1e-12 of the
             * largest and of 1, and 1 must exceed 1e-12 of the largest. When the
             * linear part passes, the inverse's translation overflowed float. */
            Mat4 lin = m, lin_inv;
            lin.m[0][3] = lin.m[1][3] = lin.m[2][3] = 0.0f;
            if (mat4_inverse(&lin, &lin_inv))
                return fail(p, &kw->loc, "transformation too extreme to invert in float "
                            "precision: undoing its translation overflows float (scale "
                            "factors %.3g..%.3g)", lo, hi);
            return fail(p, &kw->loc, "transformation too extreme to invert in float precision: "
                        "its scale factors span %.3g..%.3g (keep them within 1e-12..1e12, the "
                        "smallest more than 1e-12 times the largest)", lo, hi);
        }
        return out_of_memory(p, &kw->loc);
    }
    p->depth--;
    *out = x;
    return true;
}

static bool parse_sphere(Parser *p, const Token *kw, Object3D **out)
{
    Vec3 c;
    float r;
    SrcLoc at;
    if (!need_material(p, kw) || !expect(p, "{", NULL) || !field_vec3(p, "center", &c, NULL) ||
        !field_float(p, "radius", &r, &at) || !expect(p, "}", NULL))
        return false;
    if (r < 0.0f)
        return fail(p, &at, "Sphere radius must not be negative, found %g", (double)r);
    /* Meaningful but almost surely a slip (or a radius under the float range, 1e-50): a
     * ray meets a point only tangentially, so the sphere draws nothing. Kept, so that a
     * scene that grows it later still reads. */
    if (r == 0.0f)
        diag_warning(p->diag, &at, "this Sphere's radius is 0 (in single precision): no ray "
                                   "hits it, so it draws nothing");
    *out = sphere_new(&p->s->arena, c, r, p->current);
    if (!*out)
        return out_of_memory(p, &kw->loc);
    return note_leaves(p, kw, 1);
}

static bool parse_plane(Parser *p, const Token *kw, Object3D **out)
{
    Vec3 n;
    float d;
    SrcLoc at;
    if (!need_material(p, kw) || !expect(p, "{", NULL) || !field_vec3(p, "normal", &n, &at) ||
        !field_float(p, "offset", &d, NULL) || !expect(p, "}", NULL))
        return false;
    if (v3_is_zero(n))
        return fail(p, &at, "Plane normal is zero");
    *out = plane_new(&p->s->arena, n, d, p->current);
    if (!*out)
        return out_of_memory(p, &kw->loc);
    return note_leaves(p, kw, 1);
}

static bool parse_triangle(Parser *p, const Token *kw, Object3D **out)
{
    Vec3 v[3];
    if (!need_material(p, kw) || !expect(p, "{", NULL) || !field_vec3(p, "vertex0", &v[0], NULL) ||
        !field_vec3(p, "vertex1", &v[1], NULL) || !field_vec3(p, "vertex2", &v[2], NULL) ||
        !expect(p, "}", NULL))
        return false;
    *out = triangle_new(&p->s->arena, v[0], v[1], v[2], p->current);
    if (!*out)
        return out_of_memory(p, &kw->loc);
    return note_leaves(p, kw, 1);
}

/* obj_file resolution: the scene file's folder first, then the working directory (the
 * course used the working directory only; running from elsewhere should still work). */
/* The cached parse of an OBJ file (-cache): its vertices and faces as objfile_parse
 * made them, found by the hash of the file's bytes. The arrays are the cache's
 * (read-only); every face index is checked against the vertex count, so a damaged
 * section cannot make the build read outside them. False: parse the file. */
static bool mesh_from_cache(SetupCache *c, SetupKey key, ObjMesh *mesh)
{
    const void *part[SETUP_CACHE_MAX_PARTS];
    size_t len[SETUP_CACHE_MAX_PARTS];
    int n = 0;
    if (!setup_cache_find(c, SETUP_TAG_MESH, key, part, len, &n) || n != 3 ||
        len[0] != 2 * sizeof(int32_t))
        return false;
    int32_t count[2];
    memcpy(count, part[0], sizeof count);
    if (count[0] <= 0 || count[1] <= 0 || len[1] != (size_t)count[0] * sizeof(Vec3) ||
        len[2] != (size_t)count[1] * sizeof(int[3]))
        return false;
    const int (*tris)[3] = part[2];
    for (int32_t t = 0; t < count[1]; t++)
        for (int k = 0; k < 3; k++)
            if (tris[t][k] < 0 || tris[t][k] >= count[0])
                return false;
    mesh->verts = (Vec3 *)part[1];
    mesh->nverts = count[0];
    mesh->tris = (int (*)[3])part[2];
    mesh->ntris = count[1];
    return true;
}

/* The key of an identity (rt/file.h) in the cache's SETUP_TAG_FILE sections. */
static SetupKey identity_key(const FileIdentity *id)
{
    uint64_t v[7] = {id->dev, id->ino, id->size, (uint64_t)id->mtime_s, (uint64_t)id->mtime_ns,
                     (uint64_t)id->ctime_s, (uint64_t)id->ctime_ns};
    return setup_hash(v, sizeof v, (SetupKey){SETUP_TAG_FILE, sizeof v});
}

/* -cache without reading the OBJ file: its settled identity (rt/file.h) names the key
 * of its bytes that an earlier process recorded, and that key the cached mesh. False
 * (nothing looked up, so nothing counted as a miss, when the identity is not settled):
 * read the file. */
static bool mesh_by_identity(SetupCache *c, const char *path, SetupKey *key, ObjMesh *mesh)
{
    FileIdentity id;
    if (!file_identity(path, &id) || !file_identity_settled(&id))
        return false;
    const void *part[SETUP_CACHE_MAX_PARTS];
    size_t len[SETUP_CACHE_MAX_PARTS];
    int n = 0;
    if (!setup_cache_find(c, SETUP_TAG_FILE, identity_key(&id), part, len, &n) || n != 1 ||
        len[0] != sizeof(SetupKey))
        return false;
    memcpy(key, part[0], sizeof *key);
    return mesh_from_cache(c, *key, mesh);
}

static void mesh_to_cache(SetupCache *c, SetupKey key, const ObjMesh *mesh)
{
    int32_t count[2] = {mesh->nverts, mesh->ntris};
    const void *part[3] = {count, mesh->verts, mesh->tris};
    size_t len[3] = {sizeof count, (size_t)mesh->nverts * sizeof(Vec3),
                     (size_t)mesh->ntris * sizeof(int[3])};
    setup_cache_add(c, SETUP_TAG_MESH, key, part, len, 3);
}

static bool parse_mesh(Parser *p, const Token *kw, Object3D **out)
{
    Token name;
    if (!need_material(p, kw) || !enter(p, kw) || !expect(p, "{", NULL) ||
        !expect(p, "obj_file", NULL) || !next(p, &name))
        return false;
    if (lex_eof(&name) || lex_is(&name, "}"))
        return fail_expected(p, &name, "an OBJ file name");
    if (memchr(name.text, '\0', name.len))
        return fail(p, &name.loc, "invalid OBJ file name (contains a NUL byte)");
    Token close;
    if (!next(p, &close))
        return false;
    if (!lex_is(&close, "}")) {
        /* "obj_file my model.obj": the name ended at the space, and its rest stands
         * where the '}' goes. Said so unless the token explains itself (a brace glued
         * to a word, a comment). */
        char shown[256], hint[160];
        if (lex_eof(&close))
            return fail_expected(p, &close, "'}'");
        lex_show(&close, shown, sizeof shown);
        token_hint(hint, sizeof hint, shown, NULL);
        return fail(p, &close.loc, "expected '}', found '%s'%s", shown,
                    hint[0] ? hint
                            : " (an OBJ file name is one word: it cannot contain white space)");
    }

    char file[LEX_MAX_TOKEN + 1];
    memcpy(file, name.text, name.len);
    file[name.len] = '\0';
    const char *base = p->base_dir;
    char *tried[2] = {NULL, NULL};
    int ntried = 0;
    if (file[0] != '/' && base && base[0] && strcmp(base, ".") != 0) {
        size_t bl = strlen(base);
        bool slash = base[bl - 1] == '/';
        tried[ntried] = malloc(bl + 1 + name.len + 1);
        if (!tried[ntried])
            return out_of_memory(p, &name.loc);
        snprintf(tried[ntried], bl + 1 + name.len + 1, "%s%s%s", base, slash ? "" : "/", file);
        ntried++;
    }
    tried[ntried] = malloc(name.len + 1);
    if (!tried[ntried]) {
        free(tried[0]);
        return out_of_memory(p, &name.loc);
    }
    memcpy(tried[ntried], file, name.len + 1);
    ntried++;

    char *buf = NULL;
    size_t len = 0;
    int used = -1, first_errno = 0;
    /* With -cache and files from the disk (not raytracer-mpi's broadcast set), a file
     * whose settled identity the cache knows is not even read (mesh_by_identity); one
     * that is read has its identity recorded when it stayed the same while it was read
     * and is settled. */
    bool by_identity = p->s->cache && !p->s->files;
    bool known = false, stable = false;
    SetupKey key = {0, 0};
    FileIdentity id;
    ObjMesh mesh = {0};
    for (int i = 0; i < ntried && used < 0; i++) {
        if (by_identity && mesh_by_identity(p->s->cache, tried[i], &key, &mesh))
            used = i, known = true;
        else if (by_identity ? file_read_reusable_identified(tried[i], &buf, &len, &id, &stable)
                             : scene_files_read(p->s->files, tried[i], true, &buf, &len))
            used = i;
        else if (!first_errno)
            first_errno = errno;
    }
    bool ok = true;
    if (used < 0 && par_stop_requested()) {
        /* A stop (Ctrl-C) cut the read short (rt/file.h): nothing to report, main says
         * "interrupted". */
        ok = false;
    } else if (used < 0) {
        char shown[256];
        lex_show(&name, shown, sizeof shown);
        /* Other formats quote file names; this one takes the quotes as part of it. */
        const char *quoted = file[0] == '"' || file[0] == '\''
                                 ? " (file names are written without quotes)"
                                 : "";
        if (ntried == 2)
            fail(p, &name.loc, "cannot open OBJ file '%s' (tried '%s', '%s'): %s%s", shown,
                 tried[0], tried[1], strerror(first_errno), quoted);
        else if (file[0] != '/' && name.loc.file && strcmp(name.loc.file, "<stdin>") == 0)
            /* A scene piped in has no folder of its own: its relative names are taken
             * from the working folder, which surprises a scene written for its folder. */
            fail(p, &name.loc, "cannot open OBJ file '%s' in the working folder (a scene "
                 "read from standard input has no folder of its own): %s%s", shown,
                 strerror(first_errno), quoted);
        else
            fail(p, &name.loc, "cannot open OBJ file '%s' (tried '%s'): %s%s", shown, tried[0],
                 strerror(first_errno), quoted);
        ok = false;
    } else {
        bool cached = known;
        if (p->s->cache) {
            if (!known) {
                key = setup_hash(buf, len, (SetupKey){SETUP_TAG_MESH, len});
                cached = mesh_from_cache(p->s->cache, key, &mesh);
                if (stable && file_identity_settled(&id)) {
                    const void *part[1] = {&key};
                    size_t plen[1] = {sizeof key};
                    setup_cache_add(p->s->cache, SETUP_TAG_FILE, identity_key(&id), part, plen, 1);
                }
            }
            p->s->inputs = setup_hash(&key, sizeof key, p->s->inputs);
        } else if (p->s->identify) {
            /* The same key of the bytes as with a cache: a render's identity does not
             * depend on -cache. */
            key = setup_hash(buf, len, (SetupKey){SETUP_TAG_MESH, len});
            p->s->inputs = setup_hash(&key, sizeof key, p->s->inputs);
        }
        ok = cached || objfile_parse(buf, len, tried[used], &mesh, p->diag);
        if (ok && !cached && p->s->cache && mesh.ntris > 0)
            mesh_to_cache(p->s->cache, key, &mesh);
        if (ok && mesh.ntris == 0) {
            char shown[256];
            /* Not a word on why, when a file of lone CRs began with a comment (as
             * exporters begin theirs): the whole file was that comment. */
            bool lone_cr = !cached && objfile_has_lone_cr(buf, len);
            fail(p, &name.loc, "OBJ file '%s' has no faces%s",
                 lex_show(&name, shown, sizeof shown),
                 lone_cr ? " (" OBJ_LONE_CR_HINT ")" : "");
            ok = false;
        }
        /* A stop (Ctrl-C) after the parse: the triangles are not made (a tenth of a
         * second per million); false with nothing reported, as objfile_parse's. */
        if (ok && par_stop_requested())
            ok = false;
        if (ok) {
            /* The text is parsed: its pages become the triangles' (arena.h). */
            *out = objfile_build_group(&p->s->arena, &mesh, p->current, buf);
            buf = NULL;
            if (cached)
                memset(&mesh, 0, sizeof mesh); /* the cache's memory: not ours to free */
            if (!*out)
                ok = out_of_memory(p, &name.loc);
            else
                ok = note_leaves(p, kw, (uint32_t)mesh.ntris);
        }
    }
    objfile_mesh_free(&mesh);
    arena_buffer_free(buf);
    free(tried[0]);
    free(tried[1]);
    if (ok)
        p->depth--;
    return ok;
}

static bool parse_object(Parser *p, const Token *kw, Object3D **out)
{
#define OBJECT_ROW(name, parse) {name, parse},
    static const struct {
        const char *name;
        bool (*parse)(Parser *p, const Token *kw, Object3D **out);
    } objects[] = {OBJECT_KEYWORDS(OBJECT_ROW)};
#undef OBJECT_ROW
    for (size_t i = 0; i < sizeof objects / sizeof objects[0]; i++)
        if (lex_is(kw, objects[i].name))
            return objects[i].parse(p, kw, out);
    return fail_unknown(p, kw, "object", "an object");
}

/* ---- cameras, background, lights (3-5) ----------------------------------------------- */

static bool parse_camera(Parser *p, bool perspective)
{
    Vec3 center, dir, up;
    float size;
    SrcLoc dir_at, up_at, size_at;
    if (!expect(p, "{", NULL) || !field_vec3(p, "center", &center, NULL) ||
        !field_vec3(p, "direction", &dir, &dir_at) || !field_vec3(p, "up", &up, &up_at) ||
        !field_float(p, perspective ? "angle" : "size", &size, &size_at) ||
        !expect(p, "}", NULL))
        return false;
    if (v3_is_zero(dir))
        return fail(p, &dir_at, "camera direction is zero");
    Camera cam;
    bool ok;
    if (perspective) {
        if (!(size > 0.0f && size < 180.0f))
            return fail(p, &size_at,
                        "angle must be more than 0 and less than 180 degrees, found %g",
                        (double)size);
        ok = camera_init_perspective(&cam, center, dir, up,
                                     (float)((double)size * M_PI / 180.0));
    } else {
        if (!(size > 0.0f))
            return fail(p, &size_at, "size must be positive, found %g", (double)size);
        ok = camera_init_orthographic(&cam, center, dir, up, size);
    }
    if (!ok)
        return fail(p, &up_at, "degenerate camera: up is zero or parallel to direction");
    p->s->camera = cam;
    p->s->has_camera = true;
    return true;
}

static bool parse_background(Parser *p)
{
    if (!expect(p, "{", NULL))
        return false;
    for (;;) {
        Token t;
        if (!next(p, &t))
            return false;
        if (lex_is(&t, "}"))
            return true;
        if (lex_is(&t, "color")) {
            if (!read_vec3(p, &p->s->background))
                return false;
        } else if (lex_is(&t, "ambientLight")) {
            if (!read_vec3(p, &p->s->ambient))
                return false;
        } else {
            return fail_unknown(p, &t, "Background field", "'}'");
        }
    }
}

static bool parse_light(Parser *p, const Token *kw, Light *l)
{
    memset(l, 0, sizeof *l);
    l->attenuation[0] = 1.0f;
    if (lex_is(kw, "DirectionalLight")) {
        SrcLoc at;
        l->kind = LIGHT_DIRECTIONAL;
        if (!expect(p, "{", NULL) || !field_vec3(p, "direction", &l->direction, &at) ||
            !field_vec3(p, "color", &l->color, NULL) || !expect(p, "}", NULL))
            return false;
        if (v3_is_zero(l->direction))
            return fail(p, &at, "light direction is zero");
        l->direction = v3_normalize(l->direction);
        return true;
    }
    if (lex_is(kw, "PointLight")) {
        l->kind = LIGHT_POINT;
        if (!expect(p, "{", NULL) || !field_vec3(p, "position", &l->position, NULL) ||
            !field_vec3(p, "color", &l->color, NULL))
            return false;
        Token t;
        if (!next(p, &t))
            return false;
        if (lex_is(&t, "attenuation")) {
            if (!read_float(p, &l->attenuation[0]) || !read_float(p, &l->attenuation[1]) ||
                !read_float(p, &l->attenuation[2]))
                return false;
            if (l->attenuation[0] == 0.0f && l->attenuation[1] == 0.0f &&
                l->attenuation[2] == 0.0f)
                return fail(p, &t.loc, "attenuation 0 0 0 would divide by zero");
            if (!next(p, &t))
                return false;
            if (!lex_is(&t, "}"))
                return fail_expected(p, &t, "'}'");
            return true;
        }
        if (!lex_is(&t, "}"))
            return fail_expected(p, &t, "'attenuation' or '}'");
        return true;
    }
    return fail_unknown(p, kw, "light", "'}'");
}

static bool is_light(const Token *t)
{
    return lex_is(t, "DirectionalLight") || lex_is(t, "PointLight");
}

static bool parse_lights(Parser *p)
{
    int n;
    if (!expect(p, "{", NULL) || !read_count(p, "numLights", &n))
        return false;
    Light *tmp = NULL;
    size_t cap = 0;
    int count = 0;
    bool ok = true;
    for (;;) {
        Token t;
        if (!next(p, &t)) {
            ok = false;
            break;
        }
        static const CountedBlock lights = {"numLights", "Lights", "light", is_light};
        CountedStep step = counted_step(p, &t, count, n, &lights);
        if (step != COUNTED_ITEM) {
            ok = step == COUNTED_END;
            break;
        }
        if ((size_t)count == cap) {
            size_t nc = cap ? cap * 2 : 8;
            Light *nt = realloc(tmp, nc * sizeof *nt);
            if (!nt) {
                ok = out_of_memory(p, &t.loc);
                break;
            }
            tmp = nt;
            cap = nc;
        }
        if (!parse_light(p, &t, &tmp[count])) {
            ok = false;
            break;
        }
        count++;
    }
    if (ok) {
        Light *arr = n ? arena_calloc(&p->s->arena, (size_t)n, sizeof *arr) : NULL;
        if (n && !arr) {
            SrcLoc none = {p->lx.file, 0, 0};
            ok = out_of_memory(p, &none);
        } else {
            if (n)
                memcpy(arr, tmp, (size_t)n * sizeof *arr);
            p->s->lights = arr;   /* a repeated block replaces the earlier one (2) */
            p->s->num_lights = n;
        }
    }
    free(tmp);
    return ok;
}

/* ---- materials (6) ----------------------------------------------------------------- */

typedef struct MatList {
    Material **mats;
    int *depth;                /* nesting depth of procedural chains (render recursion) */
    int cap;
} MatList;

static bool parse_phong(Parser *p, Material **out, const Token *kw)
{
    PhongParams pp = phong_defaults();
    if (!expect(p, "{", NULL))
        return false;
    for (;;) {
        Token t;
        if (!next(p, &t))
            return false;
        bool ok;
        if (lex_is(&t, "}"))
            break;
        else if (lex_is(&t, "diffuseColor"))
            ok = read_vec3(p, &pp.diffuse);
        else if (lex_is(&t, "specularColor"))
            ok = read_vec3(p, &pp.specular);
        else if (lex_is(&t, "exponent")) {
            ok = read_float(p, &pp.exponent);
            /* pow(0, negative) is infinite: a NaN/inf highlight, never what was meant. */
            if (ok && pp.exponent < 0.0f)
                return fail(p, &t.loc, "exponent must not be negative, found %g",
                            (double)pp.exponent);
        }
        else if (lex_is(&t, "reflectiveColor"))
            ok = read_vec3(p, &pp.reflective);
        else if (lex_is(&t, "transparentColor"))
            ok = read_vec3(p, &pp.transparent);
        else if (lex_is(&t, "indexOfRefraction")) {
            ok = read_float(p, &pp.ior);
            /* Snell's ratio divides by it. */
            if (ok && !(pp.ior > 0.0f))
                return fail(p, &t.loc, "indexOfRefraction must be positive, found %g",
                            (double)pp.ior);
        }
        else
            return fail_unknown(p, &t, "PhongMaterial field", "'}'");
        if (!ok)
            return false;
    }
    *out = phong_new(&p->s->arena, &pp);
    return *out || out_of_memory(p, &kw->loc);
}

/* materialIndex i inside material number self: only earlier materials (6.2). */
static bool read_mat_ref(Parser *p, const MatList *ml, int self, const Material **m,
                         int *depth)
{
    Token num;
    int i;
    if (!field_int(p, "materialIndex", &i, &num))
        return false;
    if (i < 0 || i >= self) {
        if (self == 0)
            return fail(p, &num.loc,
                        "materialIndex %d out of range (material 0 cannot refer to another; "
                        "only earlier materials may be used)", i);
        return fail(p, &num.loc,
                    "materialIndex %d out of range (only earlier materials 0..%d may be used)",
                    i, self - 1);
    }
    *m = ml->mats[i];
    if (ml->depth[i] > *depth)
        *depth = ml->depth[i];
    return true;
}

/* The constructors of PROCEDURAL_KEYWORDS, in one shape (those without the numbers
 * ignore them). */
static Material *make_checkerboard(Arena *a, const Mat4 *xf, const Material *m1,
                                   const Material *m2, int octaves, float freq, float amp)
{
    (void)octaves, (void)freq, (void)amp;
    return checkerboard_new(a, xf, m1, m2);
}
static Material *make_noise(Arena *a, const Mat4 *xf, const Material *m1, const Material *m2,
                            int octaves, float freq, float amp)
{
    (void)freq, (void)amp;
    return noise_new(a, xf, m1, m2, octaves);
}

/* A procedural material: [Transform { ... }], two earlier materials, then its numbers. */
static bool parse_procedural(Parser *p, const Token *kw, const MatList *ml, int self,
                             Material **out, int *depth)
{
#define PROCEDURAL_ROW(name, numbers, make) {name, numbers, make},
    static const struct ProceduralKind {
        const char *name;
        int numbers;
        Material *(*make)(Arena *a, const Mat4 *xf, const Material *m1, const Material *m2,
                          int octaves, float freq, float amp);
    } kinds[] = {PROCEDURAL_KEYWORDS(PROCEDURAL_ROW)};
#undef PROCEDURAL_ROW
    const struct ProceduralKind *kind = NULL;
    for (size_t i = 0; i < sizeof kinds / sizeof kinds[0] && !kind; i++)
        if (lex_is(kw, kinds[i].name))
            kind = &kinds[i];
    if (!kind)
        return fail_unknown(p, kw, "material", "a material");
    if (!expect(p, "{", NULL))
        return false;
    Token t;
    if (!lex_peek(&p->lx, &t))
        return false;
    Mat4 *xf = NULL;
    if (lex_is(&t, "Transform")) {
        (void)next(p, &t); /* the peeked token: cannot fail */
        if (!expect(p, "{", NULL))
            return false;
        Mat4 m = mat4_identity();
        for (;;) {
            Token u;
            if (!next(p, &u))
                return false;
            if (lex_is(&u, "}"))
                break;
            if (!is_transformation(&u))
                return fail_expected_among(p, &u, "a transformation or '}'",
                                           k_transformations);
            if (!parse_transformation(p, &u, &m))
                return false;
        }
        xf = arena_alloc(&p->s->arena, sizeof *xf);
        if (!xf)
            return out_of_memory(p, &t.loc);
        *xf = m;
    }
    const Material *m1, *m2;
    int d = 0;
    if (!read_mat_ref(p, ml, self, &m1, &d) || !read_mat_ref(p, ml, self, &m2, &d))
        return false;
    *depth = d + 1;
    if (*depth > RT_MAX_NESTING)
        return fail(p, &kw->loc, "procedural materials nested deeper than %d levels",
                    RT_MAX_NESTING);
    int octaves = 0;
    float freq = 0.0f, amp = 0.0f;
    Token num;
    if (kind->numbers >= 1) {
        if (!field_int(p, "octaves", &octaves, &num))
            return false;
        if (octaves < 0 || octaves > MAX_OCTAVES)
            return fail(p, &num.loc, "octaves must be between 0 and %d, found %d", MAX_OCTAVES,
                        octaves);
    }
    if (kind->numbers >= 3 &&
        (!field_float(p, "frequency", &freq, NULL) || !field_float(p, "amplitude", &amp, NULL)))
        return false;
    if (!expect(p, "}", NULL))
        return false;
    *out = kind->make(&p->s->arena, xf, m1, m2, octaves, freq, amp);
    return *out || out_of_memory(p, &kw->loc);
}

static bool is_material(const Token *t) { return is_among(t, k_materials); }

static bool parse_materials(Parser *p)
{
    int n;
    if (!expect(p, "{", NULL) || !read_count(p, "numMaterials", &n))
        return false;
    MatList ml = {NULL, NULL, 0};
    int count = 0;
    bool ok = true;
    for (;;) {
        Token t;
        if (!next(p, &t)) {
            ok = false;
            break;
        }
        static const CountedBlock materials = {"numMaterials", "Materials", "material",
                                               is_material};
        CountedStep step = counted_step(p, &t, count, n, &materials);
        if (step != COUNTED_ITEM) {
            ok = step == COUNTED_END;
            break;
        }
        if (count == ml.cap) {
            int nc = ml.cap ? ml.cap * 2 : 16;
            Material **nm = realloc(ml.mats, (size_t)nc * sizeof *nm);
            if (nm)
                ml.mats = nm;
            int *nd = nm ? realloc(ml.depth, (size_t)nc * sizeof *nd) : NULL;
            if (!nd) {
                ok = out_of_memory(p, &t.loc);
                break;
            }
            ml.depth = nd;
            ml.cap = nc;
        }
        Material *m = NULL;
        int depth = 1;
        if (lex_is(&t, "PhongMaterial") || lex_is(&t, "Material"))
            ok = parse_phong(p, &m, &t);
        else
            ok = parse_procedural(p, &t, &ml, count, &m, &depth);
        if (!ok)
            break;
        ml.mats[count] = m;
        ml.depth[count] = depth;
        count++;
    }
    if (ok) {
        Material **arr = n ? arena_calloc(&p->s->arena, (size_t)n, sizeof *arr) : NULL;
        if (n && !arr) {
            SrcLoc none = {p->lx.file, 0, 0};
            ok = out_of_memory(p, &none);
        } else {
            if (n)
                memcpy(arr, ml.mats, (size_t)n * sizeof *arr);
            p->s->materials = arr;   /* replaces an earlier block (2) */
            p->s->num_materials = n;
        }
    }
    free(ml.mats);
    free(ml.depth);
    return ok;
}

/* ---- file ------------------------------------------------------------------------- */

/* A second top-level block of a kind replaces the first (a Background only the fields
 * it sets; a Materials block only for the Groups read after it), as in the course's
 * parser; since that is rarely meant (two scenes pasted together, a block copied to be
 * edited), it gets a warning at the second block. */
static void note_top_block(Parser *p, const Token *t)
{
    static const char *const kinds[TOP_KINDS][2] = {
        [TOP_CAMERA] = {"OrthographicCamera", "PerspectiveCamera"},
        [TOP_BACKGROUND] = {"Background", NULL},
        [TOP_LIGHTS] = {"Lights", NULL},
        [TOP_MATERIALS] = {"Materials", NULL},
        [TOP_GROUP] = {"Group", NULL}};
    for (int k = 0; k < TOP_KINDS; k++)
        for (int j = 0; j < 2 && kinds[k][j]; j++) {
            if (!lex_is(t, kinds[k][j]))
                continue;
            if (p->first_line[k] == 0) {
                p->first_line[k] = t->loc.line;
                p->first_name[k] = kinds[k][j];
            } else if (k == TOP_CAMERA) {
                diag_warning(p->diag, &t->loc, "a second camera (%s): it overrides the %s "
                             "at line %d", kinds[k][j], p->first_name[k], p->first_line[k]);
            } else if (k == TOP_MATERIALS && p->first_line[TOP_GROUP]) {
                /* A Group's objects took their materials as it was read. */
                diag_warning(p->diag, &t->loc, "a second Materials block: it overrides the "
                             "one at line %d for Groups after it (the Group at line %d keeps "
                             "its materials)", p->first_line[k], p->first_line[TOP_GROUP]);
            } else {
                diag_warning(p->diag, &t->loc, "a second %s block: it overrides the one at "
                             "line %d%s", kinds[k][j], p->first_line[k],
                             k == TOP_BACKGROUND ? " (the fields it sets)" : "");
            }
            return;
        }
}

/* Whether token t is close enough to a top-level block's name to be a misspelling of it. */
static bool near_top_level(const Token *t)
{
    char shown[64];
    const char *hit;
    lex_show(t, shown, sizeof shown);
    return suggest_find(shown, k_top_level, name_count(k_top_level), &hit, 1) > 0;
}

bool scene_parse(Scene *s, const char *buf, size_t len, const char *name,
                 const char *base_dir, Diag *diag)
{
    Parser p;
    memset(&p, 0, sizeof p);
    p.s = s;
    p.diag = diag;
    p.base_dir = base_dir;
    lex_init(&p.lx, buf, len, name, diag);
    bool ok = true;
    for (;;) {
        Token t;
        if (!next(&p, &t)) {
            ok = false;
            break;
        }
        if (lex_eof(&t)) {
            s->end_line = t.loc.line;
            s->end_col = t.loc.col;
            break;
        }
        note_top_block(&p, &t);
        if (lex_is(&t, "OrthographicCamera"))
            ok = parse_camera(&p, false);
        else if (lex_is(&t, "PerspectiveCamera"))
            ok = parse_camera(&p, true);
        else if (lex_is(&t, "Background"))
            ok = parse_background(&p);
        else if (lex_is(&t, "Lights")) {
            s->lights_line = t.loc.line; /* a second block replaces the first */
            s->lights_col = t.loc.col;
            ok = parse_lights(&p);
        }
        else if (lex_is(&t, "Materials"))
            ok = parse_materials(&p);
        else if (lex_is(&t, "Group")) {
            Object3D *root;
            ok = parse_group(&p, &t, &root);
            if (ok)
                s->root = root;   /* a second Group replaces the first (2) */
        } else if ((is_object(&t) || lex_is(&t, "MaterialIndex") || is_light(&t) ||
                    is_material(&t)) && !near_top_level(&t)) {
            /* A correct keyword in the wrong place: say which block takes it (unless it
             * is one letter from a block's name: "Material" for Materials). */
            char shown[64];
            lex_show(&t, shown, sizeof shown);
            ok = fail(&p, &t.loc, "'%s' is not a top-level block: %s", shown,
                      is_light(&t) ? "lights go inside Lights { numLights N ... }"
                      : is_material(&t) ? "materials go inside Materials { numMaterials N ... }"
                      : is_object(&t) ? "objects go inside Group { numObjects N ... }"
                                      : "MaterialIndex lines go inside Group { numObjects N ... }");
        } else {
            ok = fail_unknown(&p, &t, "top-level block", "a block");
        }
        if (!ok)
            break;
    }
    free(p.stack);
    return ok;
}
