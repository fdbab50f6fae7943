/* OBJ reader for TriangleMesh (docs/scene-format.md): one read of the whole file, then a
 * single line-oriented pass over memory. Same triangles as the course reader on the
 * official files; also slash forms, polygons (fanned), negative indices and CRLF. */
#include "obj_loader.h"
#include "lexer.h"

#include <assert.h>
#include <limits.h>
#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rt/bigmem.h"
#include "rt/file.h"
#include "rt/geom.h"
#include "rt/par.h"

/* Files from this size on are read in pieces of about OBJ_PIECE_BYTES, each ending at a
 * line end: some 20 pieces for the 40k bunny (1.3 MB). */
#define OBJ_PAR_MIN_BYTES RT_FILE_PAR_MIN_BYTES
#define OBJ_PIECE_BYTES ((size_t)64 << 10)
/* The serial reader looks at the stop request (rt/par.h) every this many lines (a power
 * of two): ~2 MB of a mesh's text, some 10 ms of reading, for one test per line of an
 * already counted line number. The pieces look at it before each piece. */
#define OBJ_STOP_LINES 65536

void objfile_mesh_free(ObjMesh *m)
{
    /* The faces first: allocated after the vertices, they may be the pool's top block,
     * and then the vertices are too once the faces are gone (rt/bigmem.h). */
    bigmem_free(m->tris);
    bigmem_free(m->verts);
    memset(m, 0, sizeof *m);
}

/* Powers of ten exactly representable as floats (5^10 < 2^24). */
static const float k_pow10f[] = {1e0f, 1e1f, 1e2f, 1e3f, 1e4f, 1e5f,
                                 1e6f, 1e7f, 1e8f, 1e9f, 1e10f};

static bool is_digit(char c) { return c >= '0' && c <= '9'; }
static bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

bool objfile_parse_float(const char **pp, const char *end, float *out)
{
    const char *p = *pp;
    const char *s = p;
    bool neg = false;
    if (*p == '+' || *p == '-')
        neg = *p++ == '-';
    uint64_t mant = 0;
    int sig = 0, digits = 0, exp10 = 0;
    /* Leading zeros carry no significance; then up to 19 digits fit a uint64_t exactly. */
    while (*p == '0') {
        digits++;
        p++;
    }
    while (is_digit(*p)) {
        if (sig < 19)
            mant = mant * 10 + (uint64_t)(*p - '0');
        else
            exp10++;
        sig++;
        digits++;
        p++;
    }
    if (*p == '.') {
        p++;
        if (sig == 0)
            while (*p == '0') {
                exp10--;
                digits++;
                p++;
            }
        while (is_digit(*p)) {
            if (sig < 19) {
                mant = mant * 10 + (uint64_t)(*p - '0');
                exp10--;
            }
            sig++;
            digits++;
            p++;
        }
    }
    bool fast = digits > 0;
    if (fast && (*p == 'e' || *p == 'E')) {
        const char *q = p + 1;
        bool eneg = false;
        if ((*q == '+' || *q == '-'))
            eneg = *q++ == '-';
        if (is_digit(*q)) {
            int e = 0;
            while (is_digit(*q)) {
                if (e < 100000)
                    e = e * 10 + (*q - '0');
                q++;
            }
            exp10 += eneg ? -e : e;
            p = q;
        }
    }
    /* Clinger's fast path: an exact mantissa times/over an exact power of ten rounds
     * once, so it is the correctly rounded value strtof returns too. */
    if (fast && sig <= 19 && mant <= (1u << 24) && exp10 >= -10 && exp10 <= 10 &&
        (!(*p == 'x' || *p == 'X' || *p == 'n' || *p == 'N'))) {
        float v = (float)mant;
        v = exp10 < 0 ? v / k_pow10f[-exp10] : v * k_pow10f[exp10];
        *out = neg ? -v : v;
        *pp = p;
        return true;
    }
    /* Everything else (long mantissas, big exponents, hex, inf/nan): strtof itself on a
     * bounded NUL-terminated copy of the run of non-blank bytes. */
    char tmp[128];
    size_t n = 0;
    while (s + n < end && n + 1 < sizeof tmp && !is_blank(s[n]) && s[n] != '\n' && s[n] != '\0')
        n++;
    memcpy(tmp, s, n);
    tmp[n] = '\0';
    char *e;
    float v = strtof(tmp, &e);
    if (e == tmp)
        return false;
    *out = v;
    *pp = s + (e - tmp);
    return true;
}

typedef struct ObjReader {
    const char *buf, *end, *p;
    const char *line_start;
    int line;
    const char *name;
    Diag *diag;
    ObjMesh *m;
    int cap_v, cap_t;
    /* A piece of a file read in parallel (parse_pieces): the vertices before it are
     * not known yet, so a positive face index is only remembered as an excess over the
     * piece's own vertex count (checked against the count before the piece later),
     * and a negative one, which needs that count, fails the piece. */
    bool piece;
    long excess;    /* max over the piece's face indices of index - nverts so far */
    /* The arrays are a piece's slots in the whole mesh's (parse_pieces), sized by
     * count_records: they cannot grow, and a record beyond them fails the piece. */
    bool fixed;
} ObjReader;

static SrcLoc objfile_loc(const ObjReader *r, const char *at)
{
    /* In characters, as the scene's columns (lex_chars). Only made for a message: it
     * walks the line up to at. */
    size_t col = lex_chars(r->line_start, (size_t)(at - r->line_start)) + 1;
    SrcLoc l = {r->name, r->line, col > INT_MAX ? INT_MAX : (int)col};
    return l;
}

static void skip_blanks(ObjReader *r)
{
    while (is_blank(*r->p))
        r->p++;
}

static bool at_eol(const ObjReader *r) { return *r->p == '\n' || *r->p == '\0'; }
/* A number or index ends at a blank, the line's end or a comment: "f 1 2 3#c" is the
 * face 1 2 3, as "f 1 2 3 #c" is. */
static bool at_sep(const ObjReader *r) { return at_eol(r) || is_blank(*r->p) || *r->p == '#'; }

/* How much of the word at `at` a message quotes: up to the next blank or the line's
 * end, at most 60 characters. */
static int word_len(const char *at)
{
    const char *e = at;
    while (*e && !is_blank(*e) && *e != '\n' && e - at < 60)
        e++;
    return (int)(e - at);
}

static bool grow(void **arr, int *cap, int need, size_t elem)
{
    if (need <= *cap)
        return true;
    int nc = *cap ? *cap : 1024;
    while (nc < need)
        nc = nc > INT_MAX / 2 ? INT_MAX : nc * 2;
    if ((size_t)nc > SIZE_MAX / elem)
        return false;
    void *na = bigmem_resize(*arr, (size_t)nc * elem);
    if (!na)
        return false;
    *arr = na;
    *cap = nc;
    return true;
}

/* A number of the common vertex form: an optional '-', digits, an optional '.' and
 * digits, at most 9 digits in all (no '+', no exponent, not hex, inf or nan): its
 * float into *out and the end into *pp, or false with *pp untouched. The same float as
 * objfile_parse_float: the same mantissa (leading zeros add nothing to it) and power
 * of ten (minus the fraction's digits), taken by the same Clinger step, which is its
 * fast path for such numbers. */
static inline bool simple_float(const char **pp, float *out)
{
    const char *p = *pp;
    bool neg = *p == '-';
    p += neg;
    const char *d0 = p;
    uint32_t mant = 0;
    while (is_digit(*p))
        mant = mant * 10 + (uint32_t)(*p++ - '0');
    size_t nint = (size_t)(p - d0), frac = 0;
    if (nint == 0)
        return false;
    if (*p == '.') {
        const char *f0 = ++p;
        while (is_digit(*p))
            mant = mant * 10 + (uint32_t)(*p++ - '0');
        frac = (size_t)(p - f0);
    }
    /* Up to 9 digits the uint32_t cannot wrap (more: the general reader); 2^24 is the
     * bound of objfile_parse_float's fast path. */
    if (nint + frac > 9 || mant > (1u << 24))
        return false;
    float v = (float)mant;
    v = frac ? v / k_pow10f[frac] : v;
    *out = neg ? -v : v;
    *pp = p;
    return true;
}

/* Whether the record ends at p as read_vertex and read_face end one after its last
 * number: blanks (CR among them), then the line's end (LF or the text's end) or a
 * comment ('#', glued or not). A CR LF line, a comment after the record, trailing
 * blanks. (CR LF files, as Windows tools write them, went all through read_vertex once,
 * and so did every vertex with a comment after b502bad: 21% more instructions for the
 * 40k bunny with one on every line; regress37, bench/REPORT.txt.) */
static inline bool ends_record(const char *p)
{
    if (*p == '\n' || (*p == '\r' && p[1] == '\n'))
        return true; /* the common cases, LF and CR LF, first */
    while (is_blank(*p))
        p++;
    return *p == '\n' || *p == '\0' || *p == '#';
}

/* The common vertex record "v x y z": single spaces, numbers of simple_float's form,
 * the record's end right after the third (ends_record: what follows is only blanks and
 * a comment; more numbers, a w or a colour, are read_vertex's to check), and room in
 * the array. Read without
 * read_vertex's machinery (its locations for messages, blank runs, the general number
 * reader): the same vertex. Anything else returns false with r untouched, and
 * read_vertex takes the line from the start, so messages do not change. */
static bool read_vertex_simple(ObjReader *r)
{
    if (r->m->nverts >= r->cap_v)
        return false;
    const char *p = r->p;
    float c[3];
    for (int k = 0; k < 3; k++) {
        if (*p != ' ')
            return false;
        p++;
        if (!simple_float(&p, &c[k]) || !(k < 2 ? *p == ' ' : ends_record(p)))
            return false;
    }
    r->m->verts[r->m->nverts++] = v3(c[0], c[1], c[2]);
    r->p = p;
    return true;
}

static bool read_vertex(ObjReader *r)
{
    float c[3];
    for (int i = 0; i < 3; i++) {
        skip_blanks(r);
        const char *at = r->p;
        SrcLoc l;
        if (at_eol(r) || *r->p == '#') {
            l = objfile_loc(r, at);
            diag_error(r->diag, &l, "vertex needs 3 coordinates, found %d", i);
            return false;
        }
        if (!objfile_parse_float(&r->p, r->end, &c[i]) || !at_sep(r)) {
            int shown = word_len(at);
            l = objfile_loc(r, at);
            /* "1,5": a decimal comma, as a tool set to a European locale writes it.
             * Said as the scene parser says it (a number of digits with a comma). */
            const char *d = at + (*at == '+' || *at == '-');
            bool comma = is_digit(*d) && memchr(at, ',', (size_t)shown) != NULL;
            diag_error(r->diag, &l, "malformed number '%.*s'%s", shown, at,
                       comma ? " (numbers are separated by white space, and their decimal "
                               "point is '.')"
                             : "");
            return false;
        }
        if (!isfinite(c[i])) {
            l = objfile_loc(r, at);
            diag_error(r->diag, &l, "number out of range: '%.*s'", (int)(r->p - at), at);
            return false;
        }
    }
    /* A fourth (w) coordinate or vertex colours (r g b, r g b a) may follow: at most
     * four numbers, ignored. Anything else is an error rather than skipped: a word
     * there is most often the next record run into this line ("v 1 2 3 v 4 5 6" from
     * a lost line break), whose vertex would otherwise vanish without a word. */
    for (int extra = 0;; extra++) {
        skip_blanks(r);
        if (at_eol(r) || *r->p == '#')
            break;
        const char *at = r->p;
        float ignored;
        if (extra == 4 || !objfile_parse_float(&r->p, r->end, &ignored) || !at_sep(r)) {
            int shown = word_len(at);
            SrcLoc l = objfile_loc(r, at);
            diag_error(r->diag, &l,
                       "unexpected '%.*s' after the vertex's coordinates (%s)", shown, at,
                       at[-1] == '\r' ? OBJ_LONE_CR_HINT
                                       : "a vertex is 'v x y z', then at most a w or a "
                                         "colour's 3 or 4 numbers");
            return false;
        }
    }
    if (r->m->nverts >= r->cap_v &&
        (r->m->nverts == INT_MAX || r->fixed ||
         !grow((void **)&r->m->verts, &r->cap_v, r->m->nverts + 1, sizeof(Vec3)))) {
        SrcLoc l = objfile_loc(r, r->line_start);
        diag_error(r->diag, &l, "out of memory (too many vertices)");
        return false;
    }
    r->m->verts[r->m->nverts++] = v3(c[0], c[1], c[2]);
    return true;
}

/* One integer of a face vertex ("12", "-3"); false if no digits. */
static bool read_index(ObjReader *r, long *out)
{
    const char *p = r->p;
    bool neg = false;
    if (*p == '+' || *p == '-')
        neg = *p++ == '-';
    if (!is_digit(*p))
        return false;
    long v = 0;
    while (is_digit(*p)) {
        if (v < 100000000000L)
            v = v * 10 + (*p - '0');
        p++;
    }
    *out = neg ? -v : v;
    r->p = p;
    return true;
}

static bool read_face(ObjReader *r, const char *f_at)
{
    int first = -1, prev = -1, count = 0;
    for (;;) {
        skip_blanks(r);
        if (at_eol(r) || *r->p == '#') /* a trailing comment ends the face */
            break;
        const char *at = r->p;
        SrcLoc l; /* made only for a message (objfile_loc walks the line) */
        long idx, ignored;
        bool ok = read_index(r, &idx);
        /* read_index saturates long runs of digits, so a message quotes the index as
         * written rather than the saturated value (which is in no file). */
        const char *idx_end = r->p;
        /* v, v/vt, v/vt/vn, v//vn: only the vertex index matters here. */
        if (ok && *r->p == '/') {
            r->p++;
            if (*r->p != '/')
                ok = read_index(r, &ignored) || at_sep(r);
            if (ok && *r->p == '/') {
                r->p++;
                ok = read_index(r, &ignored);
            }
        }
        if (!ok || !at_sep(r)) {
            int shown = word_len(at);
            l = objfile_loc(r, at);
            /* "f 1 2 3\rf 4 5 6": the next face run into this one after a lone CR, as
             * a vertex's is (a file whose lone CRs start after its faces begin). */
            diag_error(r->diag, &l, "malformed face vertex '%.*s'%s", shown, at,
                       at[-1] == '\r' ? " (" OBJ_LONE_CR_HINT ")" : "");
            return false;
        }
        int nv = r->m->nverts;
        long resolved = idx > 0 ? idx - 1 : (long)nv + idx;
        if (r->piece && idx > 0 && idx <= INT_MAX) {
            if (idx - nv > r->excess)
                r->excess = idx - nv;
        } else if (r->piece || idx == 0 || resolved < 0 || resolved >= nv) {
            l = objfile_loc(r, at);
            if (idx == 0)
                diag_error(r->diag, &l, "vertex index 0 out of range (indices start at 1)");
            else
                diag_error(r->diag, &l, "vertex index %.*s out of range (%d vertices)",
                           (int)(idx_end - at), at, nv);
            return false;
        }
        int vi = (int)resolved;
        if (count == 0) {
            first = vi;
        } else if (count >= 2) {
            if (r->m->ntris >= r->cap_t &&
                (r->m->ntris == INT_MAX || r->fixed ||
                 !grow((void **)&r->m->tris, &r->cap_t, r->m->ntris + 1, sizeof(int[3])))) {
                l = objfile_loc(r, at);
                diag_error(r->diag, &l, "out of memory (too many faces)");
                return false;
            }
            int *t = r->m->tris[r->m->ntris++];
            t[0] = first;
            t[1] = prev;
            t[2] = vi;
        }
        prev = vi;
        count++;
    }
    if (count < 3) {
        SrcLoc l = objfile_loc(r, f_at);
        diag_error(r->diag, &l, "face with %d vertices (at least 3 needed)", count);
        return false;
    }
    return true;
}

/* The common face record "f a b c": single spaces, plain positive in-range indices, the
 * record ending right after (ends_record). Read without the general machinery of
 * read_face (same triangle); anything else returns false with r untouched, and
 * read_face takes the line from the start, so messages do not change. */
static bool read_face_simple(ObjReader *r)
{
    const char *p = r->p;
    int nv = r->m->nverts, idx[3];
    for (int k = 0; k < 3; k++) {
        if (*p != ' ' || !is_digit(p[1]))
            return false;
        p++;
        int v = 0, nd = 0;
        while (is_digit(*p)) {
            if (++nd > 9)
                return false; /* no overflow; read_face handles long indices */
            v = v * 10 + (*p++ - '0');
        }
        if (v < 1)
            return false;
        if (v > nv) {
            if (!r->piece)
                return false;
            if (v - nv > r->excess)
                r->excess = v - nv;
        }
        idx[k] = v - 1;
    }
    if (!ends_record(p))
        return false;
    if (r->m->ntris >= r->cap_t &&
        (r->m->ntris == INT_MAX || r->fixed ||
         !grow((void **)&r->m->tris, &r->cap_t, r->m->ntris + 1, sizeof(int[3]))))
        return false;
    int *t = r->m->tris[r->m->ntris++];
    t[0] = idx[0];
    t[1] = idx[1];
    t[2] = idx[2];
    r->p = p;
    return true;
}

/* A UTF-8 byte-order mark at the start of a line is no part of its record: it is where
 * files were joined (cat a.obj b.obj) of which the later began with one, as Windows
 * tools write them. Taken as the record's name, "\xEF\xBB\xBFv" was an unknown record,
 * skipped: the vertex vanished, and the faces after it took the wrong vertices or none.
 * It still counts as a column (objfile_loc walks the line), as an editor shows it. */
static const char *skip_line_bom(const char *p)
{
    /* Byte by byte: the text ends in a NUL, which stops the test before the end. */
    return p[0] == '\xEF' && p[1] == '\xBB' && p[2] == '\xBF' ? p + 3 : p;
}

static atomic_ulong g_general_records; /* objfile_general_records */

unsigned long objfile_general_records(void) { return atomic_load(&g_general_records); }

static void general_record(void)
{
    atomic_fetch_add_explicit(&g_general_records, 1, memory_order_relaxed);
}

/* The records of r->p .. r->end, line by line; false after reporting an error, or
 * with nothing reported when a stop was requested (rt/par.h). */
static bool parse_lines(ObjReader *r)
{
    while (r->p < r->end) {
        r->line_start = r->p;
        r->p = skip_line_bom(r->p);
        skip_blanks(r);
        const char *kw = r->p;
        while (*r->p && !is_blank(*r->p) && *r->p != '\n')
            r->p++;
        size_t kl = (size_t)(r->p - kw);
        bool ok = true;
        if (kl == 1 && kw[0] == 'v')
            ok = read_vertex_simple(r) || (general_record(), read_vertex(r));
        else if (kl == 1 && kw[0] == 'f')
            ok = read_face_simple(r) || (general_record(), read_face(r, kw));
        else if (kl == 1 && (kw[0] == 'V' || kw[0] == 'F')) {
            /* OBJ keywords are lower case, and no tool writes these; skipped as unknown
             * records, a hand-written file in capitals lost every vertex or face
             * silently ("has no faces", or indices out of range at the first face). */
            SrcLoc l = objfile_loc(r, kw);
            diag_error(r->diag, &l, "'%c' is not an OBJ record (keywords are lower case: "
                                    "did you mean '%c'?)",
                       kw[0], kw[0] == 'V' ? 'v' : 'f');
            return false;
        }
        /* Anything else (#, vn, vt, g, o, s, usemtl, mtllib, l, ...) is skipped. */
        if (!ok)
            return false;
        while (*r->p && *r->p != '\n')
            r->p++;
        if (*r->p == '\n') {
            r->p++;
            if (r->line < INT_MAX)
                r->line++;
            if ((r->line & (OBJ_STOP_LINES - 1)) == 0 && par_stop_requested())
                return false; /* stopped: nothing to report */
        }
    }
    return true;
}

/* How many vertices and faces parse_lines reads in p .. end (NUL-terminated at or after
 * end, every line but the text's last ending in '\n'): the same lines and keywords as
 * parse_lines, so the vertex count is exact for text that parses, and so is the face
 * count as a triangle count when every face is a triangle (a polygon makes more); for
 * text that does not parse they are just finite. Cheap next to the parse (one memchr
 * per line, no numbers converted: an eighth of its instructions), and it lets each piece
 * be read straight into its place (parse_pieces). */
static void count_records(const char *p, const char *end, long *nverts, long *nfaces)
{
    long nv = 0, nf = 0;
    while (p < end) {
        p = skip_line_bom(p);
        while (is_blank(*p))
            p++;
        if ((*p == 'v' || *p == 'f') && (is_blank(p[1]) || p[1] == '\n' || p[1] == '\0')) {
            nv += *p == 'v';
            nf += *p == 'f';
        }
        const char *nl = p < end ? memchr(p, '\n', (size_t)(end - p)) : NULL;
        p = nl ? nl + 1 : end;
    }
    *nverts = nv;
    *nfaces = nf;
}

/* ---- reading a big file in pieces, in parallel (rt/par.h) ---- */

enum { OBJ_MAX_PIECES = 4096 };

static atomic_ulong g_pieces_read; /* objfile_pieces_read */

unsigned long objfile_pieces_read(void) { return atomic_load(&g_pieces_read); }

typedef struct ObjPiece {
    const char *begin, *end;
    long nverts, ntris;   /* counted (count_records: faces as triangles) */
    long vbefore, tbefore; /* counted vertices and triangles of the pieces before it */
    int got_v, got_t;     /* read by parse_piece */
    long excess;          /* ObjReader.excess */
    bool ok;
} ObjPiece;

typedef struct PieceJob {
    ObjPiece *piece;
    Vec3 *verts;          /* the whole mesh's arrays: each piece fills its own slots */
    int (*tris)[3];
} PieceJob;

static void count_piece(void *ctx, int i, int worker)
{
    (void)worker;
    ObjPiece *pc = &((PieceJob *)ctx)->piece[i];
    if (par_stop_requested())
        return; /* parse_pieces gives up after this pass */
    count_records(pc->begin, pc->end, &pc->nverts, &pc->ntris);
}

/* Piece i read straight into its slots of the whole mesh's arrays. */
static void parse_piece(void *ctx, int i, int worker)
{
    (void)worker;
    PieceJob *job = ctx;
    ObjPiece *pc = &job->piece[i];
    if (par_stop_requested())
        return; /* pc->ok stays false: the whole read fails, and is not done again */
    Diag quiet; /* a failed piece is read again by the serial reader, which reports */
    diag_init(&quiet, NULL);
    ObjMesh mesh = {job->verts ? job->verts + pc->vbefore : NULL, 0,
                    job->tris ? job->tris + pc->tbefore : NULL, 0};
    ObjReader r;
    memset(&r, 0, sizeof r);
    r.buf = r.p = r.line_start = pc->begin;
    r.end = pc->end;
    r.line = 1;
    r.name = "";
    r.diag = &quiet;
    r.m = &mesh;
    r.cap_v = (int)pc->nverts;
    r.cap_t = (int)pc->ntris;
    r.fixed = true;
    r.piece = true;
    r.excess = LONG_MIN;
    pc->ok = parse_lines(&r);
    pc->excess = r.excess;
    pc->got_v = mesh.nverts;
    pc->got_t = mesh.ntris;
}

/* The whole of buf read as pieces: exactly the mesh the serial reader makes, or false
 * (out untouched) when a piece has an error, a negative index or an index beyond the
 * vertices read so far, or memory runs out; the serial reader then reads the file
 * again and reports. Each piece is counted first (count_records), so it is read straight
 * into its place in the whole mesh's arrays: no arrays per piece, no copying them
 * together afterwards. A piece that reads other than it counted (a polygon face) fails
 * the same way: such files are read by the serial reader, which on two threads was
 * about as fast as the pieces with their own arrays and the copy. */
static bool parse_pieces(const char *buf, size_t len, ObjMesh *out)
{
    size_t want = len / OBJ_PIECE_BYTES;
    int n = want > OBJ_MAX_PIECES ? OBJ_MAX_PIECES : (int)want;
    ObjPiece *piece = calloc((size_t)n, sizeof *piece);
    if (!piece)
        return false;
    /* Piece k starts after the first line end at or after k * len / n. */
    const char *end = buf + len;
    const char *at = buf;
    int np = 0;
    for (int k = 0; k < n && at < end; k++) {
        const char *cut = k + 1 < n ? buf + (size_t)((uint64_t)len * (uint64_t)(k + 1) / (uint64_t)n) : end;
        if (cut < at)
            cut = at;
        const char *nl = cut < end ? memchr(cut, '\n', (size_t)(end - cut)) : NULL;
        cut = nl ? nl + 1 : end;
        piece[np].begin = at;
        piece[np].end = cut;
        np++;
        at = cut;
    }
    PieceJob job = {piece, NULL, NULL};
    par_for(np, count_piece, &job);
    if (par_stop_requested()) { /* the counts may be cut short: nothing is allocated */
        free(piece);
        return false;
    }
    long nv = 0, nt = 0;
    for (int k = 0; k < np; k++) {
        piece[k].vbefore = nv;
        piece[k].tbefore = nt;
        nv += piece[k].nverts;
        nt += piece[k].ntris;
    }
    bool ok = nv < INT_MAX && nt < INT_MAX;
    if (ok && nv) {
        job.verts = bigmem_calloc((size_t)nv, sizeof *job.verts);
        ok = job.verts != NULL;
    }
    if (ok && nt) {
        job.tris = bigmem_calloc((size_t)nt, sizeof *job.tris);
        ok = job.tris != NULL;
    }
    if (ok)
        par_for(np, parse_piece, &job);
    for (int k = 0; k < np && ok; k++) {
        const ObjPiece *pc = &piece[k];
        ok = pc->ok && pc->excess <= pc->vbefore && pc->got_v == pc->nverts &&
             pc->got_t == pc->ntris;
    }
    if (ok) {
        atomic_fetch_add(&g_pieces_read, 1);
        out->verts = job.verts;
        out->nverts = (int)nv;
        out->tris = job.tris;
        out->ntris = (int)nt;
    } else {
        bigmem_free(job.verts);
        bigmem_free(job.tris);
    }
    free(piece);
    return ok;
}

bool objfile_parse(const char *buf, size_t len, const char *name, ObjMesh *out, Diag *diag)
{
    memset(out, 0, sizeof *out);
    /* The scanners stop at the terminating NUL instead of comparing with the end on
     * every byte; a NUL inside the text is refused below, so NUL means end of buffer. */
    assert(buf[len] == '\0');
    /* A UTF-8 byte-order mark at the start (some editors write one) is no record:
     * skipped, as the scene lexer does; columns then count from the character after it. */
    if (len >= 3 && memcmp(buf, "\xEF\xBB\xBF", 3) == 0) {
        buf += 3;
        len -= 3;
    }
    if (memchr(buf, '\0', len)) {
        /* Binary data: say so instead of a confusing message about its first line. */
        const char *z = memchr(buf, '\0', len);
        ObjReader r = {buf, buf + len, buf, buf, 1, name, diag, out, 0, 0, false, 0, false};
        for (const char *q = buf; q < z; q++)
            if (*q == '\n') {
                r.line++;
                r.line_start = q + 1;
            }
        SrcLoc l = objfile_loc(&r, z);
        diag_error(diag, &l, "NUL byte: not a text OBJ file");
        return false;
    }
    /* Pieces cut short by a stop fail as any failed piece does; the serial reader then
     * stops too, at its first look (within OBJ_STOP_LINES lines). */
    if (len >= OBJ_PAR_MIN_BYTES && par_threads() > 1 && parse_pieces(buf, len, out))
        return true;
    ObjReader r = {buf, buf + len, buf, buf, 1, name, diag, out, 0, 0, false, 0, false};
    if (!parse_lines(&r)) {
        objfile_mesh_free(out);
        return false;
    }
    return true;
}

bool objfile_has_lone_cr(const char *buf, size_t len)
{
    for (const char *p = buf, *end = buf + len; (p = memchr(p, '\r', (size_t)(end - p)));)
        if (++p < end && *p != '\n')
            return true;
    return false;
}

Object3D *objfile_build_group(Arena *a, const ObjMesh *mesh, const Material *m, void *block)
{
    return triangle_mesh_new_in(a, block, mesh->verts, (const int(*)[3])mesh->tris,
                                mesh->ntris, m);
}
