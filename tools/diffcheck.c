/* diffcheck: a differential checker for the byte rule. It writes random valid scenes in
 * the course format (cameras, lights, Group/Transform nesting, spheres, planes, triangles,
 * small OBJ meshes, Phong and procedural materials), renders each through the binary
 * under several shading option sets, and for every option set compares the bytes of
 * every image (and the -stats block, minus its time lines) between renders that must
 * agree: brute force against -grid auto, -grid NX NY NZ and -accel twolevel, packets
 * against -no_packets, 1 against 2 and 3 threads. -stats turns packets off, so only a
 * few variants carry it; the others cover the packet paths.
 *
 * Needs nothing from librt: it only runs the binary (fork + execv, no shell). Usage in
 * usage() below; docs/tests-and-ci.md says how it is run and what a finding looks like.
 * Exit status: 0 every comparison agreed, 1 a difference or a failed render (each
 * reported with the two command lines; its scene is kept), 2 a usage or set-up error. */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <dirent.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

/* ---- text buffers ---------------------------------------------------------------- */

typedef struct Buf {
    char *s;
    size_t len, cap;
} Buf;

static void die(const char *fmt, ...) __attribute__((format(printf, 1, 2), noreturn));
static void die(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    fputs("diffcheck: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    va_end(ap);
    exit(2);
}

/* snprintf that refuses to cut: every path and message here fits, or the run stops. */
static void fmt(char *buf, size_t size, const char *f, ...) __attribute__((format(printf, 3, 4)));
static void fmt(char *buf, size_t size, const char *f, ...)
{
    va_list ap;
    va_start(ap, f);
    int n = vsnprintf(buf, size, f, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= size)
        die("a path or message longer than %zu bytes", size);
}

static void bprintf(Buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void bprintf(Buf *b, const char *fmt, ...)
{
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        size_t room = b->cap - b->len;
        int n = vsnprintf(b->s ? b->s + b->len : NULL, room, fmt, ap);
        va_end(ap);
        if (n < 0)
            die("formatting failed");
        if ((size_t)n < room) {
            b->len += (size_t)n;
            return;
        }
        size_t cap = b->cap ? b->cap : 4096;
        while (cap - b->len <= (size_t)n)
            cap *= 2;
        char *s = realloc(b->s, cap);
        if (!s)
            die("out of memory");
        b->s = s;
        b->cap = cap;
    }
}

/* b's text as the file dir/name (its path in path, when path is not NULL); a scene,
 * a mesh or a reduced scene that cannot be written ends the run. */
static void buf_write(const Buf *b, const char *dir, const char *name, char *path,
                      size_t size)
{
    char here[4096];
    if (!path) {
        path = here;
        size = sizeof here;
    }
    fmt(path, size, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f || fwrite(b->s, 1, b->len, f) != b->len || fclose(f) != 0)
        die("cannot write %s: %s", path, strerror(errno));
}

static char *xstrdup(const char *s)
{
    char *d = strdup(s);
    if (!d)
        die("out of memory");
    return d;
}

/* ---- random numbers (splitmix64: the same scenes for a seed on every machine) ----- */

static uint64_t rng;

static uint64_t rnext(void)
{
    uint64_t z = (rng += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

static double urand(double lo, double hi)
{
    return lo + (double)(rnext() >> 11) * (1.0 / 9007199254740992.0) * (hi - lo);
}

static int irand(int n) { return (int)(rnext() % (uint64_t)n); }
static int irange(int lo, int hi) { return lo + irand(hi - lo + 1); }
static bool chance(double p) { return urand(0, 1) < p; }

/* A coordinate: often a multiple of 0.5, so objects share planes, edges and cell
 * boundaries (the grid's and the packets' ties), otherwise 3 decimals. */
static double coord(double lo, double hi)
{
    double x = urand(lo, hi);
    if (chance(0.35))
        return round(x * 2.0) / 2.0;
    return round(x * 1000.0) / 1000.0;
}

static double pos(double lo, double hi) { return round(urand(lo, hi) * 1000.0) / 1000.0; }

static void put3(Buf *b, double x, double y, double z) { bprintf(b, "%g %g %g", x, y, z); }

static void put_colour(Buf *b, double lo, double hi)
{
    put3(b, pos(lo, hi), pos(lo, hi), pos(lo, hi));
}

static void put_dir(Buf *b)
{
    /* An axis now and then (rays parallel to cell walls), else a random direction. */
    if (chance(0.3)) {
        int a = irand(3);
        double s = chance(0.5) ? 1 : -1;
        put3(b, a == 0 ? s : 0, a == 1 ? s : 0, a == 2 ? s : 0);
        return;
    }
    double x, y, z;
    do {
        x = coord(-1, 1);
        y = coord(-1, 1);
        z = coord(-1, 1);
    } while (fabs(x) + fabs(y) + fabs(z) < 0.2);
    put3(b, x, y, z);
}

/* ---- scene generation -------------------------------------------------------------- */

enum { MAX_ITEMS = 64, MAX_LIGHTS = 3 };

/* A scene in the pieces the reducer (reduce below) leaves out one by one: the root
 * Group's objects and the lights. */
typedef struct Gen {
    Buf scene;            /* the whole text (scene_text) */
    Buf head;             /* camera and background */
    Buf mats;             /* the Materials block */
    bool lights_block;    /* a Lights block, even with 0 lights */
    char *lights[MAX_LIGHTS];
    int nlights;
    int mat0;             /* the root Group's first MaterialIndex */
    char *items[MAX_ITEMS]; /* the root Group's objects, each with its MaterialIndex line */
    int nitems;
    const char *dir;      /* the scene's folder, where its OBJ files go */
    int nmat;
    int nmesh;
    int budget;           /* objects left to write (keeps scenes small) */
    char *prims[32];      /* earlier primitives' text, written again as exact twins */
    int nprims;
} Gen;

static void gen_transformations(Buf *b, int max)
{
    int n = irand(max + 1);
    for (int i = 0; i < n; i++) {
        switch (irand(8)) {
        case 0: {
            /* Non-uniform, sometimes mirroring: the normals' inverse transpose. */
            double s[3];
            for (int k = 0; k < 3; k++) {
                s[k] = pos(0.3, 2.0);
                if (chance(0.12))
                    s[k] = -s[k];
            }
            bprintf(b, " Scale ");
            put3(b, s[0], s[1], s[2]);
            break;
        }
        case 1:
            bprintf(b, " UniformScale %g", pos(0.3, 2.0));
            break;
        case 2:
        case 3:
            bprintf(b, " Translate ");
            put3(b, coord(-2, 2), coord(-2, 2), coord(-2, 2));
            break;
        case 4: {
            const char *axis[] = {"XRotate", "YRotate", "ZRotate"};
            double d = chance(0.4) ? 90.0 * irange(-2, 2) : pos(-180, 180);
            bprintf(b, " %s %g", axis[irand(3)], d);
            break;
        }
        case 5:
            /* The course does not normalise the axis: a long one is not rigid. */
            bprintf(b, " Rotate { ");
            put_dir(b);
            bprintf(b, " %g }", pos(-180, 180));
            break;
        case 6:
        case 7: {
            /* Identity plus shears below 0.3 on a diagonal of 0.7 or more: diagonally
             * dominant, so always invertible. Last row 0 0 0 1 as required. */
            bprintf(b, " Matrix {");
            for (int r = 0; r < 3; r++) {
                for (int c = 0; c < 3; c++)
                    bprintf(b, " %g", r == c ? pos(0.7, 1.5) * (chance(0.1) ? -1 : 1)
                                             : (chance(0.5) ? 0.0 : pos(-0.28, 0.28)));
                bprintf(b, " %g", coord(-1.5, 1.5));
            }
            bprintf(b, " 0 0 0 1 }");
            break;
        }
        }
    }
}

static void gen_materials(Gen *g)
{
    Buf *b = &g->mats;
    g->nmat = irange(2, 8);
    bprintf(b, "Materials {\n  numMaterials %d\n", g->nmat);
    for (int i = 0; i < g->nmat; i++) {
        /* The first two are Phong, so every procedural material has two to name. */
        int kind = i < 2 ? 0 : (chance(0.5) ? 0 : irange(1, 4));
        if (kind == 0) {
            bprintf(b, "  PhongMaterial {");
            if (chance(0.9)) {
                bprintf(b, " diffuseColor ");
                put_colour(b, 0, 1);
            }
            if (chance(0.6)) {
                bprintf(b, " specularColor ");
                put_colour(b, 0, 1);
                bprintf(b, " exponent %g", chance(0.1) ? 0.0 : pos(1, 100));
            }
            if (chance(0.35)) {
                bprintf(b, " reflectiveColor ");
                put_colour(b, 0, 0.9);
            }
            if (chance(0.3)) {
                bprintf(b, " transparentColor ");
                put_colour(b, 0, 0.95);
                bprintf(b, " indexOfRefraction %g", chance(0.15) ? 1.0 : pos(0.7, 2.2));
            }
            bprintf(b, " }\n");
            continue;
        }
        const char *names[] = {"", "Checkerboard", "Noise", "Marble", "Wood"};
        bprintf(b, "  %s {", names[kind]);
        if (chance(0.7)) {
            bprintf(b, " Transform {");
            gen_transformations(b, 3);
            bprintf(b, " }");
        }
        /* Either may itself be procedural (nested textures). */
        bprintf(b, " materialIndex %d materialIndex %d", irand(i), irand(i));
        if (kind >= 2)
            bprintf(b, " octaves %d", irange(0, 4));
        if (kind >= 3)
            bprintf(b, " frequency %g amplitude %g", pos(0.5, 6), pos(0.2, 5));
        bprintf(b, " }\n");
    }
    bprintf(b, "}\n");
}

/* A small OBJ file beside the scene: a triangle soup, a box or a height field, with
 * quads (split into fans), negative indices and comments now and then. */
static void gen_obj(Gen *g, char *name, size_t size)
{
    fmt(name, size, "m%d.obj", g->nmesh++);
    Buf o = {0};
    bprintf(&o, "# diffcheck mesh\n");
    int kind = irand(3);
    if (kind == 0) {
        int nt = irange(1, 24);
        for (int i = 0; i < 3 * nt; i++) {
            bprintf(&o, "v ");
            put3(&o, coord(-1, 1), coord(-1, 1), coord(-1, 1));
            bprintf(&o, "\n");
        }
        for (int i = 0; i < nt; i++) {
            if (chance(0.2))
                bprintf(&o, "f -3 -2 -1\n"); /* the last three vertices read */
            else
                bprintf(&o, "f %d %d %d\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
        }
    } else if (kind == 1) {
        double lo[3], hi[3];
        for (int k = 0; k < 3; k++) {
            lo[k] = coord(-1, 0);
            hi[k] = lo[k] + pos(0.1, 1.5);
        }
        for (int v = 0; v < 8; v++) {
            bprintf(&o, "v ");
            put3(&o, v & 1 ? hi[0] : lo[0], v & 2 ? hi[1] : lo[1], v & 4 ? hi[2] : lo[2]);
            bprintf(&o, "\n");
        }
        /* Outward counter-clockwise quads of the box (vertex bit 1 = x, 2 = y, 4 = z). */
        static const int quads[6][4] = {{1, 5, 7, 3}, {2, 4, 8, 6}, {1, 2, 6, 5},
                                        {3, 7, 8, 4}, {1, 3, 4, 2}, {5, 6, 8, 7}};
        for (int f = 0; f < 6; f++) {
            if (chance(0.5))
                bprintf(&o, "f %d %d %d %d\n", quads[f][0], quads[f][1], quads[f][2],
                        quads[f][3]);
            else
                bprintf(&o, "f %d %d %d\nf %d %d %d\n", quads[f][0], quads[f][1],
                        quads[f][2], quads[f][0], quads[f][2], quads[f][3]);
        }
    } else {
        int nx = irange(2, 6), nz = irange(2, 6);
        double step = pos(0.1, 0.5);
        for (int z = 0; z < nz; z++)
            for (int x = 0; x < nx; x++)
                bprintf(&o, "v %g %g %g\n", (x - nx / 2) * step,
                        chance(0.3) ? 0.0 : pos(-0.3, 0.3), (z - nz / 2) * step);
        for (int z = 0; z + 1 < nz; z++)
            for (int x = 0; x + 1 < nx; x++) {
                int a = z * nx + x + 1, c = a + nx;
                bprintf(&o, "f %d %d %d\nf %d/1 %d/1 %d/1\n", a, c, a + 1, a + 1, c, c + 1);
            }
    }
    buf_write(&o, g->dir, name, NULL, 0);
    free(o.s);
}

/* -crowded: a dense cluster of small triangles (a mesh written beside the scene), so
 * that -grid auto takes the two-level grid (its crowding test, docs/twolevel.md) and
 * -accel twolevel builds leaf grids. Drawn from a stream of its own (crowded_stream), so
 * the scenes of a seed without -crowded stay what they were. */
static double crowded_p;
static long n_crowded;

static void gen_cluster(Gen *g, Buf *b)
{
    char name[64];
    fmt(name, sizeof name, "c%d.obj", g->nmesh++);
    Buf o = {0};
    bprintf(&o, "# diffcheck cluster\n");
    double c[3], s = pos(0.05, 0.5);
    for (int k = 0; k < 3; k++)
        c[k] = coord(-1.5, 1.5);
    int nt = irange(40, 240), flat = chance(0.3) ? irand(3) : -1;
    for (int i = 0; i < nt; i++) {
        /* Small triangles inside the cluster's cube, a third of them in an axis plane,
         * some with a vertex on the cube's faces (ties with the leaf grids' borders). */
        double p[3], e = s * pos(0.02, 0.3);
        for (int k = 0; k < 3; k++)
            p[k] = c[k] + (chance(0.1) ? (chance(0.5) ? s : -s) : urand(-s, s));
        int plane = flat >= 0 ? flat : chance(0.3) ? irand(3) : -1;
        for (int v = 0; v < 3; v++) {
            double q[3];
            for (int k = 0; k < 3; k++)
                q[k] = v == 0 || k == plane ? p[k] : p[k] + urand(-e, e);
            bprintf(&o, "v %.6g %.6g %.6g\n", q[0], q[1], q[2]);
        }
        bprintf(&o, "f %d %d %d\n", 3 * i + 1, 3 * i + 2, 3 * i + 3);
    }
    buf_write(&o, g->dir, name, NULL, 0);
    free(o.s);
    bprintf(b, "TriangleMesh { obj_file %s }", name);
}

static void gen_primitive(Gen *g, Buf *b)
{
    size_t start = b->len;
    if (g->nprims > 0 && chance(0.1)) {
        /* An exact twin of an earlier primitive (often under another material): ties
         * that the grid and brute force must break the same way. */
        bprintf(b, "%s", g->prims[irand(g->nprims)]);
        return;
    }
    int kind = irand(10);
    if (kind < 4) {
        bprintf(b, "Sphere { center ");
        put3(b, coord(-2, 2), coord(-2, 2), coord(-2, 2));
        bprintf(b, " radius %g }", chance(0.03) ? 0.0 : pos(0.05, 1.2));
    } else if (kind < 5) {
        bprintf(b, "Plane { normal ");
        put_dir(b);
        bprintf(b, " offset %g }", coord(-3, 1));
    } else if (kind < 8) {
        bprintf(b, "Triangle {");
        int flat = chance(0.3) ? irand(3) : -1; /* all three in one axis plane */
        double fv = coord(-2, 2);
        /* Rarely degenerate: two vertices the same, or the third halfway between the
         * first two (no area, no normal; every path must miss it alike). */
        int degenerate = chance(0.04) ? irange(1, 2) : 0;
        double p[3][3];
        for (int v = 0; v < 3; v++) {
            for (int k = 0; k < 3; k++)
                p[v][k] = coord(-2, 2);
            if (flat >= 0)
                p[v][flat] = fv;
        }
        for (int k = 0; k < 3 && degenerate; k++)
            p[2][k] = degenerate == 1 ? p[0][k] : (p[0][k] + p[1][k]) / 2;
        for (int v = 0; v < 3; v++) {
            bprintf(b, " vertex%d ", v);
            put3(b, p[v][0], p[v][1], p[v][2]);
        }
        bprintf(b, " }");
    } else {
        char name[64];
        gen_obj(g, name, sizeof name);
        bprintf(b, "TriangleMesh { obj_file %s }", name);
    }
    if (g->nprims < (int)(sizeof g->prims / sizeof g->prims[0]))
        g->prims[g->nprims++] = xstrdup(b->s + start);
}

static void gen_object(Gen *g, Buf *b, int depth, int indent);

static void gen_group_body(Gen *g, Buf *b, int n, int depth, int indent)
{
    bprintf(b, "Group {\n%*snumObjects %d\n", indent + 2, "", n);
    for (int i = 0; i < n; i++) {
        if (chance(0.35))
            bprintf(b, "%*sMaterialIndex %d\n", indent + 2, "", irand(g->nmat));
        bprintf(b, "%*s", indent + 2, "");
        gen_object(g, b, depth + 1, indent + 2);
        bprintf(b, "\n");
    }
    bprintf(b, "%*s}", indent, "");
}

static void gen_object(Gen *g, Buf *b, int depth, int indent)
{
    g->budget--;
    int r = irand(10);
    if (depth < 4 && g->budget > 2 && r < 3) {
        bprintf(b, "Transform {");
        gen_transformations(b, 3);
        bprintf(b, "\n%*s", indent + 2, "");
        gen_object(g, b, depth + 1, indent + 2);
        bprintf(b, "\n%*s}", indent, "");
    } else if (depth < 4 && g->budget > 3 && r < 4) {
        gen_group_body(g, b, irange(1, g->budget < 4 ? 1 : 4), depth, indent);
    } else {
        gen_primitive(g, b);
    }
}

/* The scene text into out, with the root objects and lights whose keep flag is set
 * (NULL: all). */
static void scene_text(const Gen *g, const bool *keep_item, const bool *keep_light, Buf *out)
{
    out->len = 0;
    bprintf(out, "%s", g->head.s);
    if (g->lights_block) {
        int nl = 0;
        for (int i = 0; i < g->nlights; i++)
            nl += !keep_light || keep_light[i];
        bprintf(out, "Lights {\n  numLights %d\n", nl);
        for (int i = 0; i < g->nlights; i++)
            if (!keep_light || keep_light[i])
                bprintf(out, "%s", g->lights[i]);
        bprintf(out, "}\n");
    }
    bprintf(out, "%s", g->mats.s);
    int n = 0;
    for (int i = 0; i < g->nitems; i++)
        n += !keep_item || keep_item[i];
    bprintf(out, "Group {\n  numObjects %d\n  MaterialIndex %d\n", n, g->mat0);
    for (int i = 0; i < g->nitems; i++)
        if (!keep_item || keep_item[i])
            bprintf(out, "%s", g->items[i]);
    bprintf(out, "}\n");
}

static void gen_free(Gen *g)
{
    for (int k = 0; k < g->nprims; k++)
        free(g->prims[k]);
    for (int k = 0; k < g->nlights; k++)
        free(g->lights[k]);
    for (int k = 0; k < g->nitems; k++)
        free(g->items[k]);
    free(g->scene.s);
    free(g->head.s);
    free(g->mats.s);
}

/* A new scene into g's pieces and g->scene. */
static void gen_scene(Gen *g)
{
    Buf *b = &g->head;
    /* Camera: looking at a point near the origin from outside the objects' box, or from
     * inside it (rays that start inside the grid); an axis-parallel view now and then. */
    double c[3], t[3] = {pos(-0.5, 0.5), pos(-0.5, 0.5), pos(-0.5, 0.5)};
    double dist = chance(0.15) ? pos(0.3, 2.0) : pos(3.5, 9);
    /* Now and then from thousands of scene sizes away (through a narrow perspective
     * angle): rays whose origins are far outside the grid's box, which the packet walk
     * sends to the single-ray march (docs/grid.md). */
    bool far = chance(0.08);
    if (far)
        dist *= 1000.0;
    if (chance(0.25)) {
        int a = irand(3);
        for (int k = 0; k < 3; k++)
            c[k] = k == a ? (chance(0.5) ? dist : -dist) : 0.0;
        t[0] = t[1] = t[2] = 0.0;
    } else {
        double d[3], l;
        do {
            for (int k = 0; k < 3; k++)
                d[k] = urand(-1, 1);
            l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        } while (l < 0.2 || l > 1);
        for (int k = 0; k < 3; k++)
            c[k] = round((t[k] + d[k] / l * dist) * 1000.0) / 1000.0;
    }
    double dir[3] = {t[0] - c[0], t[1] - c[1], t[2] - c[2]};
    /* An up vector well away from the direction. */
    double up[3] = {0, 1, 0};
    double dl = sqrt(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
    if (chance(0.3))
        for (int k = 0; k < 3; k++)
            up[k] = coord(-1, 1);
    double cr[3] = {dir[1] * up[2] - dir[2] * up[1], dir[2] * up[0] - dir[0] * up[2],
                    dir[0] * up[1] - dir[1] * up[0]};
    double ul = sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]);
    if (ul < 1e-3 || sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]) < 0.3 * dl * ul) {
        up[0] = fabs(dir[0]) < 0.5 * dl ? 1 : 0;
        up[1] = 0;
        up[2] = fabs(dir[0]) < 0.5 * dl ? 0 : 1;
    }
    if (chance(0.5)) {
        bprintf(b, "OrthographicCamera { center ");
        put3(b, c[0], c[1], c[2]);
        bprintf(b, " direction ");
        put3(b, dir[0], dir[1], dir[2]);
        bprintf(b, " up ");
        put3(b, up[0], up[1], up[2]);
        bprintf(b, " size %g }\n", pos(2, 6));
    } else {
        bprintf(b, "PerspectiveCamera { center ");
        put3(b, c[0], c[1], c[2]);
        bprintf(b, " direction ");
        put3(b, dir[0], dir[1], dir[2]);
        bprintf(b, " up ");
        put3(b, up[0], up[1], up[2]);
        bprintf(b, " angle %g }\n", far ? pos(0.1, 0.5) : pos(20, 75));
    }
    if (chance(0.85)) {
        bprintf(b, "Background {");
        if (chance(0.8)) {
            bprintf(b, " color ");
            put_colour(b, 0, 1);
        }
        if (chance(0.8)) {
            bprintf(b, " ambientLight ");
            put_colour(b, 0, 0.4);
        }
        bprintf(b, " }\n");
    }
    int nl = chance(0.1) ? 0 : irange(1, MAX_LIGHTS);
    g->lights_block = nl > 0 || chance(0.5);
    for (int i = 0; i < nl && g->lights_block; i++) {
        Buf l = {0};
        if (chance(0.5)) {
            bprintf(&l, "  DirectionalLight { direction ");
            put_dir(&l);
            bprintf(&l, " color ");
            put_colour(&l, 0.2, 1.2);
            bprintf(&l, " }\n");
        } else {
            bprintf(&l, "  PointLight { position ");
            put3(&l, coord(-5, 5), coord(-5, 5), coord(-5, 5));
            bprintf(&l, " color ");
            put_colour(&l, 0.2, 1.5);
            if (chance(0.6)) {
                double a = chance(0.3) ? 0.0 : pos(0.2, 1), lin = pos(0, 0.5),
                       q = chance(0.4) ? 0.0 : pos(0, 0.1);
                if (a + lin + q == 0.0)
                    a = 1;
                bprintf(&l, " attenuation %g %g %g", a, lin, q);
            }
            bprintf(&l, " }\n");
        }
        g->lights[g->nlights++] = l.s;
    }
    gen_materials(g);
    /* Now and then many small objects, so a grid has crowded and empty cells. */
    g->budget = chance(0.2) ? irange(20, 60) : irange(1, 14);
    int top = g->budget > 8 ? g->budget : irange(1, g->budget);
    g->mat0 = irand(g->nmat);
    for (int i = 0; i < top; i++) {
        Buf it = {0};
        if (i > 0 && chance(0.35))
            bprintf(&it, "  MaterialIndex %d\n", irand(g->nmat));
        bprintf(&it, "  ");
        gen_object(g, &it, 1, 2);
        bprintf(&it, "\n");
        g->items[g->nitems++] = it.s;
    }
    if (crowded_p > 0.0) {
        /* Its own stream (from the main one's state, which is then put back). */
        uint64_t saved = rng;
        rng ^= 0xC3A5C85C97CB3127ull;
        rnext();
        if (chance(crowded_p) && g->nitems < MAX_ITEMS) {
            Buf it = {0};
            bprintf(&it, "  ");
            gen_cluster(g, &it);
            bprintf(&it, "\n");
            g->items[g->nitems++] = it.s;
            n_crowded++;
        }
        rng = saved;
    }
    scene_text(g, NULL, NULL, &g->scene);
}

#define MAX_ARGS 64

typedef struct Args {
    char *v[MAX_ARGS];
    int n;
    int stack_kb; /* > 0: run under this stack limit (ulimit -s) */
} Args;

/* ---- running the binary ------------------------------------------------------------- */

static const char *bin = "./raytracer";
static int timeout_s = 120;
static int verbose;

/* Runs bin with args in folder dir, stdout into out_path, stderr into err_path.
 * Returns the exit status, 128 + signal when killed. */
static int run(const char *dir, const Args *a, const char *out_path, const char *err_path)
{
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid < 0)
        die("fork: %s", strerror(errno));
    if (pid == 0) {
        int in = open("/dev/null", O_RDONLY);
        int out = open(out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        int err = open(err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (in < 0 || out < 0 || err < 0 || chdir(dir) != 0)
            _exit(126);
        dup2(in, 0);
        dup2(out, 1);
        dup2(err, 2);
        /* Under 1 MiB of stack the tracer sends secondary rays one by one instead of in
         * packets (depth_choose in src/render/raytracer.c): another path to compare. */
        if (a->stack_kb > 0) {
            struct rlimit rl;
            if (getrlimit(RLIMIT_STACK, &rl) != 0)
                _exit(125);
            rl.rlim_cur = (rlim_t)a->stack_kb * 1024;
            if (setrlimit(RLIMIT_STACK, &rl) != 0)
                _exit(125);
        }
        /* A pending alarm survives execv: a render that hangs is killed. */
        alarm((unsigned)timeout_s);
        execv(a->v[0], a->v);
        _exit(127);
    }
    int st;
    while (waitpid(pid, &st, 0) < 0)
        if (errno != EINTR)
            die("waitpid: %s", strerror(errno));
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
}

static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    Buf b = {0};
    bprintf(&b, "%s", "");
    char chunk[65536];
    size_t n;
    while ((n = fread(chunk, 1, sizeof chunk, f)) > 0) {
        if (b.len + n + 1 > b.cap) {
            size_t cap = b.cap * 2 + n + 1;
            char *s = realloc(b.s, cap);
            if (!s)
                die("out of memory");
            b.s = s;
            b.cap = cap;
        }
        memcpy(b.s + b.len, chunk, n);
        b.len += n;
        b.s[b.len] = '\0';
    }
    fclose(f);
    *len = b.len;
    return b.s;
}

/* The -stats block without the lines that depend on time. */
static char *stats_without_time(const char *path)
{
    size_t len;
    char *s = slurp(path, &len);
    if (!s)
        return NULL;
    Buf b = {0};
    bprintf(&b, "%s", "");
    for (char *line = s; *line;) {
        char *end = strchr(line, '\n');
        char *next = end ? end + 1 : line + strlen(line);
        if (end)
            *end = '\0';
        if (!strstr(line, "total time") && !strstr(line, "rays per second"))
            bprintf(&b, "%s\n", line);
        line = next;
    }
    free(s);
    return b.s;
}

/* ---- the option sets and their variants --------------------------------------------- */



static void add(Args *a, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void add(Args *a, const char *fmt, ...)
{
    if (a->n + 2 >= MAX_ARGS)
        die("too many arguments");
    char tmp[4096];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(tmp, sizeof tmp, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof tmp)
        die("an argument longer than %zu bytes", sizeof tmp);
    a->v[a->n++] = xstrdup(tmp);
    a->v[a->n] = NULL;
}

static void args_free(Args *a)
{
    for (int i = 0; i < a->n; i++)
        free(a->v[i]);
    a->n = 0;
}

static void args_text(const Args *a, Buf *b)
{
    if (a->stack_kb > 0)
        bprintf(b, "(ulimit -s %d) ", a->stack_kb);
    for (int i = 0; i < a->n; i++)
        bprintf(b, "%s%s", i ? " " : "", a->v[i]);
}

/* One shading option set: everything but the accelerator, threads, packets and -stats,
 * which the variants choose. */
typedef struct Shading {
    char ext[8];
    int w, h;
    bool depth, normals, antialiased;
    Args opts;
} Shading;

static void gen_shading(Shading *s, bool quick)
{
    memset(s, 0, sizeof *s);
    fmt(s->ext, sizeof s->ext, "%s", chance(0.8) ? "tga" : "ppm");
    /* Small, and often not a multiple of the 8x8 packets (partial packets at the edges). */
    int w = quick ? irange(6, 20) : irange(6, 40), h = quick ? irange(6, 20) : irange(6, 40);
    add(&s->opts, "-size");
    add(&s->opts, "%d", w);
    add(&s->opts, "%d", h);
    s->w = w;
    s->h = h;
    if (chance(0.6))
        add(&s->opts, "-shadows");
    if (chance(0.5))
        add(&s->opts, "-shade_back");
    if (chance(0.75)) {
        add(&s->opts, "-bounces");
        add(&s->opts, "%d", irange(0, quick ? 4 : 8));
    }
    if (chance(0.4)) {
        static const char *w8[] = {"0", "0.01", "0.1", "0.3"};
        add(&s->opts, "-weight");
        add(&s->opts, "%s", w8[irand(4)]);
    }
    if (chance(0.15))
        add(&s->opts, "-noise_cutoff");
    s->depth = chance(0.3);
    s->normals = chance(0.3);
    if (chance(quick ? 0.2 : 0.3)) {
        static const char *samplers[][2] = {{"-jittered_samples", "4"},
                                            {"-uniform_samples", "4"},
                                            {"-random_samples", "3"},
                                            {"-nrooks_samples", "3"},
                                            {"-poisson_samples", "4"}};
        int k = irand(5);
        s->antialiased = true;
        add(&s->opts, "%s", samplers[k][0]);
        add(&s->opts, "%s", samplers[k][1]);
        if (chance(0.5)) {
            add(&s->opts, "-seed");
            add(&s->opts, "%d", irange(0, 1000));
        }
    } else if (chance(0.08)) {
        s->antialiased = true;
        /* a = 4: one first sample never differs from itself, so a = 1 refined no
         * pixel (and is now a usage error) */
        add(&s->opts, "-adaptive_samples");
        add(&s->opts, "4");
        add(&s->opts, "9");
        add(&s->opts, "0.05");
    }
    if (chance(0.25)) {
        static const char *filters[][2] = {{"-gaussian_filter", "0.4"},
                                           {"-tent_filter", "1"},
                                           {"-box_filter", "0.7"},
                                           {"-mitchell_filter", "1.5"}};
        int k = irand(4);
        add(&s->opts, "%s", filters[k][0]);
        add(&s->opts, "%s", filters[k][1]);
    }
}

enum { ACC_NONE, ACC_AUTO, ACC_FIXED, ACC_TWOLEVEL, ACC_COUNT };
static const char *acc_name[] = {"none", "grid auto", "grid fixed", "twolevel"};

typedef struct Variant {
    int acc, threads;
    bool no_packets, stats, no_marking;
    int stack_kb; /* see Args */
    const char *isa; /* -isa NAME, or NULL: the CPU's widest */
} Variant;

/* The scene every command reads; the reducer points it at its reduced copy. */
static const char *input_name = "scene.txt";

static void variant_args(const Variant *v, const Shading *s, const int grid[3],
                         const char *tag, Args *a)
{
    a->stack_kb = v->stack_kb;
    add(a, "%s", bin);
    add(a, "-input");
    add(a, "%s", input_name);
    add(a, "-output");
    add(a, "%s.%s", tag, s->ext);
    for (int i = 0; i < s->opts.n; i++)
        add(a, "%s", s->opts.v[i]);
    if (s->depth) {
        add(a, "-depth");
        add(a, "3");
        add(a, "14");
        add(a, "%s_d.%s", tag, s->ext);
    }
    if (s->normals) {
        add(a, "-normals");
        add(a, "%s_n.%s", tag, s->ext);
    }
    if (v->acc == ACC_AUTO) {
        add(a, "-grid");
        add(a, "auto");
    } else if (v->acc == ACC_FIXED) {
        add(a, "-grid");
        for (int k = 0; k < 3; k++)
            add(a, "%d", grid[k]);
    } else if (v->acc == ACC_TWOLEVEL) {
        add(a, "-accel");
        add(a, "twolevel");
    }
    add(a, "-threads");
    add(a, "%d", v->threads);
    if (v->no_packets)
        add(a, "-no_packets");
    if (v->no_marking && v->acc != ACC_NONE)
        add(a, "-no_marking");
    if (v->stats)
        add(a, "-stats");
    if (v->isa) {
        add(a, "-isa");
        add(a, "%s", v->isa);
    }
    add(a, "-quiet");
}

/* The instruction sets the binary takes with -isa on this CPU (probe_isas; none for a
 * binary without the option), given to the variants in turn: the AVX2 and baseline
 * copies of the kernels must give the AVX-512 copies' bytes. */
static const char *isas[3];
static int n_isas;

/* Counters of the whole run. */
static long n_renders, n_compares, n_failures;

/* What the run covered: scene keywords (counted in the scenes' text) and the kinds of
 * variant rendered, printed at the end so a run (and the test's fixed seed) shows that
 * it reached every feature. */
static const char *const covered_words[] = {
    "OrthographicCamera", "PerspectiveCamera", "DirectionalLight", "PointLight",
    "attenuation", "reflectiveColor", "transparentColor", "Checkerboard", "Noise",
    "Marble", "Wood", "Group", "Transform", "Scale", "UniformScale", "Translate",
    "XRotate", "YRotate", "ZRotate", "Rotate", "Matrix", "Sphere", "Plane", "Triangle",
    "TriangleMesh"};
enum { N_WORDS = sizeof covered_words / sizeof covered_words[0] };
static long covered[N_WORDS];
enum { COV_GRID_AUTO, COV_GRID_FIXED, COV_TWOLEVEL, COV_NO_PACKETS, COV_THREADS3,
       COV_STATS, COV_STACK, COV_TILES, COV_REGIONS, COV_CACHE, COV_AA, COV_ISA, COV_COUNT };
static const char *const cov_names[COV_COUNT] = {
    "grid_auto", "grid_fixed", "twolevel", "no_packets", "threads3",
    "stats", "small_stack", "tiles", "regions", "cache", "antialiased", "isa"};
static long cov[COV_COUNT];

/* The first failure of a scene, for the reducer: two renders whose images differ, one
 * that fails (its status), or two -stats blocks that differ. A split render's failure
 * is not reduced (kind FIND_NONE). */
enum { FIND_NONE, FIND_IMAGES, FIND_STATUS, FIND_STATS };
typedef struct Finding {
    int kind, status;
    Shading s;
    int grid[3];
    Variant a, b;
} Finding;
static Finding finding;
static bool reduce_on = true;

static void note_finding(int kind, int status, const Shading *s, const int grid[3],
                         const Variant *a, const Variant *b)
{
    if (finding.kind != FIND_NONE)
        return;
    finding.kind = kind;
    finding.status = status;
    finding.s = *s;
    memset(&finding.s.opts, 0, sizeof finding.s.opts);
    for (int i = 0; i < s->opts.n; i++)
        add(&finding.s.opts, "%s", s->opts.v[i]);
    memcpy(finding.grid, grid, sizeof finding.grid);
    finding.a = *a;
    if (b)
        finding.b = *b;
}

static void count_words(const char *text)
{
    const char *p = text;
    while (*p) {
        while (*p == ' ' || *p == '\n')
            p++;
        size_t n = strcspn(p, " \n");
        for (int k = 0; k < N_WORDS; k++)
            if (strlen(covered_words[k]) == n && !strncmp(p, covered_words[k], n))
                covered[k]++;
        p += n;
    }
}

static void count_variant(const Variant *v)
{
    if (v->acc == ACC_AUTO)
        cov[COV_GRID_AUTO]++;
    if (v->acc == ACC_FIXED)
        cov[COV_GRID_FIXED]++;
    if (v->acc == ACC_TWOLEVEL)
        cov[COV_TWOLEVEL]++;
    if (v->no_packets)
        cov[COV_NO_PACKETS]++;
    if (v->threads == 3)
        cov[COV_THREADS3]++;
    if (v->stats)
        cov[COV_STATS]++;
    if (v->stack_kb)
        cov[COV_STACK]++;
}

static bool same_file(const char *dir, const char *a, const char *b, long *first, long *ndiff)
{
    char pa[4096], pb[4096];
    fmt(pa, sizeof pa, "%s/%s", dir, a);
    fmt(pb, sizeof pb, "%s/%s", dir, b);
    size_t la, lb;
    char *x = slurp(pa, &la), *y = slurp(pb, &lb);
    bool same = x && y && la == lb && memcmp(x, y, la) == 0;
    *first = -1;
    *ndiff = 0;
    if (x && y && !same) {
        size_t n = la < lb ? la : lb;
        for (size_t i = 0; i < n; i++)
            if (x[i] != y[i]) {
                if (*first < 0)
                    *first = (long)i;
                ++*ndiff;
            }
        *ndiff += (long)(la > lb ? la - lb : lb - la);
        if (*first < 0) /* one is the other and more */
            *first = (long)n;
    }
    free(x);
    free(y);
    return same;
}

static void report(const char *dir, const char *what, const Args *ref, const Args *var)
{
    Buf b = {0};
    bprintf(&b, "DIFF %s\n  scene: %s/scene.txt\n  reference: ", what, dir);
    args_text(ref, &b);
    bprintf(&b, "\n  variant:   ");
    args_text(var, &b);
    printf("%s\n", b.s);
    fflush(stdout);
    free(b.s);
    n_failures++;
}

/* Runs a (a full command line) in dir, stdout and stderr into tag.out and tag.err;
 * a non-zero status is reported against the reference ref. */
static int last_status; /* of run_ok's last command */

static bool run_ok(const char *dir, const Args *a, const char *tag, const Args *ref)
{
    char outp[4096], errp[4096];
    fmt(outp, sizeof outp, "%s/%s.out", dir, tag);
    fmt(errp, sizeof errp, "%s/%s.err", dir, tag);
    int st = run(dir, a, outp, errp);
    last_status = st;
    n_renders++;
    if (verbose) {
        Buf b = {0};
        args_text(a, &b);
        printf("  %s %s\n", st == 0 ? "ran " : "FAIL", b.s);
        free(b.s);
    }
    if (st == 0)
        return true;
    char what[10000];
    fmt(what, sizeof what, "render failed with status %d (stderr in %s)", st, errp);
    report(dir, what, ref ? ref : a, a);
    return false;
}

/* Compares the images tag*.ext with the reference's r*.ext; a is what made them. */
static bool same_images(const char *dir, const Shading *s, const char *tag, const Args *ref,
                        const Args *a)
{
    const char *suffix[] = {"", "_d", "_n"};
    bool want[] = {true, s->depth, s->normals};
    for (int k = 0; k < 3; k++) {
        if (!want[k])
            continue;
        char fa[64], fb[64];
        fmt(fa, sizeof fa, "r%s.%s", suffix[k], s->ext);
        fmt(fb, sizeof fb, "%s%s.%s", tag, suffix[k], s->ext);
        long first, nd;
        n_compares++;
        if (!same_file(dir, fa, fb, &first, &nd)) {
            char what[10000];
            fmt(what, sizeof what, "%s and %s: %ld bytes differ, the first at offset %ld", fa,
                fb, nd, first);
            report(dir, what, ref, a);
            return false;
        }
    }
    return true;
}

/* Renders one variant into tag.* and compares it with the reference's files ("r"; ref
 * NULL: this is the reference). Returns false on a difference or a failed render. */
static bool check_variant(const char *dir, const Shading *s, const int grid[3],
                          const Variant *v, const char *tag, const Args *ref)
{
    static const Variant ref_v = {ACC_NONE, 1, false, false, false, 0, NULL};
    Args a = {0};
    variant_args(v, s, grid, tag, &a);
    count_variant(v);
    bool ok = run_ok(dir, &a, tag, ref);
    if (!ok) {
        note_finding(FIND_STATUS, last_status, s, grid, v, NULL);
    } else if (ref && !same_images(dir, s, tag, ref, &a)) {
        note_finding(FIND_IMAGES, 0, s, grid, &ref_v, v);
        ok = false;
    }
    args_free(&a);
    return ok;
}

/* Cuts at n - 1 distinct places in 1..len-1, sorted, with 0 and len around them. */
static void cuts(int len, int n, int *at)
{
    at[0] = 0;
    at[n] = len;
    for (int i = 1; i < n; i++) {
        bool fresh;
        do {
            at[i] = irange(1, len - 1);
            fresh = true;
            for (int j = 1; j < i; j++)
                fresh = fresh && at[j] != at[i];
        } while (!fresh);
    }
    for (int i = 1; i < n; i++) /* insertion sort of a handful */
        for (int j = i; j > 1 && at[j - 1] > at[j]; j--) {
            int t = at[j];
            at[j] = at[j - 1];
            at[j - 1] = t;
        }
}

/* One variant rendered in parts (-tile K N, -tile K CxR, or -region rectangles cut at
 * random columns and rows, which need not line up with the 8x8 packets) and put back
 * together with -merge: the merged images must be the reference's bytes. */
static bool check_split(const char *dir, const Shading *s, const int grid[3],
                        const Variant *v, const char *tag, const Args *ref)
{
    int cols = irange(1, 3), rows = irange(1, 3);
    if (cols * rows == 1)
        rows = 2;
    bool tiles = chance(0.5);
    /* Half the time the parts share a -cache file: the first writes its meshes and
     * grid, the later ones read them. */
    bool cache = chance(0.5);
    cov[tiles ? COV_TILES : COV_REGIONS]++;
    cov[COV_CACHE] += cache;
    count_variant(v);
    int xs[4], ys[4];
    cuts(s->w, cols, xs);
    cuts(s->h, rows, ys);
    const char *suffix[] = {"", "_d", "_n"};
    bool want[] = {true, s->depth, s->normals};
    Args merge[3];
    memset(merge, 0, sizeof merge);
    for (int k = 0; k < 3; k++) {
        add(&merge[k], "%s", bin);
        add(&merge[k], "-merge");
        add(&merge[k], "%s%s.%s", tag, suffix[k], s->ext);
    }
    bool ok = true;
    for (int p = 0; p < cols * rows && ok; p++) {
        char ptag[64];
        fmt(ptag, sizeof ptag, "%sp%d", tag, p);
        Args a = {0};
        variant_args(v, s, grid, ptag, &a);
        if (tiles) {
            add(&a, "-tile");
            add(&a, "%d", p);
            if (cols == 1)
                add(&a, "%d", rows);
            else
                add(&a, "%dx%d", cols, rows);
        } else {
            int c = p % cols, r = p / cols;
            add(&a, "-region");
            add(&a, "%d", xs[c]);
            add(&a, "%d", ys[r]);
            add(&a, "%d", xs[c + 1] - xs[c]);
            add(&a, "%d", ys[r + 1] - ys[r]);
        }
        if (cache) {
            add(&a, "-cache");
            add(&a, "%s.cache", tag);
        }
        ok = run_ok(dir, &a, ptag, ref);
        args_free(&a);
        for (int k = 0; k < 3; k++)
            add(&merge[k], "%s%s.%s", ptag, suffix[k], s->ext);
    }
    for (int k = 0; k < 3 && ok; k++) {
        char mtag[64];
        fmt(mtag, sizeof mtag, "%sm%d", tag, k);
        if (want[k])
            ok = run_ok(dir, &merge[k], mtag, ref);
    }
    if (ok) {
        /* The first part's command line stands for the split in a report. */
        Args a = {0};
        variant_args(v, s, grid, tag, &a);
        add(&a, "(in %d %s%s, merged)", cols * rows, tiles ? "tiles" : "regions",
            cache ? " with -cache" : "");
        ok = same_images(dir, s, tag, ref, &a);
        args_free(&a);
    }
    for (int k = 0; k < 3; k++)
        args_free(&merge[k]);
    return ok;
}

/* Renders and compares every variant of one shading option set. */
static bool check_shading(const char *dir, const Shading *s, int set, bool quick, long scene)
{
    int grid[3] = {irange(1, 12), irange(1, 12), irange(1, 12)};
    Variant ref = {ACC_NONE, 1, false, false, false, 0, NULL};
    Args ra = {0};
    variant_args(&ref, s, grid, "r", &ra);
    bool ok = check_variant(dir, s, grid, &ref, "r", NULL);
    if (!ok) {
        args_free(&ra);
        return false;
    }
    /* Always: the packet paths of both grids and of the two-level grid at 2 and 3 threads,
     * and the single-ray march; then a few drawn from every combination. */
    Variant vs[12];
    int nv = 0;
    vs[nv++] = (Variant){ACC_AUTO, 2, false, false, false, 0, NULL};
    vs[nv++] = (Variant){ACC_FIXED, 3, false, false, false, 0, NULL};
    vs[nv++] = (Variant){ACC_FIXED, 1, true, false, false, 0, NULL};
    if (!quick) {
        vs[nv++] = (Variant){ACC_TWOLEVEL, 1, false, false, false, 0, NULL};
        for (int i = 0; i < 2; i++)
            vs[nv++] = (Variant){irand(ACC_COUNT), irange(1, 3), chance(0.5), false,
                                 chance(0.15), chance(0.15) ? 512 : 0, NULL};
    } else {
        vs[nv++] = (Variant){ACC_TWOLEVEL, 2, chance(0.5), false, false, chance(0.2) ? 512 : 0, NULL};
    }
    /* -stats at 1 and 3 threads on one accelerator: the same image, and the same block
     * but for its time lines. */
    bool stats = chance(quick ? 0.2 : 0.3);
    int sacc = irand(ACC_COUNT);
    if (stats) {
        vs[nv++] = (Variant){sacc, 1, false, true, false, 0, NULL};
        vs[nv++] = (Variant){sacc, 3, false, true, false, 0, NULL};
    }
    /* Each variant an instruction set in turn (from the scene, set and variant, not
     * from the scene's random stream, which stays as it was), or the default. */
    for (int i = 0; i < nv && n_isas > 0; i++) {
        int k = (int)((scene + 3 * set + i) % (n_isas + 1));
        vs[i].isa = k < n_isas ? isas[k] : NULL;
        if (vs[i].isa)
            cov[COV_ISA]++;
    }
    for (int i = 0; i < nv && ok; i++) {
        char tag[32];
        fmt(tag, sizeof tag, "s%dv%d", set, i);
        ok = check_variant(dir, s, grid, &vs[i], tag, &ra);
    }
    /* Now and then the render in parts, merged. */
    if (ok && chance(quick ? 0.25 : 0.4)) {
        Variant v = {irand(ACC_COUNT), irange(1, 3), chance(0.3), false, false, 0, NULL};
        char tag[32];
        fmt(tag, sizeof tag, "s%dsplit", set);
        ok = check_split(dir, s, grid, &v, tag, &ra);
    }
    if (ok && stats) {
        char p1[4096], p3[4096];
        fmt(p1, sizeof p1, "%s/s%dv%d.out", dir, set, nv - 2);
        fmt(p3, sizeof p3, "%s/s%dv%d.out", dir, set, nv - 1);
        char *a = stats_without_time(p1), *b = stats_without_time(p3);
        n_compares++;
        if (!a || !b || strcmp(a, b) != 0 || !strstr(a, "RAY TRACING STATISTICS")) {
            Args va = {0};
            variant_args(&vs[nv - 1], s, grid, "stats", &va);
            char what[10000];
            fmt(what, sizeof what, "-stats blocks (%s) differ between 1 and 3 threads: %s and %s",
                     acc_name[sacc], p1, p3);
            report(dir, what, &ra, &va);
            args_free(&va);
            note_finding(FIND_STATS, 0, s, grid, &vs[nv - 2], &vs[nv - 1]);
            ok = false;
        }
        free(a);
        free(b);
    }
    args_free(&ra);
    return ok;
}

/* Whether the finding repeats on the scene with only the kept root objects and lights
 * (written to dir/reduced.txt): the same status, or the same two renders differing. */
static bool still_fails(const Gen *g, const char *dir, const bool *keep_item,
                        const bool *keep_light)
{
    Buf t = {0};
    scene_text(g, keep_item, keep_light, &t);
    buf_write(&t, dir, "reduced.txt", NULL, 0);
    free(t.s);
    const Finding *fd = &finding;
    input_name = "reduced.txt";
    Args a = {0}, b = {0};
    char oa[4096], ea[4096], ob[4096], eb[4096];
    fmt(oa, sizeof oa, "%s/xa.out", dir);
    fmt(ea, sizeof ea, "%s/xa.err", dir);
    fmt(ob, sizeof ob, "%s/xb.out", dir);
    fmt(eb, sizeof eb, "%s/xb.err", dir);
    variant_args(&fd->a, &fd->s, fd->grid, "xa", &a);
    int sa = run(dir, &a, oa, ea), sb = 0;
    n_renders++;
    bool fails = false;
    if (fd->kind == FIND_STATUS) {
        fails = sa == fd->status;
    } else if (sa == 0) {
        variant_args(&fd->b, &fd->s, fd->grid, "xb", &b);
        sb = run(dir, &b, ob, eb);
        n_renders++;
        if (sb == 0 && fd->kind == FIND_IMAGES) {
            const char *suffix[] = {"", "_d", "_n"};
            bool want[] = {true, fd->s.depth, fd->s.normals};
            for (int k = 0; k < 3 && !fails; k++) {
                char fa[64], fb[64];
                long first, nd;
                fmt(fa, sizeof fa, "xa%s.%s", suffix[k], fd->s.ext);
                fmt(fb, sizeof fb, "xb%s.%s", suffix[k], fd->s.ext);
                fails = want[k] && !same_file(dir, fa, fb, &first, &nd);
            }
        } else if (sb == 0) {
            char *x = stats_without_time(oa), *y = stats_without_time(ob);
            fails = !x || !y || strcmp(x, y) != 0;
            free(x);
            free(y);
        }
    }
    input_name = "scene.txt";
    args_free(&a);
    args_free(&b);
    return fails;
}

/* Shrinks a scene whose finding repeats: leaves out root objects and lights one at a
 * time while it still repeats, until no single one can go, and writes what is left to
 * dir/reduced.txt (its OBJ files are the scene's, beside it). */
static void reduce(const Gen *g, const char *dir)
{
    bool keep_item[MAX_ITEMS], keep_light[MAX_LIGHTS];
    for (int i = 0; i < MAX_ITEMS; i++)
        keep_item[i] = true;
    for (int i = 0; i < MAX_LIGHTS; i++)
        keep_light[i] = true;
    if (!still_fails(g, dir, keep_item, keep_light)) {
        printf("  not reduced: the finding did not repeat with the reducer's two commands\n");
        return;
    }
    int items = g->nitems, lights = g->nlights;
    for (bool changed = true; changed;) {
        changed = false;
        for (int i = g->nitems - 1; i >= 0; i--) {
            if (!keep_item[i] || items == 1)
                continue;
            keep_item[i] = false;
            if (still_fails(g, dir, keep_item, keep_light)) {
                items--;
                changed = true;
            } else {
                keep_item[i] = true;
            }
        }
        for (int i = g->nlights - 1; i >= 0; i--) {
            if (!keep_light[i])
                continue;
            keep_light[i] = false;
            if (still_fails(g, dir, keep_item, keep_light)) {
                lights--;
                changed = true;
            } else {
                keep_light[i] = true;
            }
        }
    }
    /* The last try may have been one that was put back: write the result again. */
    still_fails(g, dir, keep_item, keep_light);
    printf("  reduced to %d of %d root objects and %d of %d lights: %s/reduced.txt "
           "(the same commands with -input reduced.txt)\n",
           items, g->nitems, lights, g->nlights, dir);
    fflush(stdout);
}

static void rmtree(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    char p[4096];
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        fmt(p, sizeof p, "%s/%s", dir, e->d_name);
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode))
            rmtree(p);
        else
            unlink(p);
    }
    closedir(d);
    rmdir(dir);
}

/* Which of -isa base, avx2, avx512 the binary renders a one-sphere scene with (in the
 * run's folder root). */
static void probe_isas(const char *root)
{
    static const char *const names[] = {"base", "avx2", "avx512"};
    char scene[4096], outp[4096], errp[4096];
    fmt(scene, sizeof scene, "%s/isa_probe.txt", root);
    fmt(outp, sizeof outp, "%s/isa_probe.out", root);
    fmt(errp, sizeof errp, "%s/isa_probe.err", root);
    FILE *f = fopen(scene, "w");
    if (!f || fputs("OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 3 }\n"
                    "Materials { numMaterials 1 PhongMaterial { } }\n"
                    "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n",
                    f) < 0 || fclose(f) != 0)
        die("cannot write %s", scene);
    for (int k = 0; k < 3; k++) {
        Args a = {0};
        add(&a, "%s", bin);
        add(&a, "-input");
        add(&a, "isa_probe.txt");
        add(&a, "-output");
        add(&a, "/dev/null");
        add(&a, "-size");
        add(&a, "1");
        add(&a, "1");
        add(&a, "-isa");
        add(&a, "%s", names[k]);
        add(&a, "-quiet");
        if (run(root, &a, outp, errp) == 0)
            isas[n_isas++] = names[k];
        args_free(&a);
    }
    unlink(scene);
    unlink(outp);
    unlink(errp);
}

static void usage(FILE *f)
{
    fprintf(f,
            "usage: diffcheck [-bin PATH] [-n N] [-seed S] [-start I] [-sets K] [-dir DIR]\n"
            "                 [-timeout SECONDS] [-quick] [-crowded P] [-stop] [-no_reduce]\n"
            "                 [-keep] [-v]\n"
            "  Renders N random scenes (scene I uses seed S and index I: -seed S -start I -n 1\n"
            "  repeats it) under K shading option sets each (default 3), and compares the\n"
            "  bytes of every image of the brute-force single-thread render with -grid auto,\n"
            "  -grid nx ny nz, -accel twolevel, -no_packets and 2 or 3 threads, and the\n"
            "  -stats blocks (minus time lines) of 1 and 3 threads.\n"
            "  -bin       the raytracer to check (default ./raytracer; an absolute path is best)\n"
            "  -dir       where scenes are written (default a fresh $TMPDIR/rt_diffcheck.XXXXXX);\n"
            "             agreeing scenes are removed, differing ones kept and named\n"
            "  -quick     smaller images, fewer bounces and variants (for the test suite)\n"
            "  -crowded P add, to P%% of the scenes, a dense cluster of 40-240 small triangles\n"
            "             (an OBJ mesh), so that -grid auto builds the two-level grid and\n"
            "             -accel twolevel its leaf grids (from a stream of its own: the\n"
            "             scenes are otherwise those of the seed without it)\n"
            "  -stop      stop after the first scene with a difference\n"
            "  -no_reduce do not shrink a differing scene (by default its root objects and\n"
            "             lights are left out one by one while the difference stays, and\n"
            "             what is left is written beside it as reduced.txt)\n"
            "  -keep      keep every scene\n"
            "  -v         print every command\n"
            "Exit status: 0 all agreed, 1 a difference or a failed render, 2 usage error.\n");
}

static long parse_long(const char *opt, const char *s, long lo, long hi)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "diffcheck: %s: '%s' is not a number in %ld..%ld\n", opt, s, lo, hi);
        usage(stderr);
        exit(2);
    }
    return v;
}

int main(int argc, char **argv)
{
    long n = 20, start = 0, sets = 3;
    uint64_t seed = 1;
    const char *dir_arg = NULL;
    bool keep = false, quick = false, stop = false;
    for (int i = 1; i < argc; i++) {
        const char *o = argv[i];
        bool has = i + 1 < argc;
        if (!strcmp(o, "-h") || !strcmp(o, "--help")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(o, "-bin") && has) {
            bin = argv[++i];
        } else if (!strcmp(o, "-n") && has) {
            n = parse_long(o, argv[++i], 1, 100000000);
        } else if (!strcmp(o, "-seed") && has) {
            seed = (uint64_t)parse_long(o, argv[++i], 0, 0x7fffffffffffffffL);
        } else if (!strcmp(o, "-start") && has) {
            start = parse_long(o, argv[++i], 0, 100000000);
        } else if (!strcmp(o, "-sets") && has) {
            sets = parse_long(o, argv[++i], 1, 100);
        } else if (!strcmp(o, "-dir") && has) {
            dir_arg = argv[++i];
        } else if (!strcmp(o, "-timeout") && has) {
            timeout_s = (int)parse_long(o, argv[++i], 1, 100000);
        } else if (!strcmp(o, "-crowded") && has) {
            crowded_p = parse_long(o, argv[++i], 0, 100) / 100.0;
        } else if (!strcmp(o, "-quick")) {
            quick = true;
        } else if (!strcmp(o, "-no_reduce")) {
            reduce_on = false;
        } else if (!strcmp(o, "-stop")) {
            stop = true;
        } else if (!strcmp(o, "-keep")) {
            keep = true;
        } else if (!strcmp(o, "-v")) {
            verbose = 1;
        } else {
            fprintf(stderr, "diffcheck: unknown option or missing value: '%s'\n", o);
            usage(stderr);
            return 2;
        }
    }
    if (access(bin, X_OK) != 0)
        die("cannot run '%s': %s", bin, strerror(errno));
    /* The renders run in the scene's folder: an absolute binary path. */
    char *abs_bin = realpath(bin, NULL);
    if (!abs_bin)
        die("cannot resolve '%s': %s", bin, strerror(errno));
    bin = abs_bin;
    char root[4096];
    if (dir_arg) {
        fmt(root, sizeof root, "%s", dir_arg);
        if (mkdir(root, 0755) != 0 && errno != EEXIST)
            die("cannot make %s: %s", root, strerror(errno));
    } else {
        const char *t = getenv("TMPDIR");
        fmt(root, sizeof root, "%s/rt_diffcheck.XXXXXX", t && *t ? t : "/tmp");
        if (!mkdtemp(root))
            die("cannot make a folder in %s: %s", t && *t ? t : "/tmp", strerror(errno));
    }
    /* A render killed by a signal is a failure to report, not a reason to stop. */
    signal(SIGPIPE, SIG_IGN);
    probe_isas(root);
    if (verbose)
        printf("diffcheck: -isa takes %d instruction sets\n", n_isas);
    long failed_scenes = 0;
    for (long i = start; i < start + n; i++) {
        char dir[4096];
        fmt(dir, sizeof dir, "%s/scene_%llu_%ld", root, (unsigned long long)seed, i);
        rmtree(dir);
        if (mkdir(dir, 0755) != 0)
            die("cannot make %s: %s", dir, strerror(errno));
        /* Each scene its own stream: seed and index mixed, so -start I -n 1 repeats it. */
        rng = seed * 0x9E3779B97F4A7C15ull ^ ((uint64_t)i * 0xD1B54A32D192ED03ull);
        rnext();
        Gen g = {0};
        g.dir = dir;
        gen_scene(&g);
        args_free(&finding.s.opts);
        finding.kind = FIND_NONE;
        char sp[4096];
        buf_write(&g.scene, dir, "scene.txt", sp, sizeof sp);
        if (verbose)
            printf("scene %ld: %s\n", i, sp);
        count_words(g.scene.s);
        bool ok = true;
        for (int k = 0; k < sets && ok; k++) {
            Shading s;
            gen_shading(&s, quick);
            cov[COV_AA] += s.antialiased;
            ok = check_shading(dir, &s, k, quick, i);
            args_free(&s.opts);
        }
        if (!ok && reduce_on && finding.kind != FIND_NONE)
            reduce(&g, dir);
        gen_free(&g);
        if (!ok) {
            failed_scenes++;
            if (stop) {
                n = i - start + 1;
                break;
            }
        }
        else if (!keep)
            rmtree(dir);
    }
    printf("diffcheck: %ld scenes (seed %llu, from %ld), %ld renders, %ld comparisons, "
           "%ld failures in %ld scenes\n",
           n, (unsigned long long)seed, start, n_renders, n_compares, n_failures, failed_scenes);
    if (crowded_p > 0.0)
        printf("diffcheck: %ld scenes with a dense cluster (-crowded)\n", n_crowded);
    printf("diffcheck: covered:");
    for (int k = 0; k < N_WORDS; k++)
        printf(" %s=%ld", covered_words[k], covered[k]);
    for (int k = 0; k < COV_COUNT; k++)
        printf(" %s=%ld", cov_names[k], cov[k]);
    printf("\n");
    if (!failed_scenes && !keep && !dir_arg)
        rmdir(root);
    else if (failed_scenes)
        printf("diffcheck: the differing scenes are kept in %s\n", root);
    args_free(&finding.s.opts);
    free(abs_bin);
    return failed_scenes ? 1 : 0;
}
