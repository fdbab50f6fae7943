/* raytracer -merge: assembles part images (-region, -tile) into the full image. Every
 * part's header and region record is read and checked before anything is written, so a
 * refused merge writes nothing; then the output is written strip by strip from the top,
 * each strip's rows read from the parts that hold them (src/io/rows.c), so a merge holds
 * one strip and a row buffer per part being read, not the images: a 20000x20000 frame
 * is merged in a few MB. The parts' open files are capped below the open-file limit
 * (part_files_cap, rows.c's ImageRowsFiles), so any number of parts merges. A TGA or PPM output is written at its rows' places, a PNG
 * output row by row, both into the temporary file that is renamed at the end; standard
 * output, a pipe or a device gets the whole image at the end, as before (held as bytes
 * meanwhile), so a failure half-way still writes nothing there. */
#include "rt/image.h"
#include "codec.h"

#include <errno.h>
#include <inttypes.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>

/* The part's rectangle in the full image's top-left coordinates. */
typedef struct Part {
    const char *path;
    int x0, y0, x1, y1; /* columns x0..x1-1, rows y0..y1-1 from the top */
} Part;

static bool rects_overlap(const Part *a, const Part *b)
{
    return a->x0 < b->x1 && b->x0 < a->x1 && a->y0 < b->y1 && b->y0 < a->y1;
}

/* The first pixel no part covers (row-major from the top-left); false if none. Only
 * called when the areas do not add up, to say where the gap is. */
static bool find_gap(const Part *parts, int n, int w, int h, int *gx, int *gy)
{
    unsigned char *seen = calloc((size_t)w * (size_t)h, 1);
    if (!seen)
        return false;
    for (int i = 0; i < n; i++)
        for (int y = parts[i].y0; y < parts[i].y1; y++)
            memset(seen + (size_t)y * (size_t)w + (size_t)parts[i].x0, 1,
                   (size_t)(parts[i].x1 - parts[i].x0));
    bool found = false;
    for (size_t k = 0; k < (size_t)w * (size_t)h && !found; k++)
        if (!seen[k]) {
            *gx = (int)(k % (size_t)w);
            *gy = (int)(k / (size_t)w);
            found = true;
        }
    free(seen);
    return found;
}

static void part_describe(const Part *p, char *buf, size_t size)
{
    snprintf(buf, size, "region %d %d %dx%d", p->x0, p->y0, p->x1 - p->x0, p->y1 - p->y0);
}

/* Descriptors left to the rest of the process while parts are open: the standard
 * streams, the output's temporary file, what the C library opens for itself (a
 * locale's message catalogue for strerror), at most half the limit. */
enum { FILES_KEPT = 32 };

/* How many part files may be open at once (rows.c, ImageRowsFiles). Parts side by side
 * are all read in every strip they cross, so with fewer open than that some are closed
 * and opened again at each strip (two system calls a part: cheap beside its rows, but
 * not free), and the soft open-file limit is first raised towards the hard one (which
 * a process may do unprivileged) as far as n parts need: 1024 is the usual soft limit,
 * with hard limits of 4096 to a million. The limit stays raised: the merge is the
 * process's last work. */
static int part_files_cap(int n)
{
    struct rlimit rl;
    if (getrlimit(RLIMIT_NOFILE, &rl) != 0)
        return FILES_KEPT / 2;
    rlim_t want = (rlim_t)n + FILES_KEPT;
    if (rl.rlim_cur != RLIM_INFINITY && rl.rlim_cur < want && rl.rlim_max > rl.rlim_cur) {
        struct rlimit raised = rl;
        raised.rlim_cur = rl.rlim_max != RLIM_INFINITY && rl.rlim_max < want ? rl.rlim_max
                                                                               : want;
        if (setrlimit(RLIMIT_NOFILE, &raised) == 0)
            rl = raised;
    }
    if (rl.rlim_cur == RLIM_INFINITY || rl.rlim_cur >= want)
        return n;
    long soft = (long)rl.rlim_cur;
    long keep = soft / 2 < FILES_KEPT ? soft / 2 : FILES_KEPT;
    return soft - keep < 1 ? 1 : (int)(soft - keep);
}

/* Bytes of output a strip holds at most: a 20000-wide image's strip is 69 rows. */
enum { STRIP_BYTES = 4 << 20 };

/* The part order the strips read in: by first row, then column. */
static int by_top(const void *a, const void *b)
{
    const Part *p = *(const Part *const *)a, *q = *(const Part *const *)b;
    if (p->y0 != q->y0)
        return p->y0 < q->y0 ? -1 : 1;
    return (p->x0 > q->x0) - (p->x0 < q->x0);
}

/* The output on its way to out: how its rows are written. */
typedef struct Sink {
    int how;             /* SINK_FIXED, SINK_PNG, SINK_WHOLE */
    Image img;           /* size only; SINK_WHOLE: the byte image */
    ImageEncoding enc;   /* SINK_FIXED, SINK_PNG: the streamed temporary file */
#ifdef RT_HAVE_PNG
    PngOut *png;
#endif
} Sink;
enum { SINK_FIXED = 1, SINK_PNG, SINK_WHOLE };

#ifdef RT_HAVE_PNG
static bool sink_append(void *ctx, const uint8_t *p, size_t n)
{
    ImageEncoding *e = ctx;
    image_encoding_append(e, p, n);
    return image_encoding_error(e) == 0;
}
#endif

/* Chooses how out is written and begins it; false when out of memory (reported). */
static bool sink_begin(Sink *s, const char *out, int w, int h, Diag *diag)
{
    memset(s, 0, sizeof *s);
    s->img.width = w;
    s->img.height = h;
    if (image_encoding_stream_only(&s->enc, &s->img, out, NULL)) {
        s->how = SINK_FIXED;
        return true;
    }
#ifdef RT_HAVE_PNG
    const ImageCodec *c = image_codec_for_path(out);
    struct stat st;
    if (c && strcmp(c->name, "png") == 0 && strcmp(out, IMAGE_STDOUT) != 0 &&
        (stat(out, &st) != 0 || S_ISREG(st.st_mode)) &&
        image_encoding_stream_raw(&s->enc, &s->img, out)) {
        s->png = png_out_begin(&s->img, sink_append, &s->enc);
        if (s->png) {
            s->how = SINK_PNG;
            return true;
        }
        image_encoding_free(&s->enc);
    }
#endif
    /* Standard output, a pipe or a device (or a file that could not be made: the write
     * at the end says why) */
    if (!image_init_bytes(&s->img, w, h)) {
        diag_error(diag, NULL, "out of memory for a %dx%d image", w, h);
        return false;
    }
    s->how = SINK_WHOLE;
    return true;
}

/* Rows top .. top + n - 1 (from the top), R G B (B G R for a TGA's fixed rows, as
 * sink_bgr says), into the output. */
static bool sink_rows(Sink *s, int top, int n, const uint8_t *rows)
{
    size_t w3 = (size_t)s->img.width * 3;
    int h = s->img.height;
    if (s->how == SINK_FIXED) {
        image_encoding_flush_rows(&s->enc, h - top - n, h - 1 - top, rows);
        return image_encoding_error(&s->enc) == 0;
    }
#ifdef RT_HAVE_PNG
    if (s->how == SINK_PNG) {
        for (int k = 0; k < n; k++)
            if (!png_out_row(s->png, rows + (size_t)k * w3))
                return false;
        return true;
    }
#endif
    for (int k = 0; k < n; k++) /* byte image rows count from the bottom */
        memcpy(s->img.bytes + (size_t)(h - 1 - (top + k)) * w3, rows + (size_t)k * w3, w3);
    return true;
}

static bool sink_bgr(const Sink *s) { return s->how == SINK_FIXED && s->enc.bgr; }

/* Writes the rest and renames the file into place (or writes the whole image). */
static bool sink_finish(Sink *s, const char *out, Diag *diag)
{
#ifdef RT_HAVE_PNG
    if (s->how == SINK_PNG) {
        bool ended = png_out_end(s->png);
        s->png = NULL;
        if (!ended && image_encoding_error(&s->enc) == 0) {
            image_report_write_error(out, ENOMEM, diag);
            return false;
        }
    }
#endif
    if (s->how == SINK_WHOLE)
        return image_write(&s->img, out, diag);
    ImageOutput one = {&s->img, out, NULL, &s->enc};
    return image_write_all(&one, 1, diag);
}

static void sink_free(Sink *s)
{
#ifdef RT_HAVE_PNG
    png_out_free(s->png);
    s->png = NULL;
#endif
    if (s->how == SINK_FIXED || s->how == SINK_PNG)
        image_encoding_free(&s->enc);
    image_free(&s->img);
}

/* Writes the checked parts into out, strip by strip. */
static bool write_strips(const char *out, Part *parts, ImageRows *rows, int n, int fw, int fh,
                         const volatile int *stop, Diag *diag)
{
    size_t w3 = (size_t)fw * 3;
    int strip = (int)(STRIP_BYTES / w3);
    if (strip < 1)
        strip = 1;
    if (strip > fh)
        strip = fh;
    int widest = 1;
    for (int i = 0; i < n; i++)
        if (parts[i].x1 - parts[i].x0 > widest)
            widest = parts[i].x1 - parts[i].x0;
    Part **order = malloc((size_t)n * sizeof *order);
    uint8_t *buf = malloc(w3 * (size_t)strip);
    uint8_t *row = malloc((size_t)widest * 3);
    Sink sink;
    bool ok = order && buf && row;
    if (!ok)
        diag_error(diag, NULL, "out of memory");
    else
        ok = sink_begin(&sink, out, fw, fh, diag);
    if (!ok) {
        free(order);
        free(buf);
        free(row);
        return false;
    }
    for (int i = 0; i < n; i++)
        order[i] = &parts[i];
    qsort(order, (size_t)n, sizeof *order, by_top);
    bool bgr = sink_bgr(&sink);
    int first = 0; /* parts before it in order are all written */
    for (int top = 0; top < fh && ok; top += strip) {
        /* A big merge takes a while: a stop is obeyed between strips. */
        if (stop && *stop) {
            ok = false;
            break;
        }
        int end = top + strip < fh ? top + strip : fh;
        while (first < n && order[first]->y1 <= top)
            first++;
        for (int k = first; k < n && ok && order[k]->y0 < end; k++) {
            Part *p = order[k];
            if (p->y1 <= top)
                continue;
            ImageRows *r = &rows[p - parts];
            int pw = p->x1 - p->x0;
            int from = p->y0 > top ? p->y0 : top, to = p->y1 < end ? p->y1 : end;
            for (int y = from; y < to && ok; y++) {
                ok = image_rows_read(r, y - p->y0, row, diag);
                uint8_t *dst = buf + (size_t)(y - top) * w3 + (size_t)p->x0 * 3;
                if (ok && bgr) {
                    for (int x = 0; x < pw; x++) {
                        dst[3 * x] = row[3 * x + 2];
                        dst[3 * x + 1] = row[3 * x + 1];
                        dst[3 * x + 2] = row[3 * x];
                    }
                } else if (ok) {
                    memcpy(dst, row, (size_t)pw * 3);
                }
            }
            /* Its last row is read: its file is closed (a PNG's end checked). */
            if (ok && p->y1 <= end)
                ok = image_rows_end(r, diag);
        }
        if (ok && !sink_rows(&sink, top, end - top, buf)) {
            ok = false;
            if (sink.how == SINK_FIXED || sink.how == SINK_PNG) {
                int e = image_encoding_error(&sink.enc);
                image_report_write_error(out, e ? e : ENOMEM, diag);
            }
        }
    }
    if (ok && stop && *stop)
        ok = false;
    if (ok)
        ok = sink_finish(&sink, out, diag);
    sink_free(&sink);
    free(order);
    free(buf);
    free(row);
    return ok;
}

bool image_merge(const char *out, const char *const *paths, int n,
                 const volatile int *stop, Diag *diag)
{
    if (n < 1) {
        diag_error(diag, NULL, "-merge %s: no parts to merge", out);
        return false;
    }
    /* The output is checked first, as a render checks it before its work: a missing or
     * read-only folder is named before any part is read. */
    if (!image_check_output(out, NULL, diag))
        return false;
    Part *parts = calloc((size_t)n, sizeof *parts);
    ImageRows *rows = calloc((size_t)n, sizeof *rows);
    if (!parts || !rows) {
        free(parts);
        free(rows);
        diag_error(diag, NULL, "out of memory");
        return false;
    }
    for (int i = 0; i < n; i++)
        rows[i].fd = -1;
    ImageRowsFiles files = {0, part_files_cap(n), NULL, NULL};
    bool ok = true;
    int fw = 0, fh = 0;
    bool has_id = false;
    uint64_t id = 0;
    long long area = 0;
    /* A part's header is quick to check, but a part from a pipe is read whole: a stop
     * is obeyed between parts, not only after all of them. */
    for (int i = 0; i < n && ok; i++) {
        if (stop && *stop) {
            ok = false;
            break;
        }
        Part *p = &parts[i];
        p->path = paths[i];
        SrcLoc loc = {p->path, 0, 0};
        ImageRows *img = &rows[i];
        if (!image_rows_open(img, p->path, diag)) {
            ok = false;
            break;
        }
        img->files = &files;
        if (!img->has_region) {
            diag_error(diag, &loc, "not a part image: it has no region record (write parts "
                       "with -region or -tile)");
            ok = false;
            break;
        }
        const ImageRegion *r = &img->region;
        p->x0 = r->x;
        p->y0 = r->y;
        p->x1 = r->x + img->width;
        p->y1 = r->y + img->height;
        if (i == 0) {
            fw = r->full_width;
            fh = r->full_height;
            has_id = r->has_id;
            id = r->id;
        } else if (r->full_width != fw || r->full_height != fh) {
            diag_error(diag, &loc, "part of a %dx%d image, but %s is part of a %dx%d image",
                       r->full_width, r->full_height, parts[0].path, fw, fh);
            ok = false;
        } else if (r->has_id != has_id) {
            /* Without an identity nothing tells whether the parts belong together: an
             * earlier version's parts merge only among themselves. */
            if (r->has_id)
                diag_error(diag, &loc, "has a render identity but %s has none (written "
                           "by an earlier raytracer): cannot tell whether they come from "
                           "the same render; render all the parts again", parts[0].path);
            else
                diag_error(diag, &loc, "has no render identity (written by an earlier "
                           "raytracer) but %s has one: cannot tell whether they come from "
                           "the same render; render all the parts again", parts[0].path);
            ok = false;
        } else if (r->id != id) {
            diag_error(diag, &loc, "part of another render than %s (render identity "
                       "%016" PRIx64 " against %016" PRIx64 "): another scene, other OBJ "
                       "files, another image kind or other options that change pixels",
                       parts[0].path, r->id, id);
            ok = false;
        }
        for (int j = 0; j < i && ok; j++) {
            if (rects_overlap(p, &parts[j])) {
                char a[80], b[80];
                part_describe(p, a, sizeof a);
                part_describe(&parts[j], b, sizeof b);
                diag_error(diag, &loc, "%s overlaps %s (%s)", a, parts[j].path, b);
                ok = false;
            }
        }
        area += (long long)(p->x1 - p->x0) * (p->y1 - p->y0);
    }
    /* Inside the full image and pairwise disjoint: they cover it exactly when the areas
     * add up to its size. */
    if (ok && area != (long long)fw * fh) {
        /* Not located at the output: it does not exist, and nothing is wrong with it. */
        int gx = 0, gy = 0;
        if (find_gap(parts, n, fw, fh, &gx, &gy))
            diag_error(diag, NULL, "-merge %s: the %d %s not cover the %dx%d image: no "
                       "part has pixel (%d, %d) (x, y from the top-left); nothing written",
                       out, n, n == 1 ? "part does" : "parts do", fw, fh, gx, gy);
        else
            diag_error(diag, NULL, "-merge %s: the %d %s not cover the %dx%d image; "
                       "nothing written", out, n, n == 1 ? "part does" : "parts do", fw, fh);
        ok = false;
    }
    if (ok && stop && *stop)
        ok = false;
    /* Inside the full image (the read checked the record), disjoint and covering it:
     * every output pixel comes from exactly one part. */
    if (ok)
        ok = write_strips(out, parts, rows, n, fw, fh, stop, diag);
    for (int i = 0; i < n; i++)
        image_rows_free(&rows[i]);
    free(rows);
    free(parts);
    return ok;
}
