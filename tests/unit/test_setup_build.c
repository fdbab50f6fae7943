/* The parallel set-up gives the serial one's results to the bit: OBJ files read in
 * pieces (every record form, errors and forward references in late pieces), meshes
 * built in chunks (the box, signed zeros included), and grids binned by several
 * threads (the CSR arrays, entry order included, the packed triangles, the course counts
 * and the reference estimates), and primitive tables filled in chunks (kept-out leaves
 * included), for 0, 1, 2 and 3 helpers. */
#define _POSIX_C_SOURCE 200809L
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "../harness.h"
#include "../../src/accel/grid_internal.h"
#include "../../src/scene/obj_loader.h"
#include "rt/file.h"
#include "rt/arena.h"
#include "rt/geom.h"
#include "rt/par.h"
#include "rt/scene.h"

static const int k_helpers[] = {0, 1, 2, 3};
enum { N_HELPERS = 4 };

static uint64_t g_rng = 0x2545f4914f6cdd1dull;

static uint64_t rnd(void)
{
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 7;
    g_rng ^= g_rng << 17;
    return g_rng;
}

static double unit(void) { return (double)(rnd() >> 11) * 0x1p-53; }

/* A growing text buffer. */
typedef struct Text {
    char *s;
    size_t len, cap;
} Text;

static void put(Text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(Text *t, const char *fmt, ...)
{
    char line[256];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    if (t->len + (size_t)n + 1 > t->cap) {
        t->cap = 2 * (t->len + (size_t)n + 1) + 4096;
        t->s = realloc(t->s, t->cap);
    }
    memcpy(t->s + t->len, line, (size_t)n + 1);
    t->len += (size_t)n;
}

/* A coordinate in one of the spellings OBJ files use. */
static void put_coord(Text *t)
{
    double x = (unit() - 0.5) * 4.0;
    switch (rnd() % 8) {
    case 0: put(t, " %.6g", x); break;
    case 1: put(t, " %.9e", x); break;
    case 2: put(t, " %+.3f", x); break;
    case 3: put(t, " %d", (int)(x * 3)); break;
    case 4: put(t, " %s0", (rnd() & 1) ? "-" : ""); break; /* signed zeros */
    case 5: put(t, " %.17g", x); break;                     /* beyond the fast path */
    case 6: put(t, " %.4fE%+d", x, (int)(rnd() % 5) - 2); break;
    default: put(t, " %.7f", x); break;
    }
}

/* An OBJ text of about `bytes` bytes: vertices and faces interleaved (faces use only
 * vertices read before them, so the file is valid), in every form the reader accepts.
 * negative: also faces with negative indices (pieces then give up: serial reading). */
static char *make_obj_faces(size_t bytes, bool negative, bool polygons, size_t *len)
{
    Text t = {0};
    int nv = 0;
    while (t.len < bytes) {
        int r = (int)(rnd() % 16);
        if (nv < 3 || r < 6) {
            put(&t, "%sv", (rnd() % 8) ? "" : "  ");
            for (int k = 0; k < 3; k++)
                put_coord(&t);
            if (rnd() % 16 == 0)
                put(&t, " 1.0"); /* a w coordinate: ignored */
            put(&t, "%s\n", (rnd() % 8) ? "" : "\r");
            nv++;
        } else if (r < 12) {
            put(&t, "f %d %d %d\n", 1 + (int)(rnd() % (unsigned)nv),
                1 + (int)(rnd() % (unsigned)nv), 1 + (int)(rnd() % (unsigned)nv));
        } else if (r == 12) {
            int m = polygons ? 3 + (int)(rnd() % 4) : 3;
            put(&t, "f");
            for (int k = 0; k < m; k++) {
                int v = 1 + (int)(rnd() % (unsigned)nv);
                switch (rnd() % 4) {
                case 0: put(&t, " %d/%d/%d", v, 1, 1); break;
                case 1: put(&t, " %d//%d", v, 2); break;
                case 2: put(&t, " %d/%d", v, 3); break;
                default:
                    if (negative)
                        put(&t, " %d", v - nv - 1);
                    else
                        put(&t, "\t%d", v);
                    break;
                }
            }
            put(&t, "%s\n", (rnd() % 4) ? "" : " # trailing comment");
        } else if (r == 13) {
            put(&t, "# a comment line f 1 2 3\n");
        } else if (r == 14) {
            put(&t, "vn 0 1 0\nvt 0.5 0.5\n\n");
        } else {
            put(&t, "g part%d\ns off\n", (int)(rnd() % 100));
        }
    }
    *len = t.len;
    return t.s;
}

static char *make_obj(size_t bytes, bool negative, size_t *len)
{
    return make_obj_faces(bytes, negative, true, len);
}

/* Parses text with h helpers; the diagnostics go to *d. */
static bool parse_with(int h, const char *text, size_t len, ObjMesh *m, Diag *d)
{
    par_set_helpers(h);
    diag_init(d, NULL);
    bool ok = objfile_parse(text, len, "big.obj", m, d);
    par_set_helpers(-1);
    return ok;
}

static void check_same_parse(const char *text, size_t len, const char *what)
{
    ObjMesh ref;
    Diag dref;
    bool ok_ref = parse_with(0, text, len, &ref, &dref);
    for (int i = 1; i < N_HELPERS; i++) {
        ObjMesh m;
        Diag d;
        bool ok = parse_with(k_helpers[i], text, len, &m, &d);
        CHECK_MSG(ok == ok_ref, "%s, %d helpers: ok %d, serial %d", what, k_helpers[i], ok,
                  ok_ref);
        CHECK_STR(d.last, dref.last);
        CHECK_INT(d.errors, dref.errors);
        CHECK_INT(m.nverts, ref.nverts);
        CHECK_INT(m.ntris, ref.ntris);
        if (ok && ok_ref && m.nverts == ref.nverts && m.ntris == ref.ntris) {
            CHECK_MSG(m.nverts == 0 ||
                          memcmp(m.verts, ref.verts, (size_t)m.nverts * sizeof *m.verts) == 0,
                      "%s, %d helpers: vertices differ", what, k_helpers[i]);
            CHECK_MSG(m.ntris == 0 ||
                          memcmp(m.tris, ref.tris, (size_t)m.ntris * sizeof *m.tris) == 0,
                      "%s, %d helpers: faces differ", what, k_helpers[i]);
        }
        objfile_mesh_free(&m);
    }
    objfile_mesh_free(&ref);
}

static void test_obj_pieces_match_serial(void)
{
    for (int round = 0; round < 3; round++) {
        size_t len;
        char *text = make_obj((size_t)(300 + 400 * round) << 10, false, &len);
        ObjMesh m;
        Diag d;
        CHECK_MSG(parse_with(0, text, len, &m, &d), "generated OBJ: %s", d.last);
        CHECK(m.ntris > 1000);
        objfile_mesh_free(&m);
        check_same_parse(text, len, "valid file");
        free(text);
    }
}

/* Triangles only (in every vertex form, with comments, tabs, CRs and leading blanks):
 * the pieces are counted and read straight into place, and the mesh is the serial
 * reader's. Polygons send the file to the serial reader (the test above). */
static void test_obj_pieces_in_place(void)
{
    size_t len;
    char *text = make_obj_faces((size_t)600 << 10, false, false, &len);
    unsigned long before = objfile_pieces_read();
    check_same_parse(text, len, "triangles only");
    CHECK_MSG(objfile_pieces_read() - before == N_HELPERS - 1,
              "files read in pieces: %lu of %d", objfile_pieces_read() - before,
              N_HELPERS - 1);
    /* The last line without its line end, and a vertex line of a single "v": the
     * counts hold at the text's end, and an error is still the serial reader's. */
    char *cut = malloc(len + 16);
    memcpy(cut, text, len - 1);
    cut[len - 1] = '\0';
    check_same_parse(cut, len - 1, "no final line end");
    size_t n = len + (size_t)sprintf(cut + len - 1, "\nv") - 1;
    check_same_parse(cut, n, "lone v at the end");
    free(cut);
    free(text);
}

static void test_obj_pieces_negative_indices(void)
{
    size_t len;
    char *text = make_obj((size_t)500 << 10, true, &len);
    check_same_parse(text, len, "negative indices");
    free(text);
}

/* Errors near the end (in a late piece) and faces naming vertices that only come
 * later: the same message, at the same place, as the serial reader's. */
static void test_obj_pieces_errors(void)
{
    static const char *tails[] = {
        "f 1 2 999999\n",              /* beyond every vertex */
        "f 1 2 0\n",                   /* index 0 */
        "v 1 2\n",                     /* too few coordinates */
        "v 1 2 3e99\n",                /* out of range */
        "f 1 2\n",                     /* too few vertices */
        "f 1 2 x\n",                   /* malformed */
        "f 1 2 -999999\n",             /* negative, out of range */
    };
    for (size_t k = 0; k < sizeof tails / sizeof tails[0]; k++) {
        size_t len;
        char *text = make_obj((size_t)400 << 10, false, &len);
        char *full = malloc(len + strlen(tails[k]) + 64);
        memcpy(full, text, len);
        size_t n = len + (size_t)sprintf(full + len, "%sv 0 0 0\n", tails[k]);
        check_same_parse(full, n, tails[k]);
        free(full);
        free(text);
    }
    /* A face naming a vertex defined only further down: an error for the serial reader
     * ("out of range" at that face), even though the index exists at the end. */
    size_t len;
    char *text = make_obj((size_t)400 << 10, false, &len);
    char *full = malloc(2 * len + 64);
    size_t n = (size_t)sprintf(full, "f 1 2 50000\n");
    memcpy(full + n, text, len);
    n += len;
    memcpy(full + n, text, len);
    n += len;
    full[n] = '\0';
    check_same_parse(full, n, "forward reference");
    /* Again, in the middle of the file. */
    char *mid = strstr(full + len / 2, "\nf ");
    if (mid) {
        size_t off = (size_t)(mid + 1 - full);
        char *copy = malloc(n + 64);
        memcpy(copy, full, off);
        size_t m = off + (size_t)sprintf(copy + off, "f 3 2 %d\n", 20000000);
        memcpy(copy + m, full + off, n - off);
        m += n - off;
        copy[m] = '\0';
        check_same_parse(copy, m, "forward reference, middle");
        free(copy);
    }
    free(full);
    free(text);
}

/* Meshes built in chunks: the same triangles and the same box, bit for bit, also when
 * the box's extremes are signed zeros met in different chunks. */
static void test_mesh_chunks_match(void)
{
    int nv = 30000, nf = 40000;
    Vec3 *v = malloc((size_t)nv * sizeof *v);
    int(*f)[3] = malloc((size_t)nf * sizeof *f);
    for (int i = 0; i < nv; i++) {
        v[i] = v3((float)(unit() * 2), (float)(unit() * 2), (float)(unit() * 2));
        if (i % 7000 == 3) /* minima: +0 first, -0 later, in other chunks */
            v[i] = v3(i < 15000 ? 0.0f : -0.0f, i < 15000 ? -0.0f : 0.0f, 0.0f);
    }
    for (int i = 0; i < nf; i++)
        for (int k = 0; k < 3; k++)
            f[i][k] = (int)(rnd() % (unsigned)nv);
    f[5][0] = 3;
    f[39000][1] = 28003;
    Arena a0;
    arena_init(&a0);
    par_set_helpers(0);
    Object3D *ref = triangle_mesh_new(&a0, v, (const int(*)[3])f, nf, NULL);
    for (int h = 1; h < N_HELPERS; h++) {
        Arena a;
        arena_init(&a);
        par_set_helpers(k_helpers[h]);
        Object3D *m = triangle_mesh_new(&a, v, (const int(*)[3])f, nf, NULL);
        CHECK(m && ref);
        if (m && ref) {
            CHECK_MSG(memcmp(&m->bbox, &ref->bbox, sizeof m->bbox) == 0,
                      "%d helpers: mesh box differs", k_helpers[h]);
            int bad = 0;
            for (int i = 0; i < nf; i++) {
                const Object3D *ta = group_child(m, i), *tb = group_child(ref, i);
                Vec3 va[3], vb[3];
                triangle_vertices(ta, va);
                triangle_vertices(tb, vb);
                Vec3 na = triangle_normal(ta), nb = triangle_normal(tb);
                bad += memcmp(va, vb, sizeof va) != 0 || memcmp(&na, &nb, sizeof na) != 0 ||
                       memcmp(&ta->bbox, &tb->bbox, sizeof ta->bbox) != 0;
            }
            CHECK_INT(bad, 0);
        }
        arena_free(&a);
    }
    par_set_helpers(-1);
    arena_free(&a0);
    free(v);
    free(f);
}

/* Hash of everything the grid build produces. */
static uint64_t grid_hash(const Grid *g)
{
    uint64_t h = 1469598103934665603ull;
#define MIX(p, n) \
    do { \
        const unsigned char *c_ = (const unsigned char *)(p); \
        for (size_t i_ = 0; i_ < (size_t)(n); i_++) \
            h = (h ^ c_[i_]) * 1099511628211ull; \
    } while (0)
    MIX(g->cell_start, (g->num_cells + 1) * sizeof *g->cell_start);
    MIX(g->cell_items, g->cell_start[g->num_cells] * sizeof *g->cell_items);
    MIX(grid_course_counts(g), g->num_cells * sizeof(uint32_t));
    for (uint32_t i = 0; i < g->num_prims; i++) {
        MIX(&g->prims[i].obj->id, sizeof g->prims[i].obj->id);
        int depth = g->prims[i].xf ? g->prims[i].xf->path.depth : -1;
        MIX(&depth, sizeof depth);
    }
    MIX(&g->num_unbounded, sizeof g->num_unbounded);
    /* The packed triangles (field by field: no padding bytes) and their entries' tags. */
    for (uint32_t i = 0; g->tri && i < g->num_prims; i++) {
        const PackedTri *t = &g->tri[i];
        MIX(&t->v0, sizeof t->v0);
        MIX(&t->e1, sizeof t->e1);
        MIX(&t->e2, sizeof t->e2);
        MIX(&t->id, sizeof t->id);
        MIX(&t->box, sizeof t->box);
        if (t->id != RT_NO_ID) {
            MIX(&g->tri_hit[i].normal, sizeof g->tri_hit[i].normal);
            MIX(&g->tri_hit[i].material, sizeof g->tri_hit[i].material);
        }
    }
#undef MIX
    return h;
}

/* The primitive table of s with 1-3 helpers equals the serial one (a mesh's leaves
 * are added in chunks): every slot, its Transform chain, and the counters. */
static void check_tables(const Scene *s, const char *what)
{
    PrimTable ref, t;
    par_set_helpers(0);
    CHECK(prim_table_build(&ref, s));
    for (int h = 1; h < N_HELPERS; h++) {
        par_set_helpers(k_helpers[h]);
        CHECK(prim_table_build(&t, s));
        CHECK_INT(t.num_prims, ref.num_prims);
        CHECK_INT(t.num_bounded, ref.num_bounded);
        CHECK_INT(t.num_kept_out, ref.num_kept_out);
        CHECK_INT(t.first_kept_out, ref.first_kept_out);
        CHECK_INT(t.num_xforms, ref.num_xforms);
        CHECK(memcmp(&t.scene_bounds, &ref.scene_bounds, sizeof t.scene_bounds) == 0);
        int bad = 0;
        for (uint32_t i = 0; i < t.num_prims && i < ref.num_prims; i++) {
            const Prim *a = &t.prims[i], *b = &ref.prims[i];
            bool xf_same = (a->xf == NULL) == (b->xf == NULL) &&
                           (!a->xf || (a->xf->path.depth == b->xf->path.depth &&
                                       memcmp(&a->xf->m, &b->xf->m, sizeof a->xf->m) == 0));
            bad += !(a->obj == b->obj && a->id == b->id && a->bounded == b->bounded && xf_same &&
                     memcmp(&a->bounds, &b->bounds, sizeof a->bounds) == 0);
        }
        CHECK_MSG(bad == 0, "%s, %d helpers: %d table slots differ", what, k_helpers[h], bad);
        prim_table_free(&t);
    }
    par_set_helpers(-1);
    prim_table_free(&ref);
}

static void check_grids(const Scene *s, int nx, int ny, int nz, const char *what)
{
    Diag d;
    diag_init(&d, NULL);
    par_set_helpers(0);
    Grid *ref = grid_build(s, nx, ny, nz, &d);
    CHECK_MSG(ref != NULL, "%s: %s", what, d.last);
    if (!ref)
        return;
    uint64_t href = grid_hash(ref);
    CHECK(ref->num_prims > 2048); /* several chunks, so the helpers have work */
    CHECK(ref->tri != NULL);
    /* Every entry of a packed triangle is tagged, and only those. */
    int untagged = 0;
    for (uint32_t e = 0; ref->tri && e < ref->cell_start[ref->num_cells]; e++) {
        uint32_t it = ref->cell_items[e];
        untagged += ((it & GRID_ITEM_TRI) != 0) != (ref->tri[GRID_ITEM_INDEX(it)].id != RT_NO_ID);
    }
    CHECK_INT(untagged, 0);
    /* The reference budget's estimates (chunk sums on the helpers): the full sum, and
     * refits whose quick bound passes the cap in a late chunk, in an early one, and not
     * at all, against the serial answers. */
    PrimTable t;
    CHECK(prim_table_build(&t, s));
    int dims[3] = {nx, ny, nz};
    uint64_t est_ref = grid_ref_estimate(&t, dims);
    uint64_t caps[4] = {est_ref, est_ref - est_ref / 8, est_ref / 6, 2 * (uint64_t)t.num_bounded};
    int fit_ref[4][3];
    uint64_t fit_est_ref[4];
    for (int c = 0; c < 4; c++) {
        memcpy(fit_ref[c], dims, sizeof dims);
        grid_fit_refs(&t, fit_ref[c], caps[c], &fit_est_ref[c]);
    }
    for (int h = 1; h < N_HELPERS; h++) {
        par_set_helpers(k_helpers[h]);
        Grid *g = grid_build(s, nx, ny, nz, &d);
        CHECK(g != NULL);
        if (g) {
            CHECK_MSG(grid_hash(g) == href, "%s %dx%dx%d, %d helpers: grid differs", what, nx,
                      ny, nz, k_helpers[h]);
            CHECK_INT(g->cell_start[g->num_cells], ref->cell_start[ref->num_cells]);
            /* The reordered table was copied by the pack's chunks (the serial build
             * moves it in place): both paths are compared. */
            CHECK(g->prims_spare != NULL);
        }
        grid_free(g);
        CHECK_MSG(grid_ref_estimate(&t, dims) == est_ref, "%s, %d helpers: estimate differs",
                  what, k_helpers[h]);
        for (int c = 0; c < 4; c++) {
            int n[3];
            uint64_t est;
            memcpy(n, dims, sizeof dims);
            grid_fit_refs(&t, n, caps[c], &est);
            CHECK_MSG(memcmp(n, fit_ref[c], sizeof n) == 0 && est == fit_est_ref[c],
                      "%s, %d helpers, cap %llu: %dx%dx%d (%llu) instead of %dx%dx%d (%llu)",
                      what, k_helpers[h], (unsigned long long)caps[c], n[0], n[1], n[2],
                      (unsigned long long)est, fit_ref[c][0], fit_ref[c][1], fit_ref[c][2],
                      (unsigned long long)fit_est_ref[c]);
        }
    }
    par_set_helpers(-1);
    prim_table_free(&t);
    grid_free(ref);
}

static void test_grid_threads_match(void)
{
    char dir[] = "/tmp/rt_setup_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/big.obj", dir);
    size_t len;
    char *text = make_obj((size_t)600 << 10, false, &len);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fwrite(text, 1, len, f);
        fclose(f);
    }
    free(text);
    /* The mesh twice, once under nested Transforms, and spheres plain and transformed. */
    const char *scene =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Lights { numLights 0 }\n"
        "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 1 1 } }\n"
        "Group { numObjects 5 MaterialIndex 0\n"
        "  TriangleMesh { obj_file big.obj }\n"
        "  Transform { Translate 1 0 0 Transform { YRotate 30 Scale 1 2 1\n"
        "    TriangleMesh { obj_file big.obj } } }\n"
        "  Sphere { center 0.5 0.5 0.5 radius 0.7 }\n"
        "  Transform { Scale 2 1 1 Sphere { center 0 0 0 radius 0.4 } }\n"
        "  Plane { normal 0 1 0 offset -3 }\n"
        "}\n";
    Diag d;
    diag_init(&d, NULL);
    Scene *s = scene_load_string(scene, "setup.txt", dir, &d);
    CHECK_MSG(s != NULL, "%s", d.last);
    if (s) {
        check_tables(s, "generated");
        check_grids(s, 40, 40, 33, "generated");
        check_grids(s, 7, 3, 50, "generated");
        check_grids(s, 1, 1, 1, "generated");
        scene_free(s);
    }
    /* Leaves kept out of the grid for their huge boxes, after others: the first one's
     * index and the counts. */
    const char *huge =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Lights { numLights 0 }\n"
        "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 1 1 } }\n"
        "Group { numObjects 3 MaterialIndex 0\n"
        "  TriangleMesh { obj_file big.obj }\n"
        "  Transform { Scale 1e11 1 1 Transform { Scale 1e11 1 1 Transform { Scale 1e11 1 1\n"
        "    TriangleMesh { obj_file big.obj } } } }\n"
        "  Sphere { center 0.5 0.5 0.5 radius 0.7 }\n"
        "}\n";
    s = scene_load_string(huge, "huge.txt", dir, &d);
    CHECK_MSG(s != NULL, "%s", d.last);
    if (s) {
        PrimTable t;
        CHECK(prim_table_build(&t, s));
        CHECK(t.num_kept_out > 0 && t.first_kept_out > 0);
        prim_table_free(&t);
        check_tables(s, "kept out");
        scene_free(s);
    }
    unlink(path);
    rmdir(dir);
}

static void test_grid_threads_match_bunny(void)
{
    const char *course = harness_course_dir();
    if (!course)
        harness_skip("course folder absent (RT_COURSE): no 40k bunny");
    char path[1024];
    snprintf(path, sizeof path, "%s/scene6_07_bunny_mesh_40k.txt", course);
    Diag d;
    diag_init(&d, NULL);
    for (int h = 0; h < N_HELPERS; h++) {
        /* Also the whole load (OBJ pieces and mesh chunks) with h helpers. */
        par_set_helpers(k_helpers[h]);
        Scene *s = scene_load(path, &d);
        par_set_helpers(-1);
        CHECK_MSG(s != NULL, "%s", d.last);
        if (!s)
            return;
        CHECK_INT(s->num_primitives, 40001);
        if (h == 0)
            check_tables(s, "bunny 40k");
        check_grids(s, 40, 40, 33, "bunny 40k");
        if (h == 0)
            check_grids(s, 13, 9, 70, "bunny 40k");
        scene_free(s);
    }
}

/* A big file read by parallel preads: the same bytes as the ordinary read. */
static void test_read_parallel_match(void)
{
    char dir[] = "/tmp/rt_setup_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/big.obj", dir);
    size_t len;
    char *text = make_obj((size_t)900 << 10, false, &len);
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fwrite(text, 1, len, f);
        fclose(f);
    }
    for (int h = 0; h < N_HELPERS; h++) {
        par_set_helpers(k_helpers[h]);
        char *buf = NULL;
        size_t n = 0;
        CHECK(file_read_reusable(path, &buf, &n));
        CHECK_INT(n, len);
        CHECK_MSG(buf && n == len && memcmp(buf, text, len) == 0 && buf[n] == '\0',
                  "%d helpers: bytes differ", k_helpers[h]);
        arena_buffer_free(buf);
        CHECK(file_read_all(path, &buf, &n));
        CHECK_MSG(buf && n == len && memcmp(buf, text, len) == 0, "%d helpers: bytes differ",
                  k_helpers[h]);
        free(buf);
    }
    par_set_helpers(-1);
    free(text);
    unlink(path);
    rmdir(dir);
}

/* A stream (a FIFO: no size to read at once) of 65535, 65536 and 300001 bytes: the
 * buffer of 64 KB exactly full at its end, one byte beyond it (the byte read to see
 * whether the buffer is full must land in the grown buffer), and several doublings. */
static void test_read_stream(void)
{
    char dir[] = "/tmp/rt_setup_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/stream.obj", dir);
    CHECK(mkfifo(path, 0600) == 0);
    static const size_t sizes[] = {65535, 65536, 300001};
    for (size_t i = 0; i < sizeof sizes / sizeof sizes[0]; i++) {
        size_t len = sizes[i];
        char *text = malloc(len);
        CHECK(text != NULL);
        if (!text)
            break;
        for (size_t k = 0; k < len; k++)
            text[k] = (char)('a' + k % 23);
        pid_t pid = fork();
        CHECK(pid >= 0);
        if (pid == 0) {
            FILE *w = fopen(path, "wb");
            _exit(w && fwrite(text, 1, len, w) == len && fclose(w) == 0 ? 0 : 1);
        }
        char *buf = NULL;
        size_t n = 0;
        CHECK(file_read_all(path, &buf, &n));
        int status = 0;
        CHECK(pid > 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status) &&
              WEXITSTATUS(status) == 0);
        CHECK_MSG(buf && n == len && memcmp(buf, text, len) == 0 && buf[n] == '\0',
                  "%zu bytes: read %zu, not the same", len, n);
        free(buf);
        free(text);
    }
    unlink(path);
    rmdir(dir);
}

/* The grid's bit-stepping nextafterf agrees with libm's on the special values and on
 * a spread of 131k bit patterns over the whole float range (every sign, exponent, NaN). */
static bool same_float_bits(float a, float b)
{
    uint32_t x, y;
    memcpy(&x, &a, sizeof x);
    memcpy(&y, &b, sizeof y);
    return x == y || (a != a && b != b);
}

static void test_float_step(void)
{
    static const float special[] = {0.0f, -0.0f, INFINITY, -INFINITY, FLT_MAX, -FLT_MAX,
                                    FLT_MIN, -FLT_MIN, 1e-45f, -1e-45f, 1.0f, -1.0f, NAN};
    for (size_t i = 0; i < sizeof special / sizeof special[0]; i++) {
        float x = special[i];
        CHECK_MSG(same_float_bits(grid_float_step_up(x), nextafterf(x, INFINITY)), "up %a",
                  (double)x);
        CHECK_MSG(same_float_bits(grid_float_step_down(x), nextafterf(x, -INFINITY)),
                  "down %a", (double)x);
    }
    int bad = 0;
    for (uint64_t u = 0; u <= UINT32_MAX; u += 32749u) {
        uint32_t b = (uint32_t)u;
        float x;
        memcpy(&x, &b, sizeof x);
        bad += !same_float_bits(grid_float_step_up(x), nextafterf(x, INFINITY));
        bad += !same_float_bits(grid_float_step_down(x), nextafterf(x, -INFINITY));
    }
    CHECK_INT(bad, 0);
}

static const TestCase tests[] = {
    {"setup: grid_float_step matches nextafterf", test_float_step},
    {"setup: big file read by parallel preads = ordinary read", test_read_parallel_match},
    {"setup: a stream read whole (64 KB buffer full, one byte more, doublings)", test_read_stream},
    {"setup: OBJ with polygons (serial fallback) = serial read, every form", test_obj_pieces_match_serial},
    {"setup: OBJ pieces of triangles read in place = serial read", test_obj_pieces_in_place},
    {"setup: OBJ pieces with negative indices (serial fallback)", test_obj_pieces_negative_indices},
    {"setup: OBJ errors in late pieces: serial message and place", test_obj_pieces_errors},
    {"setup: mesh built in chunks: same triangles, same box bits", test_mesh_chunks_match},
    {"setup: grid binned by 1-4 threads: identical CSR arrays", test_grid_threads_match},
    {"setup: 40k bunny loaded and binned by 1-4 threads: identical", test_grid_threads_match_bunny},
};

RT_TEST_MAIN(tests)
