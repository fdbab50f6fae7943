/* The OBJ reader gives the same result for any thread count: a file read in parallel
 * pieces (src/scene/obj_loader.c, 2+ threads, files of RT_FILE_PAR_MIN_BYTES and more)
 * makes exactly the serial reader's mesh, and a bad file the serial reader's single
 * message, at the same line and column. Hostile texts (every line end, blank and
 * comment form, long lines, polygons and bad indices placed in late pieces, piece cuts
 * swept across CRLF pairs) and seeded random mutations of valid files, each read with 0
 * helpers and with 1-3; also whole-file reads at the reader's buffer boundaries. */
#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../harness.h"
#include "../test_rng.h"
#include "../../src/scene/obj_loader.h"
#include "rt/arena.h"
#include "rt/file.h"
#include "rt/par.h"

enum { N_HELPER_COUNTS = 3 };
static const int k_helpers[N_HELPER_COUNTS] = {1, 2, 3};

/* rng_state starts at 0 and is never reseeded: the same texts and mutations on every
 * run. */
static unsigned pick(unsigned n) { return (unsigned)(rng_next() % n); }

/* A growing text buffer, always NUL-terminated (the reader's sentinel). */
typedef struct Text {
    char *s;
    size_t len, cap;
} Text;

static void reserve(Text *t, size_t more)
{
    if (t->len + more + 1 > t->cap) {
        t->cap = 2 * (t->len + more + 1) + 4096;
        t->s = realloc(t->s, t->cap);
        if (!t->s)
            abort();
    }
}

static void put_bytes(Text *t, const char *s, size_t n)
{
    reserve(t, n);
    memcpy(t->s + t->len, s, n);
    t->len += n;
    t->s[t->len] = '\0';
}

static void put(Text *t, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void put(Text *t, const char *fmt, ...)
{
    char line[512];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
    put_bytes(t, line, (size_t)n);
}

static void put_repeat(Text *t, char c, size_t n)
{
    reserve(t, n);
    memset(t->s + t->len, c, n);
    t->len += n;
    t->s[t->len] = '\0';
}

/* Line ends: LF, CRLF, or (rarely) a lone CR, which the reader treats as a blank: the
 * rest of the line up to the next LF is part of the same line. */
static const char *line_end(int crlf)
{
    return crlf ? "\r\n" : "\n";
}

static void put_coord(Text *t)
{
    double x = ((double)(rng_next() >> 11) * 0x1p-53 - 0.5) * 6.0;
    switch (pick(10)) {
    case 0: put(t, " %.6g", x); break;
    case 1: put(t, " %.9e", x); break;
    case 2: put(t, " %+.3f", x); break;          /* leading '+' */
    case 3: put(t, " %d", (int)(x * 3)); break;
    case 4: put(t, " .%u", pick(1000)); break;   /* ".5" */
    case 5: put(t, " %.17g", x); break;          /* beyond the fast path */
    case 6: put(t, " %.4fE%+d", x, (int)pick(9) - 4); break;
    case 7: put(t, " -.%ue-2", pick(100)); break;
    case 8: put(t, "\t%.2f", x); break;
    default: put(t, " %.7f", x); break;
    }
}

/* One face vertex in one of the forms v, v/vt, v//vn, v/vt/vn. */
static void put_face_vertex(Text *t, int v)
{
    switch (pick(5)) {
    case 0: put(t, " %d/%u", v, 1 + pick(9)); break;
    case 1: put(t, " %d//%u", v, 1 + pick(9)); break;
    case 2: put(t, " %d/%u/%u", v, 1 + pick(9), 1 + pick(9)); break;
    case 3: put(t, "\t %d", v); break;
    default: put(t, " %d", v); break;
    }
}

typedef struct GenOpts {
    int crlf;          /* 0: LF; 1: CRLF; 2: mixed LF, CRLF and a few lone CRs */
    bool negative;     /* some faces with negative indices */
    bool long_lines;   /* some lines beyond 64 KB */
} GenOpts;

/* Valid triangle-only OBJ text of at least `bytes` bytes, every line ended. */
static void gen_obj(Text *t, size_t bytes, const GenOpts *o, int *nv_out)
{
    int nv = 0;
    while (t->len < bytes) {
        int crlf = o->crlf == 2 ? (int)pick(2) : o->crlf;
        unsigned r = pick(32);
        if (nv < 3 || r < 11) {
            put(t, "%sv", pick(8) ? "" : (pick(2) ? "  " : "\t"));
            for (int k = 0; k < 3; k++)
                put_coord(t);
            if (pick(10) == 0)
                put(t, " 1.0"); /* w: ignored */
            if (pick(12) == 0)
                put(t, " # after data");
            if (pick(12) == 0)
                put(t, " \t ");
            if (o->crlf == 2 && pick(40) == 0)
                put(t, "\r# after a lone CR, which ends no line");
            put(t, "%s", line_end(crlf));
            nv++;
        } else if (r < 24) {
            put(t, "f");
            for (int k = 0; k < 3; k++) {
                int v = 1 + (int)pick((unsigned)nv);
                if (o->negative && pick(6) == 0)
                    v = v - nv - 1;
                put_face_vertex(t, v);
            }
            if (pick(10) == 0)
                put(t, " #f 1 2 3 4");
            put(t, "%s", line_end(crlf));
        } else if (r < 26) {
            put(t, "# comment v 1 2 3%s", line_end(crlf));
        } else if (r == 26) {
            put(t, "%s%s", pick(2) ? "" : " \t  ", line_end(crlf)); /* blank / blanks only */
        } else if (r == 27) {
            put(t, "vn 0 1 0%svt .5 .5%s", line_end(crlf), line_end(crlf));
        } else if (r == 28) {
            put(t, "%s%s", pick(2) ? "usemtl x" : "vp 1 2 3", line_end(crlf)); /* unknown */
        } else if (r == 29) {
            put(t, "g g%u%so obj%s", pick(99), line_end(crlf), line_end(crlf));
        } else if (r == 30 && o->long_lines && pick(8) == 0) {
            /* Beyond 64 KB: a comment, or a face padded with blanks. */
            if (pick(2)) {
                put(t, "#");
                put_repeat(t, 'x', 70000 + pick(5000));
            } else {
                put(t, "f 1");
                put_repeat(t, ' ', 66000 + pick(5000));
                put(t, "2 3");
            }
            put(t, "%s", line_end(crlf));
        } else {
            put(t, "s off%s", line_end(crlf));
        }
    }
    if (nv_out)
        *nv_out = nv;
}

/* Outcome of one parse. */
typedef struct Outcome {
    bool ok;
    ObjMesh m;
    Diag d;
} Outcome;

static void parse_with(int helpers, const char *text, size_t len, Outcome *o)
{
    par_set_helpers(helpers);
    diag_init(&o->d, NULL);
    o->ok = objfile_parse(text, len, "t.obj", &o->m, &o->d);
    par_set_helpers(-1);
}

static bool same_outcome(const Outcome *a, const Outcome *b)
{
    if (a->ok != b->ok || a->d.errors != b->d.errors || strcmp(a->d.last, b->d.last) != 0 ||
        a->m.nverts != b->m.nverts || a->m.ntris != b->m.ntris)
        return false;
    return (a->m.nverts == 0 ||
            memcmp(a->m.verts, b->m.verts, (size_t)a->m.nverts * sizeof *a->m.verts) == 0) &&
           (a->m.ntris == 0 ||
            memcmp(a->m.tris, b->m.tris, (size_t)a->m.ntris * sizeof *a->m.tris) == 0);
}

static int g_cases;  /* texts compared */
static int g_differ; /* of which some thread count differed from the serial read */

/* text (NUL-terminated at len) read with 0 helpers and with 1-3: the same outcome.
 * want: 1 must parse, 0 must fail, -1 either. Returns the serial read's success. */
static bool check_text(const char *text, size_t len, int want, const char *what)
{
    Outcome ref;
    parse_with(0, text, len, &ref);
    g_cases++;
    if (want >= 0)
        CHECK_MSG(ref.ok == (want == 1), "%s: serial read %s (%s)", what,
                  ref.ok ? "succeeded" : "failed", ref.d.last);
    if (!ref.ok)
        CHECK_MSG(ref.d.errors == 1 && strncmp(ref.d.last, "t.obj:", 6) == 0,
                  "%s: not one located message: %d, '%s'", what, ref.d.errors, ref.d.last);
    bool differ = false;
    for (int i = 0; i < N_HELPER_COUNTS; i++) {
        Outcome o;
        parse_with(k_helpers[i], text, len, &o);
        if (!same_outcome(&o, &ref)) {
            if (!differ)
                CHECK_MSG(false, "%s, %d helpers: ok %d '%s' v%d t%d; serial ok %d '%s' v%d t%d",
                          what, k_helpers[i], o.ok, o.d.last, o.m.nverts, o.m.ntris, ref.ok,
                          ref.d.last, ref.m.nverts, ref.m.ntris);
            differ = true;
        }
        objfile_mesh_free(&o.m);
    }
    g_differ += differ;
    bool ok = ref.ok;
    objfile_mesh_free(&ref.m);
    return ok;
}

static void check_case(Text *t, int want, const char *what)
{
    check_text(t->s, t->len, want, what);
}

#define BIG ((size_t)300 << 10) /* above RT_FILE_PAR_MIN_BYTES: several pieces */

/* Valid texts in every line-end style: read in pieces (and equal to the serial read). */
static void test_valid_styles(void)
{
    for (int crlf = 0; crlf < 3; crlf++)
        for (int neg = 0; neg < 2; neg++) {
            GenOpts o = {crlf, neg != 0, crlf == 1};
            Text t = {0};
            gen_obj(&t, BIG + (size_t)crlf * 40000, &o, NULL);
            unsigned long before = objfile_pieces_read();
            check_case(&t, 1, neg ? "valid, negative indices" : "valid");
            if (!neg) /* triangles only, positive indices: the parallel path was taken */
                CHECK_MSG(objfile_pieces_read() - before == N_HELPER_COUNTS,
                          "crlf %d: read in pieces %lu times of %d", crlf,
                          objfile_pieces_read() - before, N_HELPER_COUNTS);
            /* No final line end; a last line that is a face or a comment, with or without
             * its line end; trailing blanks only. */
            size_t n = t.len;
            char last = t.s[n - (crlf == 1 ? 2 : 1)];
            t.len -= crlf == 1 ? 2 : 1;
            t.s[t.len] = '\0';
            check_case(&t, 1, "no final line end");
            t.s[t.len] = last;
            static const char *tails[] = {"f 1 2 3", "f 3 2 1\r", "# last", "#", "   \t",
                                          "f 1/1 2//2 3/3/3", "v 1 2 3", "\r", "v 1 2 3 4"};
            for (size_t k = 0; k < sizeof tails / sizeof *tails; k++) {
                t.len = n;
                put(&t, "%s", tails[k]);
                check_case(&t, 1, tails[k]);
                put(&t, "\n");
                check_case(&t, 1, tails[k]);
            }
            free(t.s);
        }
}

/* Texts that are wrong somewhere (or polygons, which are valid but read serially),
 * at the start, just after a piece cut, in the middle and at the end. */
static void test_placed_lines(void)
{
    static const struct {
        const char *line;
        int want;
    } lines[] = {
        {"f 1 2 3 4", 1},               /* polygon: serial reading, same mesh */
        {"f 1/1/1 2/2/2 3/3/3 1/1/1 2//2", 1},
        {"f 1 2 0", 0},                 /* index 0 */
        {"f 1 2 999999999", 0},         /* beyond every vertex */
        {"f 1 2 99999999999999", 0},    /* beyond INT_MAX */
        {"f 1/2/3 -1 0/1", 0},
        {"f -1 -2 -3", 1},              /* relative (valid when 3 vertices precede) */
        {"f 1 2 -999999", 0},
        {"f 1 2", 0},
        {"f 1 2 x", 0},
        {"f 1 2 3x", 0},
        {"f 1//2/3 2 3", 0},
        {"f 1 2 +3", 1},
        {"v 1 2", 0},
        {"v 1 2 nan", 0},
        {"v inf 2 3", 0},
        {"v 1 2 3e99", 0},
        {"v 1 2 1e-50", 1},
        {"v +1 .5 -.5e+1", 1},
        {"v 0x1p3 1 2", 1},
        {"v 1 2 3,", 0},
        {"v", 0},
        {"f", 0},
        {"vx 1 2 3", 1},                /* unknown keyword */
        {"F 1 2 3", 0},                 /* capitals: not skipped, an error */
        {"f 1 2 3 # 4 5", 1},
        {"f 1 2 3#4", 1},               /* a comment glued to the last number */
        {"v 1 2 3#4", 1},
        {"v 1 2 3 1 0.5 0.5 0.5", 1},   /* w and a colour: at most four more numbers */
        {"v 1 2 3 1 0.5 0.5 0.5 1", 0},
        {"v 1 2 3 x", 0},               /* a word after the coordinates */
    };
    GenOpts o = {2, false, false};
    Text base = {0};
    gen_obj(&base, BIG, &o, NULL);
    /* Line starts: the first line, right after the cuts at k * len / 4 (the pieces of a
     * 300 KB text), the middle, and the last line. */
    size_t at[8];
    int nat = 0;
    at[nat++] = 0;
    size_t npieces = base.len / (64u << 10);
    for (size_t k = 1; k < npieces && nat < 6; k++) {
        const char *nl = memchr(base.s + base.len * k / npieces, '\n',
                                base.len - base.len * k / npieces);
        if (nl)
            at[nat++] = (size_t)(nl + 1 - base.s);
    }
    at[nat++] = base.len;
    for (size_t i = 0; i < sizeof lines / sizeof *lines; i++)
        for (int a = 0; a < nat; a++) {
            /* An error on the first line is an error everywhere, except where vertices
             * are needed before it: skip the index lines at offset 0. */
            if (at[a] == 0 && lines[i].line[0] == 'f')
                continue;
            for (int crlf = 0; crlf < 2; crlf++) {
                Text t = {0};
                put_bytes(&t, base.s, at[a]);
                put(&t, "%s%s", lines[i].line, line_end(crlf));
                put_bytes(&t, base.s + at[a], base.len - at[a]);
                char what[128];
                snprintf(what, sizeof what, "'%s' at byte %zu", lines[i].line, at[a]);
                check_case(&t, lines[i].want, what);
                free(t.s);
            }
        }
    /* The exact edge of the index range after each cut: the last vertex read so far
     * (valid) and the one after it (an error, though it exists further down). */
    for (int a = 1; a < nat - 1; a++) {
        Outcome pre;
        char *prefix = malloc(at[a] + 1);
        memcpy(prefix, base.s, at[a]);
        prefix[at[a]] = '\0';
        parse_with(0, prefix, at[a], &pre);
        CHECK(pre.ok);
        int nv = pre.m.nverts;
        objfile_mesh_free(&pre.m);
        free(prefix);
        for (int over = 0; over < 2; over++)
            for (int form = 0; form < 2; form++) {
                Text t = {0};
                put_bytes(&t, base.s, at[a]);
                if (form)
                    put(&t, "f 1/1 2//2 %d/3/3\n", nv + over);
                else
                    put(&t, "f 1 2 %d\n", nv + over);
                put_bytes(&t, base.s + at[a], base.len - at[a]);
                check_case(&t, over ? 0 : 1, over ? "index one past the vertices so far"
                                                  : "index of the last vertex so far");
                free(t.s);
            }
    }
    free(base.s);
}

/* Piece cuts swept across every position of a few lines (inside CRLF pairs, right
 * before and after a line end), and file sizes at the buffer and piece boundaries. */
static void test_cut_positions(void)
{
    GenOpts o = {1, false, false};
    Text base = {0};
    gen_obj(&base, BIG, &o, NULL);
    for (size_t pad = 0; pad < 48; pad++) {
        Text t = {0};
        put(&t, "#");
        put_repeat(&t, 'p', pad);
        put(&t, "\r\n");
        put_bytes(&t, base.s, base.len);
        check_case(&t, 1, "cut sweep");
        free(t.s);
    }
    /* Exact sizes: a valid text cut after a line, padded with a comment to the size. */
    static const size_t sizes[] = {65535, 65536, 65537, (size_t)256 << 10,
                                   ((size_t)256 << 10) - 1, ((size_t)256 << 10) + 1,
                                   ((size_t)320 << 10) - 1, (size_t)320 << 10,
                                   ((size_t)320 << 10) + 1, ((size_t)384 << 10) + 2};
    for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++) {
        for (int end_cr = 0; end_cr < 2; end_cr++) {
            size_t want = sizes[k];
            const char *nl = base.s + want - 200;
            while (*nl != '\n')
                nl--;
            Text t = {0};
            put_bytes(&t, base.s, (size_t)(nl + 1 - base.s));
            put(&t, "#");
            while (t.len < want - 2)
                put(&t, "c");
            put(&t, end_cr ? "\r\n" : "cc");
            t.len = want; /* exactly `want` bytes */
            t.s[t.len] = '\0';
            check_case(&t, 1, "exact size");
        }
    }
    free(base.s);
}

/* Degenerate files: empty, only comments or blanks (big enough for pieces), a NUL
 * byte in the middle, lone CRs only, a huge single line. */
static void test_degenerate(void)
{
    check_text("", 0, 1, "empty");
    Text t = {0};
    while (t.len < BIG)
        put(&t, "# only comments %zu\r\n", t.len);
    check_case(&t, 1, "only comments");
    t.len = 0;
    while (t.len < BIG)
        put(&t, "%s", pick(2) ? " \t \n" : "\n");
    check_case(&t, 1, "only blank lines");
    t.len = 0;
    while (t.len < BIG)
        put(&t, "v 1 2 3\r");
    /* One line (a lone CR ends none): an error at its second record, where the first
     * vertex's line went on, read serially or in pieces alike. */
    check_case(&t, 0, "lone CRs only: one line");
    /* Files joined with cat, each beginning with a BOM (a BOM at a line start is
     * skipped): every piece counts and reads the same records as the serial read. */
    t.len = 0;
    int blocks = 0;
    for (; t.len < BIG; blocks++)
        put(&t, "\xEF\xBB\xBFv 0 0 %d\r\nv 1 0 0\r\nv 0 1 0\r\nf -3 -2 -1\r\n", blocks);
    check_case(&t, 1, "joined files, each with a BOM");
    Outcome joined;
    parse_with(0, t.s, t.len, &joined);
    CHECK_INT(joined.m.nverts, 3 * blocks);
    CHECK_INT(joined.m.ntris, blocks);
    objfile_mesh_free(&joined.m);
    /* The same with positive indices, which the pieces read themselves (relative ones
     * send the file to the serial reader): the parallel path is taken only when each
     * piece's count_records skips the BOMs as parse_lines does, so the joined file
     * above alone left that skip untested (without it, the counts differ and the file
     * quietly went serial). */
    t.len = 0;
    for (int b = 0; t.len < BIG; b++)
        put(&t, "\xEF\xBB\xBFv 0 0 %d\r\nv 1 0 0\r\nv 0 1 0\r\nf %d %d %d\r\n", b, 3 * b + 1,
            3 * b + 2, 3 * b + 3);
    unsigned long before = objfile_pieces_read();
    check_case(&t, 1, "joined files, each with a BOM, positive indices");
    CHECK_MSG(objfile_pieces_read() - before == N_HELPER_COUNTS,
              "joined files with BOMs: read in pieces %lu times of %d",
              objfile_pieces_read() - before, N_HELPER_COUNTS);
    t.len = 0;
    put(&t, "#");
    put_repeat(&t, 'x', BIG);
    check_case(&t, 1, "one comment line of 300 KB");
    free(t.s);

    GenOpts o = {0, false, true};
    Text b = {0};
    gen_obj(&b, BIG, &o, NULL);
    check_case(&b, 1, "long lines");
    for (int k = 1; k <= 3; k++) {
        char *copy = malloc(b.len + 1);
        memcpy(copy, b.s, b.len + 1);
        copy[b.len * (size_t)k / 4] = '\0';
        check_text(copy, b.len, 0, "NUL in the middle");
        free(copy);
    }
    free(b.s);
}

/* Seeded random mutations of valid files: bytes flipped, inserted, deleted (anywhere,
 * and near the piece cuts); the outcome must not depend on the thread count. */
static void test_mutations(void)
{
    static const char alphabet[] = " \t\r\n/#-+.0123456789efvEnx\0";
    for (int file = 0; file < 3; file++) {
        GenOpts o = {file, false, file == 2};
        Text base = {0};
        gen_obj(&base, BIG + (size_t)file * 30000, &o, NULL);
        size_t npieces = base.len / (64u << 10);
        for (int round = 0; round < 70; round++) {
            Text t = {0};
            put_bytes(&t, base.s, base.len);
            int edits = 1 + (int)pick(4);
            for (int e = 0; e < edits; e++) {
                size_t pos;
                if (pick(2)) /* near a cut */
                    pos = t.len * (1 + pick((unsigned)npieces)) / npieces;
                else
                    pos = (size_t)(rng_next() % t.len);
                pos = pos + pick(64) < t.len ? pos + pick(64) : t.len - 1;
                char c = pick(4) ? alphabet[pick(sizeof alphabet - 2)] : (char)pick(256);
                switch (pick(3)) {
                case 0: /* flip */
                    t.s[pos] = c;
                    break;
                case 1: /* insert */
                    reserve(&t, 1);
                    memmove(t.s + pos + 1, t.s + pos, t.len - pos + 1);
                    t.s[pos] = c;
                    t.len++;
                    break;
                default: /* delete */
                    memmove(t.s + pos, t.s + pos + 1, t.len - pos);
                    t.len--;
                    break;
                }
            }
            t.s[t.len] = '\0';
            check_text(t.s, t.len, -1, "mutation");
            free(t.s);
        }
        free(base.s);
    }
}

/* The other end of a FIFO: len bytes of text in chunks of odd sizes. A thread, not a
 * child process: a fork next to the set-up helpers is a race report under TSan. */
typedef struct FifoWriter {
    const char *path, *text;
    size_t len;
} FifoWriter;

static void *fifo_write(void *arg)
{
    const FifoWriter *fw = arg;
    FILE *w = fopen(fw->path, "wb");
    size_t off = 0;
    while (w && off < fw->len) {
        size_t part = 1 + (off * 7919u) % 40000u;
        if (part > fw->len - off)
            part = fw->len - off;
        fwrite(fw->text + off, 1, part, w);
        fflush(w);
        off += part;
    }
    if (w)
        fclose(w);
    return NULL;
}

/* Whole-file reads (file_read_reusable, file_read_all) with 0 and 2 helpers at the
 * buffer's sizes: every byte, the NUL after them, and the OBJ outcome the same. */
static void test_file_sizes(void)
{
    char dir[] = "/tmp/rt_objthr_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/t.obj", dir);
    GenOpts o = {1, false, false};
    Text base = {0};
    gen_obj(&base, (size_t)400 << 10, &o, NULL);
    static const size_t sizes[] = {0, 1, 65535, 65536, 65537, 131072,
                                   ((size_t)256 << 10) - 1, (size_t)256 << 10,
                                   ((size_t)256 << 10) + 1, (size_t)400 << 10};
    for (size_t k = 0; k < sizeof sizes / sizeof *sizes; k++) {
        size_t len = sizes[k];
        FILE *f = fopen(path, "wb");
        CHECK(f != NULL);
        if (!f)
            break;
        fwrite(base.s, 1, len, f);
        fclose(f);
        for (int h = 0; h < 3; h += 2) {
            par_set_helpers(h);
            char *buf = NULL;
            size_t n = 0;
            CHECK(file_read_reusable(path, &buf, &n));
            CHECK_MSG(buf && n == len && memcmp(buf, base.s, len) == 0 && buf[n] == '\0',
                      "size %zu, %d helpers: reusable read differs (%zu bytes)", len, h, n);
            par_set_helpers(-1);
            if (buf && n == len)
                check_text(buf, n, -1, "file read");
            arena_buffer_free(buf);
            par_set_helpers(h);
            CHECK(file_read_all(path, &buf, &n));
            CHECK_MSG(buf && n == len && memcmp(buf, base.s, len) == 0 && buf[n] == '\0',
                      "size %zu, %d helpers: read differs (%zu bytes)", len, h, n);
            free(buf);
            par_set_helpers(-1);
        }
    }
    /* A FIFO has no size: the buffer starts at 64 KB and grows when full after a 1-byte
     * probe (src/core/file.c); lengths around each capacity, written in odd chunks. */
    static const size_t fifo_sizes[] = {0, 1, 65534, 65535, 65536, 65537, 131071,
                                        131072, 131073, 262143, 262144, 262145};
    snprintf(path, sizeof path, "%s/fifo.obj", dir);
    for (size_t k = 0; k < sizeof fifo_sizes / sizeof *fifo_sizes; k++) {
        size_t len = fifo_sizes[k];
        CHECK(mkfifo(path, 0600) == 0);
        FifoWriter w = {path, base.s, len};
        pthread_t th;
        bool started = pthread_create(&th, NULL, fifo_write, &w) == 0;
        CHECK(started);
        if (!started) { /* nobody would open the other end */
            unlink(path);
            continue;
        }
        char *buf = NULL;
        size_t n = 0;
        CHECK(file_read_all(path, &buf, &n));
        CHECK_MSG(buf && n == len && memcmp(buf, base.s, len) == 0 && buf[n] == '\0',
                  "FIFO of %zu bytes: read differs (%zu bytes)", len, n);
        if (buf && n == len)
            check_text(buf, n, -1, "FIFO read");
        free(buf);
        pthread_join(th, NULL);
        unlink(path);
    }
    free(base.s);
    /* path names the FIFO now (removed above); the regular file is t.obj */
    snprintf(path, sizeof path, "%s/t.obj", dir);
    CHECK(unlink(path) == 0);
    CHECK_MSG(rmdir(dir) == 0, "%s left behind", dir);
}

/* A stop request (rt/par.h: main's stop-signal flag) ends a whole-file read: false with
 * EINTR (the callers report nothing and main says "interrupted"), for the one-thread
 * read and the parallel one, reusable or not, a big file and a small one; with the flag
 * clear the same reads succeed, and a file of two steps and a byte more
 * (RT_FILE_STOP_BYTES: the one-thread read goes in steps to look between them) is
 * read whole. Before, a read ran to its end whatever the flag (a 100 MB OBJ file on a
 * slow disk kept a Ctrl-C waiting for seconds). */
static void test_read_stop_request(void)
{
    char dir[] = "/tmp/rt_objstop_XXXXXX";
    CHECK(mkdtemp(dir) != NULL);
    char big[256], small[256];
    snprintf(big, sizeof big, "%s/big.obj", dir);
    snprintf(small, sizeof small, "%s/small.obj", dir);
    GenOpts o = {1, false, false};
    Text text = {0};
    size_t len = 2 * RT_FILE_STOP_BYTES + 1;
    gen_obj(&text, len, &o, NULL);
    CHECK(text.s != NULL && text.len >= len);
    if (harness_failures) {
        free(text.s);
        return;
    }
    FILE *f = fopen(big, "wb");
    CHECK(f != NULL && fwrite(text.s, 1, len, f) == len);
    if (f)
        fclose(f);
    f = fopen(small, "wb");
    CHECK(f != NULL && fwrite(text.s, 1, 100, f) == 100);
    if (f)
        fclose(f);
    volatile int stop = 0;
    par_set_stop_flag(&stop);
    for (int h = 0; h < 3; h += 2) {
        par_set_helpers(h);
        const char *paths[2] = {big, small};
        for (int k = 0; k < 2; k++) {
            char *buf = NULL;
            size_t n = 0;
            stop = 0;
            CHECK(file_read_reusable(paths[k], &buf, &n));
            CHECK_MSG(buf && n == (k ? 100 : len) && memcmp(buf, text.s, n) == 0 && !buf[n],
                      "%d helpers, %s: the read differs (%zu bytes)", h, paths[k], n);
            arena_buffer_free(buf);
            stop = 15; /* SIGTERM's number, as the handler stores it */
            buf = NULL;
            errno = 0;
            CHECK_MSG(!file_read_reusable(paths[k], &buf, &n) && errno == EINTR,
                      "%d helpers, %s: read after the stop (errno %d)", h, paths[k], errno);
            errno = 0;
            CHECK_MSG(!file_read_all(paths[k], &buf, &n) && errno == EINTR,
                      "%d helpers, %s: read (file_read_all) after the stop (errno %d)", h,
                      paths[k], errno);
        }
    }
    par_set_stop_flag(NULL);
    par_set_helpers(-1);
    free(text.s);
    CHECK(unlink(big) == 0 && unlink(small) == 0);
    CHECK_MSG(rmdir(dir) == 0, "%s left behind", dir);
}

/* Each test runs in its own process (tests/harness.c): it reports its own count. */
static void report(int min_cases)
{
    printf("(%d texts, %d differing) ", g_cases, g_differ);
    CHECK_MSG(g_cases >= min_cases, "only %d texts compared", g_cases);
    CHECK_INT(g_differ, 0);
}

static void run_valid(void) { test_valid_styles(); report(100); }
static void run_placed(void) { test_placed_lines(); report(200); }
static void run_cuts(void) { test_cut_positions(); report(60); }
static void run_degenerate(void) { test_degenerate(); report(8); }
static void run_mutations(void) { test_mutations(); report(200); }
static void run_file_sizes(void) { test_file_sizes(); report(25); }

static const TestCase tests[] = {
    {"obj threads: valid texts, every line end and last line", run_valid},
    {"obj threads: polygons and errors in first, late and last pieces", run_placed},
    {"obj threads: piece cuts swept, sizes at buffer and piece boundaries", run_cuts},
    {"obj threads: empty, comments only, blanks only, lone CRs, NUL, long lines",
     run_degenerate},
    {"obj threads: seeded mutations of valid files", run_mutations},
    {"obj threads: whole-file and FIFO reads at buffer sizes", run_file_sizes},
    {"obj threads: a stop request ends a whole-file read", test_read_stop_request},
};

RT_TEST_MAIN(tests)
