/* raytracer -merge: assembles part images (-region, -tile) into the full image. Every
 * part is read and checked before anything is written, so a refused merge writes
 * nothing. Each part is copied into the full image's bytes as soon as it is read and
 * checked, and freed: one part's pixels are held at a time, and the full image is a
 * byte image (rt/image.h) that the encoder only copies. */
#include "rt/image.h"

#include <inttypes.h>
#include <stdlib.h>
#include <string.h>

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
    if (!parts) {
        diag_error(diag, NULL, "out of memory");
        return false;
    }
    bool ok = true;
    int fw = 0, fh = 0;
    bool has_id = false;
    uint64_t id = 0;
    long long area = 0;
    Image full;
    memset(&full, 0, sizeof full);
    /* A part of a big image takes a while to read (a 4000x4000 PNG about 0.3 s): a stop
     * is obeyed between parts, not only after all of them. */
    for (int i = 0; i < n && ok; i++) {
        if (stop && *stop) {
            ok = false;
            break;
        }
        Part *p = &parts[i];
        p->path = paths[i];
        SrcLoc loc = {p->path, 0, 0};
        Image img;
        if (!image_read(&img, p->path, diag)) {
            ok = false;
            break;
        }
        if (!img.has_region) {
            diag_error(diag, &loc, "not a part image: it has no region record (write parts "
                       "with -region or -tile)");
            image_free(&img);
            ok = false;
            break;
        }
        const ImageRegion *r = &img.region;
        p->x0 = r->x;
        p->y0 = r->y;
        p->x1 = r->x + img.width;
        p->y1 = r->y + img.height;
        if (i == 0) {
            fw = r->full_width;
            fh = r->full_height;
            has_id = r->has_id;
            id = r->id;
            if (!image_init_bytes(&full, fw, fh)) {
                diag_error(diag, NULL, "out of memory for a %dx%d image", fw, fh);
                ok = false;
            }
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
        /* Inside the full image (image_read checked the record) and disjoint from the
         * parts before it: its pixels go to their place now. Decoded pixels are
         * byte / 255, which quantise back to the same byte. */
        for (int y = 0; ok && y < img.height; y++) {
            /* Image rows count from the bottom, regions from the top. */
            int fy = fh - 1 - (p->y0 + (img.height - 1 - y));
            for (int x = 0; x < img.width; x++)
                image_put(&full, p->x0 + x, fy, image_get(&img, x, y));
        }
        image_free(&img);
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
    if (ok)
        ok = image_write(&full, out, diag);
    image_free(&full);
    free(parts);
    return ok;
}
