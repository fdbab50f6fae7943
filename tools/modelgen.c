/* modelgen: writes the project's own OBJ models (v/f lines, 1-based, counter-clockwise
 * outward faces): icosphere, torus, lathe vase, ground grid and a large seeded "blob"
 * mesh for benchmarks. Needs nothing from librt; run `modelgen -h` for the usage. */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* A growing indexed triangle mesh in double precision (written with %.6g-ish text). */
typedef struct Mesh {
    double *v;      /* 3 per vertex */
    uint32_t *f;    /* 3 per triangle, 0-based */
    size_t nv, nf, cap_v, cap_f;
} Mesh;

static void die_oom(void)
{
    fprintf(stderr, "modelgen: out of memory\n");
    exit(1);
}

static uint32_t mesh_vertex(Mesh *m, double x, double y, double z)
{
    if (m->nv == m->cap_v) {
        m->cap_v = m->cap_v ? m->cap_v * 2 : 1024;
        m->v = realloc(m->v, m->cap_v * 3 * sizeof *m->v);
        if (!m->v)
            die_oom();
    }
    m->v[3 * m->nv] = x;
    m->v[3 * m->nv + 1] = y;
    m->v[3 * m->nv + 2] = z;
    return (uint32_t)m->nv++;
}

static void mesh_face(Mesh *m, uint32_t a, uint32_t b, uint32_t c)
{
    if (m->nf == m->cap_f) {
        m->cap_f = m->cap_f ? m->cap_f * 2 : 1024;
        m->f = realloc(m->f, m->cap_f * 3 * sizeof *m->f);
        if (!m->f)
            die_oom();
    }
    m->f[3 * m->nf] = a;
    m->f[3 * m->nf + 1] = b;
    m->f[3 * m->nf + 2] = c;
    m->nf++;
}

static void mesh_free(Mesh *m)
{
    free(m->v);
    free(m->f);
    memset(m, 0, sizeof *m);
}

/* Signed volume by the divergence theorem: positive for a closed mesh whose faces are
 * counter-clockwise seen from outside, so it doubles as an orientation check. */
static double mesh_signed_volume(const Mesh *m)
{
    double vol = 0.0;
    for (size_t i = 0; i < m->nf; i++) {
        const double *a = m->v + 3 * m->f[3 * i], *b = m->v + 3 * m->f[3 * i + 1],
                     *c = m->v + 3 * m->f[3 * i + 2];
        vol += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
               a[2] * (b[0] * c[1] - b[1] * c[0]);
    }
    return vol / 6.0;
}

/* Fixed-point text: a small vertex line is short, and -0 is printed as 0 so the files
 * do not depend on the sign of rounding noise. */
static void put_num(FILE *out, double x, int decimals)
{
    char buf[64];
    snprintf(buf, sizeof buf, "%.*f", decimals, x);
    /* trim trailing zeros: "1.500000" -> "1.5", "2.000000" -> "2" */
    char *dot = strchr(buf, '.');
    if (dot) {
        char *e = buf + strlen(buf) - 1;
        while (e > dot && *e == '0')
            *e-- = '\0';
        if (e == dot)
            *e = '\0';
    }
    if (strcmp(buf, "-0") == 0)
        strcpy(buf, "0");
    fputs(buf, out);
}

static int mesh_write(const Mesh *m, FILE *out, int decimals)
{
    for (size_t i = 0; i < m->nv; i++) {
        fputs("v ", out);
        put_num(out, m->v[3 * i], decimals);
        fputc(' ', out);
        put_num(out, m->v[3 * i + 1], decimals);
        fputc(' ', out);
        put_num(out, m->v[3 * i + 2], decimals);
        fputc('\n', out);
    }
    for (size_t i = 0; i < m->nf; i++)
        fprintf(out, "f %u %u %u\n", m->f[3 * i] + 1, m->f[3 * i + 1] + 1, m->f[3 * i + 2] + 1);
    return ferror(out) ? -1 : 0;
}

/* ---- icosphere ------------------------------------------------------------------- */

/* Open-addressing map from an undirected edge (two vertex indices) to its midpoint
 * vertex, so neighbouring triangles share the new vertices (a watertight mesh). */
typedef struct EdgeMap {
    uint64_t *keys; /* 0 = empty; key = (lo+1) << 32 | (hi+1) */
    uint32_t *vals;
    size_t mask;
} EdgeMap;

static void edgemap_init(EdgeMap *e, size_t expected)
{
    size_t n = 1024;
    while (n < expected * 2)
        n *= 2;
    e->keys = calloc(n, sizeof *e->keys);
    e->vals = malloc(n * sizeof *e->vals);
    if (!e->keys || !e->vals)
        die_oom();
    e->mask = n - 1;
}

static uint32_t midpoint(Mesh *m, EdgeMap *e, uint32_t a, uint32_t b)
{
    uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
    uint64_t key = ((uint64_t)(lo + 1) << 32) | (uint64_t)(hi + 1);
    size_t h = (size_t)((key * 0x9E3779B97F4A7C15ull) >> 20) & e->mask;
    while (e->keys[h] != 0) {
        if (e->keys[h] == key)
            return e->vals[h];
        h = (h + 1) & e->mask;
    }
    const double *p = m->v + 3 * a, *q = m->v + 3 * b;
    double x = p[0] + q[0], y = p[1] + q[1], z = p[2] + q[2];
    double l = sqrt(x * x + y * y + z * z);
    uint32_t v = mesh_vertex(m, x / l, y / l, z / l);
    e->keys[h] = key;
    e->vals[h] = v;
    return v;
}

/* Unit icosphere: the regular icosahedron (vertices at (0, +-1, +-phi) and cyclic
 * permutations), each subdivision splitting every triangle into four and pushing the
 * new vertices onto the sphere. 20 * 4^level triangles. */
static void make_icosphere(Mesh *m, int level)
{
    const double t = (1.0 + sqrt(5.0)) / 2.0, l = sqrt(1.0 + t * t);
    const double base[12][3] = {
        {-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
        {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1},
    };
    static const int faces[20][3] = {
        {0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
        {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
        {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1},
    };
    for (int i = 0; i < 12; i++)
        mesh_vertex(m, base[i][0] / l, base[i][1] / l, base[i][2] / l);
    for (int i = 0; i < 20; i++) {
        /* orient each face outward explicitly (normal . centroid > 0) rather than trust
         * the table's winding */
        const double *a = m->v + 3 * faces[i][0], *b = m->v + 3 * faces[i][1],
                     *c = m->v + 3 * faces[i][2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        double d = n[0] * (a[0] + b[0] + c[0]) + n[1] * (a[1] + b[1] + c[1]) +
                   n[2] * (a[2] + b[2] + c[2]);
        if (d > 0)
            mesh_face(m, (uint32_t)faces[i][0], (uint32_t)faces[i][1], (uint32_t)faces[i][2]);
        else
            mesh_face(m, (uint32_t)faces[i][0], (uint32_t)faces[i][2], (uint32_t)faces[i][1]);
    }
    for (int s = 0; s < level; s++) {
        size_t nf = m->nf;
        uint32_t *old = malloc(nf * 3 * sizeof *old);
        if (!old)
            die_oom();
        memcpy(old, m->f, nf * 3 * sizeof *old);
        m->nf = 0;
        EdgeMap e;
        edgemap_init(&e, nf * 3 / 2);
        for (size_t i = 0; i < nf; i++) {
            uint32_t a = old[3 * i], b = old[3 * i + 1], c = old[3 * i + 2];
            uint32_t ab = midpoint(m, &e, a, b), bc = midpoint(m, &e, b, c),
                     ca = midpoint(m, &e, c, a);
            mesh_face(m, a, ab, ca);
            mesh_face(m, b, bc, ab);
            mesh_face(m, c, ca, bc);
            mesh_face(m, ab, bc, ca);
        }
        free(e.keys);
        free(e.vals);
        free(old);
    }
}

/* ---- lathe (surfaces of revolution about +y) --------------------------------------- */

/* Revolves the profile (r[k], y[k]), k = 0..n-1, about the y axis with nu segments.
 * Points with r == 0 become one vertex on the axis. The profile must run so that the
 * solid lies to its left when walking it in the (r, y) half-plane with r to the right
 * (bottom outward, up the outside, down the inside): then the faces come out
 * counter-clockwise from outside. closed: the last point joins the first (a torus). */
static void make_lathe(Mesh *m, const double *r, const double *y, int n, int nu, int closed)
{
    uint32_t *first = malloc((size_t)n * sizeof *first);
    int *on_axis = malloc((size_t)n * sizeof *on_axis);
    if (!first || !on_axis)
        die_oom();
    for (int k = 0; k < n; k++) {
        on_axis[k] = r[k] <= 0.0;
        first[k] = (uint32_t)m->nv;
        if (on_axis[k]) {
            mesh_vertex(m, 0.0, y[k], 0.0);
            continue;
        }
        for (int i = 0; i < nu; i++) {
            double th = 2.0 * M_PI * i / nu;
            mesh_vertex(m, r[k] * cos(th), y[k], r[k] * sin(th));
        }
    }
    int segs = closed ? n : n - 1;
    for (int k = 0; k < segs; k++) {
        int k2 = (k + 1) % n;
        for (int i = 0; i < nu; i++) {
            int i2 = (i + 1) % nu;
            uint32_t a = on_axis[k] ? first[k] : first[k] + (uint32_t)i;   /* (i, k) */
            uint32_t b = on_axis[k2] ? first[k2] : first[k2] + (uint32_t)i; /* (i, k+1) */
            uint32_t c = on_axis[k2] ? first[k2] : first[k2] + (uint32_t)i2;
            uint32_t d = on_axis[k] ? first[k] : first[k] + (uint32_t)i2;
            /* With P(theta, s) = (r cos, y, r sin): dP/ds x dP/dtheta points out of the
             * solid, so walk s first, then theta. */
            if (!on_axis[k2])
                mesh_face(m, a, b, c);
            if (!on_axis[k])
                mesh_face(m, a, c, d);
        }
    }
    free(first);
    free(on_axis);
}

/* Uniform Catmull-Rom through control points (x[i], y[i]), sampled at t in [0, n-1]. */
static void catmull_rom(const double *px, const double *py, int n, double t, double *ox,
                        double *oy)
{
    int i = (int)floor(t);
    if (i > n - 2)
        i = n - 2;
    if (i < 0)
        i = 0;
    double u = t - i;
    int i0 = i > 0 ? i - 1 : 0, i3 = i + 2 < n ? i + 2 : n - 1;
    const double *P[2] = {px, py};
    double *O[2] = {ox, oy};
    for (int c = 0; c < 2; c++) {
        double p0 = P[c][i0], p1 = P[c][i], p2 = P[c][i + 1], p3 = P[c][i3];
        *O[c] = 0.5 * ((2 * p1) + (-p0 + p2) * u + (2 * p0 - 5 * p1 + 4 * p2 - p3) * u * u +
                       (-p0 + 3 * p1 - 3 * p2 + p3) * u * u * u);
    }
}

/* A vase 2.1 units tall standing on y = 0: a thin-walled solid of revolution (outside,
 * a rounded lip, inside, a thick floor) so it looks right through glass too. */
static void make_vase(Mesh *m, int nu, int nv)
{
    static const double cy[] = {0.0, 0.12, 0.6, 1.2, 1.7, 1.95, 2.1};
    static const double cr[] = {0.30, 0.42, 0.62, 0.45, 0.24, 0.26, 0.34};
    const int nc = (int)(sizeof cy / sizeof cy[0]);
    const double wall = 0.04, floor_y = 0.08;
    int cap = 2 * nv + 8;
    double *r = malloc((size_t)cap * sizeof *r), *y = malloc((size_t)cap * sizeof *y);
    if (!r || !y)
        die_oom();
    int n = 0;
    r[n] = 0.0, y[n++] = 0.0;            /* centre of the base */
    for (int s = 0; s <= nv; s++) {       /* outside, bottom to top */
        catmull_rom(cr, cy, nc, (nc - 1) * (double)s / nv, &r[n], &y[n]);
        n++;
    }
    for (int s = nv; s >= 0; s--) {       /* inside, top to the floor */
        double t = (nc - 1) * (double)s / nv, rr, yy;
        catmull_rom(cr, cy, nc, t, &rr, &yy);
        if (yy < floor_y)
            break;
        r[n] = rr - wall, y[n++] = yy;
    }
    r[n] = r[n - 1], y[n++] = floor_y;    /* inner floor edge */
    r[n] = 0.0, y[n++] = floor_y;         /* centre of the floor */
    make_lathe(m, r, y, n, nu, 0);
    free(r);
    free(y);
}

static void make_torus(Mesh *m, double big_r, double small_r, int nu, int nv)
{
    double *r = malloc((size_t)nv * sizeof *r), *y = malloc((size_t)nv * sizeof *y);
    if (!r || !y)
        die_oom();
    /* the tube's circle, walked counter-clockwise in (r, y): up the outside first */
    for (int k = 0; k < nv; k++) {
        double a = 2.0 * M_PI * k / nv;
        r[k] = big_r + small_r * cos(a);
        y[k] = small_r * sin(a);
    }
    make_lathe(m, r, y, nv, nu, 1);
    free(r);
    free(y);
}

/* ---- ground grid ------------------------------------------------------------------- */

/* n x n quads over [-size/2, size/2]^2 in the y = 0 plane, faces up (+y); amplitude > 0
 * adds gentle deterministic waves so the mesh is not just a plane. */
static void make_ground(Mesh *m, int n, double size, double amplitude)
{
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            double x = size * ((double)i / n - 0.5), z = size * ((double)j / n - 0.5);
            double h = amplitude * (sin(1.3 * x + 0.4) * cos(0.9 * z - 0.2) +
                                    0.5 * sin(2.7 * x - 1.9 * z));
            mesh_vertex(m, x, h, z);
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a = (uint32_t)(j * (n + 1) + i), b = a + (uint32_t)(n + 1);
            /* (x,z) -> (x,z+1) -> (x+1,z): (0,0,1) x (1,0,0) = +y */
            mesh_face(m, a, b, a + 1);
            mesh_face(m, a + 1, b, b + 1);
        }
}

/* ---- large seeded blob ------------------------------------------------------------- */

static uint64_t rng_state;

static double rng_uniform(void) /* xorshift64*, [0, 1) */
{
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (double)((rng_state * 0x2545F4914F6CDD1Dull) >> 11) * (1.0 / 9007199254740992.0);
}

/* An icosphere whose vertices are pushed along the radius by a sum of seeded Gaussian
 * bumps and ridges: an irregular rock, 20 * 4^level triangles (level 8: 1,310,720),
 * with triangles of uneven size and orientation, which is what a grid must cope with. */
static void make_blob(Mesh *m, int level, unsigned long seed)
{
    enum { BUMPS = 96 };
    double c[BUMPS][3], amp[BUMPS], width[BUMPS];
    rng_state = 0x9E3779B97F4A7C15ull ^ ((uint64_t)seed * 0xD1B54A32D192ED03ull);
    if (rng_state == 0)
        rng_state = 1;
    for (int k = 0; k < BUMPS; k++) {
        double z = 2.0 * rng_uniform() - 1.0, phi = 2.0 * M_PI * rng_uniform();
        double s = sqrt(1.0 - z * z);
        c[k][0] = s * cos(phi), c[k][1] = z, c[k][2] = s * sin(phi);
        amp[k] = (rng_uniform() - 0.4) * (k < 16 ? 0.35 : 0.08);
        width[k] = k < 16 ? 0.15 + 0.3 * rng_uniform() : 0.01 + 0.04 * rng_uniform();
    }
    make_icosphere(m, level);
    for (size_t i = 0; i < m->nv; i++) {
        double *p = m->v + 3 * i, d = 1.0;
        for (int k = 0; k < BUMPS; k++) {
            double cosang = p[0] * c[k][0] + p[1] * c[k][1] + p[2] * c[k][2];
            d += amp[k] * exp(-(1.0 - cosang) / width[k]);
        }
        d += 0.015 * sin(23.0 * p[0] + 5.0 * p[1]) * sin(19.0 * p[2] - 7.0 * p[1]);
        if (d < 0.3)
            d = 0.3; /* stays star-shaped about the origin, so no fold-overs */
        p[0] *= d, p[1] *= d, p[2] *= d;
    }
}

/* ---- uneven scenes for the benchmarks ---------------------------------------------- */

/* Appends src scaled by s and moved by (tx, ty, tz) to dst. */
static void mesh_append(Mesh *dst, const Mesh *src, double s, double tx, double ty, double tz)
{
    uint32_t base = (uint32_t)dst->nv;
    for (size_t i = 0; i < src->nv; i++)
        mesh_vertex(dst, s * src->v[3 * i] + tx, s * src->v[3 * i + 1] + ty,
                    s * src->v[3 * i + 2] + tz);
    for (size_t i = 0; i < src->nf; i++)
        mesh_face(dst, base + src->f[3 * i], base + src->f[3 * i + 1], base + src->f[3 * i + 2]);
}

/* A big sparse room: a square floor of side size at height y0 (two triangles, facing
 * up) and a ring of n wall quads (2n triangles) of radius size/2 and height size/3,
 * facing the centre. With a small dense mesh inside, the "teapot in a stadium". */
static void make_room(Mesh *m, double size, int n, double y0)
{
    double h = size / 2.0, top = y0 + size / 3.0;
    uint32_t a = mesh_vertex(m, -h, y0, -h), b = mesh_vertex(m, h, y0, -h);
    uint32_t c = mesh_vertex(m, h, y0, h), d = mesh_vertex(m, -h, y0, h);
    /* (-h,-h) -> (-h,h) -> (h,h): (0,0,2h) x (2h,0,0) points up */
    mesh_face(m, a, d, c);
    mesh_face(m, a, c, b);
    uint32_t first = (uint32_t)m->nv;
    for (int i = 0; i < n; i++) {
        double ang = 2.0 * M_PI * i / n;
        mesh_vertex(m, h * cos(ang), y0, h * sin(ang));
        mesh_vertex(m, h * cos(ang), top, h * sin(ang));
    }
    for (int i = 0; i < n; i++) {
        uint32_t lo0 = first + 2u * (uint32_t)i, hi0 = lo0 + 1;
        uint32_t lo1 = first + 2u * (uint32_t)((i + 1) % n), hi1 = lo1 + 1;
        /* counter-clockwise seen from the centre */
        mesh_face(m, lo0, hi0, lo1);
        mesh_face(m, lo1, hi0, hi1);
    }
}

/* k seeded blobs (make_blob, level) of radius radius, far apart: centres drawn in a
 * cube of side spread, at least 4 radii from each other where possible. */
static void make_clusters(Mesh *m, int k, int level, double spread, double radius)
{
    double (*c)[3] = calloc((size_t)k, sizeof *c);
    if (!c)
        die_oom();
    rng_state = 0x853C49E6748FEA9Bull;
    for (int i = 0; i < k; i++) {
        for (int tries = 0; tries < 200; tries++) {
            for (int a = 0; a < 3; a++)
                c[i][a] = spread * (rng_uniform() - 0.5);
            int ok = 1;
            for (int j = 0; j < i && ok; j++) {
                double d2 = 0.0;
                for (int a = 0; a < 3; a++)
                    d2 += (c[i][a] - c[j][a]) * (c[i][a] - c[j][a]);
                ok = d2 >= 16.0 * radius * radius;
            }
            if (ok)
                break;
        }
    }
    for (int i = 0; i < k; i++) {
        Mesh b = {0};
        uint64_t keep = rng_state;
        make_blob(&b, level, (unsigned long)(i + 1));
        rng_state = keep;
        mesh_append(m, &b, radius, c[i][0], c[i][1], c[i][2]);
        mesh_free(&b);
    }
    free(c);
}

/* n seeded triangles whose vertices lie anywhere in [-1, 1]^3: each spans about half the
 * cube and they all overlap (the grid's worst case for cell references, bench (g)). */
static void make_shards(Mesh *m, int n, unsigned long seed)
{
    rng_state = 0x9E3779B97F4A7C15ull ^ ((uint64_t)seed * 0xD1B54A32D192ED03ull);
    if (rng_state == 0)
        rng_state = 1;
    for (int i = 0; i < n; i++) {
        uint32_t v[3];
        for (int k = 0; k < 3; k++) {
            double x = 2.0 * rng_uniform() - 1.0, y = 2.0 * rng_uniform() - 1.0,
                   z = 2.0 * rng_uniform() - 1.0;
            v[k] = mesh_vertex(m, x, y, z);
        }
        mesh_face(m, v[0], v[1], v[2]);
    }
}

/* A long thin scene: k blobs of radius 1 (make_blob, level) in a row along +x, centres
 * from 0 to length. */
static void make_row(Mesh *m, int k, int level, double length)
{
    for (int i = 0; i < k; i++) {
        Mesh b = {0};
        make_blob(&b, level, (unsigned long)(i + 1));
        mesh_append(m, &b, 1.0, k > 1 ? length * i / (k - 1) : 0.0, 0.0, 0.0);
        mesh_free(&b);
    }
}

/* ---- command line ------------------------------------------------------------------ */

static void usage(FILE *out)
{
    fputs("usage: modelgen [-o FILE] [-q] MODEL ARGS...\n"
          "Writes an OBJ mesh (v and f lines, 1-based, faces counter-clockwise seen from\n"
          "outside) to FILE or standard output, and a one-line summary to stderr.\n"
          "\n"
          "models:\n"
          "  icosphere LEVEL [RADIUS]     subdivided icosahedron, 20*4^LEVEL triangles\n"
          "  torus R r NU NV              ring about +y: radii R (ring) and r (tube),\n"
          "                               NU segments round the ring, NV round the tube\n"
          "  vase NU NV                   lathe vase 2.1 tall on y=0 (thin wall, floor):\n"
          "                               NU segments round, NV along the profile\n"
          "  ground N SIZE [AMPLITUDE]    N x N quads over [-SIZE/2,SIZE/2]^2 at y=0, facing\n"
          "                               +y, optionally with gentle waves of AMPLITUDE\n"
          "  blob LEVEL [SEED]            icosphere displaced by seeded bumps (SEED default\n"
          "                               1): LEVEL 8 gives 1,310,720 triangles (benchmarks)\n"
          "  room SIZE N [Y0]             floor of side SIZE at height Y0 (default 0) and a\n"
          "                               ring of N wall quads, facing in (uneven scenes)\n"
          "  clusters K LEVEL SPREAD R    K blobs of radius R far apart in a cube of side\n"
          "                               SPREAD, 20*4^LEVEL triangles each\n"
          "  row K LEVEL LENGTH           K blobs of radius 1 in a row along x, LENGTH long\n"
          "  shards N [SEED]              N seeded triangles with vertices anywhere in\n"
          "                               [-1,1]^3: large and all overlapping (benchmarks)\n"
          "\n"
          "options:\n"
          "  -o FILE   write to FILE (written to FILE.tmp, then renamed)\n"
          "  -q        no summary line\n"
          "  -h        this help\n"
          "\n"
          "The committed models/ were made by `make models` (mk/bench.mk).\n",
          out);
}

static int parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi) {
        fprintf(stderr, "modelgen: '%s' is not an integer in [%d, %d]\n", s, lo, hi);
        return 0;
    }
    *out = (int)v;
    return 1;
}

static int parse_double(const char *s, double lo, double hi, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !(v >= lo && v <= hi)) {
        fprintf(stderr, "modelgen: '%s' is not a number in [%g, %g]\n", s, lo, hi);
        return 0;
    }
    *out = v;
    return 1;
}

int main(int argc, char **argv)
{
    const char *outpath = NULL;
    int quiet = 0, a = 1;
    for (; a < argc && argv[a][0] == '-' && argv[a][1]; a++) {
        if (!strcmp(argv[a], "-h") || !strcmp(argv[a], "--help")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(argv[a], "-q")) {
            quiet = 1;
        } else if (!strcmp(argv[a], "-o") && a + 1 < argc) {
            outpath = argv[++a];
        } else {
            fprintf(stderr, "modelgen: unknown option '%s' (try -h)\n", argv[a]);
            return 2;
        }
    }
    if (a >= argc) {
        usage(stderr);
        return 2;
    }
    const char *model = argv[a++];
    int nargs = argc - a;
    char **args = argv + a;
    Mesh m = {0};
    int decimals = 6;
    int ok = 1;

#define NEED(lo, hi)                                                                   \
    if (nargs < (lo) || nargs > (hi)) {                                                \
        fprintf(stderr, "modelgen: %s takes %d to %d arguments (try -h)\n", model, lo, hi); \
        return 2;                                                                      \
    }
    if (!strcmp(model, "icosphere")) {
        NEED(1, 2);
        int level;
        double radius = 1.0;
        ok = parse_int(args[0], 0, 8, &level) &&
             (nargs < 2 || parse_double(args[1], 1e-6, 1e6, &radius));
        if (ok) {
            make_icosphere(&m, level);
            for (size_t i = 0; i < 3 * m.nv; i++)
                m.v[i] *= radius;
        }
    } else if (!strcmp(model, "torus")) {
        NEED(4, 4);
        double br, sr;
        int nu, nv;
        ok = parse_double(args[0], 1e-6, 1e6, &br) && parse_double(args[1], 1e-6, 1e6, &sr) &&
             parse_int(args[2], 3, 4096, &nu) && parse_int(args[3], 3, 4096, &nv);
        if (ok && sr >= br) {
            fprintf(stderr, "modelgen: torus needs r < R (a ring, not a spindle)\n");
            ok = 0;
        }
        if (ok)
            make_torus(&m, br, sr, nu, nv);
    } else if (!strcmp(model, "vase")) {
        NEED(2, 2);
        int nu, nv;
        ok = parse_int(args[0], 3, 4096, &nu) && parse_int(args[1], 2, 4096, &nv);
        if (ok)
            make_vase(&m, nu, nv);
    } else if (!strcmp(model, "ground")) {
        NEED(2, 3);
        int n;
        double size, amp = 0.0;
        ok = parse_int(args[0], 1, 4096, &n) && parse_double(args[1], 1e-6, 1e6, &size) &&
             (nargs < 3 || parse_double(args[2], 0.0, 1e6, &amp));
        if (ok)
            make_ground(&m, n, size, amp);
    } else if (!strcmp(model, "blob")) {
        NEED(1, 2);
        int level, seed = 1;
        ok = parse_int(args[0], 0, 9, &level) &&
             (nargs < 2 || parse_int(args[1], 0, 1000000000, &seed));
        if (ok)
            make_blob(&m, level, (unsigned long)seed);
        decimals = 5; /* keeps the 1.3M-triangle file near 50 MB */
    } else if (!strcmp(model, "room")) {
        NEED(2, 3);
        int n;
        double size, y0 = 0.0;
        ok = parse_double(args[0], 1e-6, 1e6, &size) && parse_int(args[1], 3, 4096, &n) &&
             (nargs < 3 || parse_double(args[2], -1e6, 1e6, &y0));
        if (ok)
            make_room(&m, size, n, y0);
    } else if (!strcmp(model, "clusters")) {
        NEED(4, 4);
        int k, level;
        double spread, radius;
        ok = parse_int(args[0], 1, 4096, &k) && parse_int(args[1], 0, 7, &level) &&
             parse_double(args[2], 0.0, 1e6, &spread) &&
             parse_double(args[3], 1e-6, 1e6, &radius);
        if (ok)
            make_clusters(&m, k, level, spread, radius);
        decimals = 5;
    } else if (!strcmp(model, "row")) {
        NEED(3, 3);
        int k, level;
        double length;
        ok = parse_int(args[0], 1, 65536, &k) && parse_int(args[1], 0, 7, &level) &&
             parse_double(args[2], 0.0, 1e6, &length);
        if (ok)
            make_row(&m, k, level, length);
        decimals = 5;
    } else if (!strcmp(model, "shards")) {
        NEED(1, 2);
        int n, seed = 1;
        ok = parse_int(args[0], 1, 10000000, &n) &&
             (nargs < 2 || parse_int(args[1], 0, 1000000000, &seed));
        if (ok)
            make_shards(&m, n, (unsigned long)seed);
        decimals = 4;
    } else {
        fprintf(stderr, "modelgen: unknown model '%s' (try -h)\n", model);
        return 2;
    }
#undef NEED
    if (!ok)
        return 2;

    FILE *out = stdout;
    char tmp[4096];
    if (outpath) {
        if (snprintf(tmp, sizeof tmp, "%s.tmp", outpath) >= (int)sizeof tmp) {
            fprintf(stderr, "modelgen: output path too long\n");
            return 1;
        }
        out = fopen(tmp, "w");
        if (!out) {
            fprintf(stderr, "modelgen: cannot write %s: %s\n", tmp, strerror(errno));
            return 1;
        }
    }
    int wr = mesh_write(&m, out, decimals);
    if (outpath) {
        if (fclose(out) != 0)
            wr = -1;
        if (wr != 0 || rename(tmp, outpath) != 0) {
            fprintf(stderr, "modelgen: failed writing %s: %s\n", outpath, strerror(errno));
            remove(tmp);
            mesh_free(&m);
            return 1;
        }
    } else if (fflush(stdout) != 0 || wr != 0) {
        fprintf(stderr, "modelgen: write error\n");
        mesh_free(&m);
        return 1;
    }
    if (!quiet)
        fprintf(stderr, "modelgen: %s: %zu vertices, %zu triangles, signed volume %.4f\n",
                outpath ? outpath : "(stdout)", m.nv, m.nf, mesh_signed_volume(&m));
    mesh_free(&m);
    return 0;
}
