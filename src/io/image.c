/* Image files by name: the codec follows the extension when writing and the file's
 * signature when reading (src/io/codec_table.c), and a write goes to a temporary file in
 * the target folder that is renamed into place, so a failed run leaves no file. */
#define _GNU_SOURCE /* fallocate (Linux); otherwise POSIX 2008 */
#include "rt/image.h"
#include "rt/bigmem.h"
#include "rt/file.h"
#include "codec.h"

#include <ctype.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- messages ------------------------------------------------------------------ */

static bool is_stdout(const char *path) { return strcmp(path, IMAGE_STDOUT) == 0; }

/* How messages name path: standard output by that name. */
static const char *shown(const char *path) { return is_stdout(path) ? "<stdout>" : path; }

static void report(Diag *diag, const char *path, const char *fmt_msg, const char *detail)
{
    if (!diag)
        return;
    SrcLoc loc = {shown(path), 0, 0};
    diag_error(diag, &loc, "%s%s", fmt_msg, detail ? detail : "");
}

/* The format's name as messages write it: "PNG". */
void codec_upper_name(const ImageCodec *codec, char *buf, size_t size)
{
    size_t i = 0;
    for (; codec->name[i] && i + 1 < size; i++)
        buf[i] = (char)toupper((unsigned char)codec->name[i]);
    buf[i] = '\0';
}

/* ---- writing ------------------------------------------------------------------- */

static bool write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return false;
        }
        if (w == 0) {
            errno = EIO;
            return false;
        }
        p += w;
        n -= (size_t)w;
    }
    return true;
}

/* Gives the file of fd its len bytes of disk now (best effort: a file system without
 * fallocate gets them as the bytes are written). Why: ext4 allocates written blocks
 * late, and renaming a file over an existing one makes it allocate and start writing
 * back all of the new file's blocks inside rename(2) (its "replace by rename" safety):
 * 3-5 ms for a 1080p TGA on the machines measured, on the calling thread after the
 * render. Blocks allocated beforehand leave rename nothing to allocate. */
static void preallocate(int fd, size_t len)
{
#if defined(__linux__)
    if (len > 0 && (off_t)len > 0)
        (void)fallocate(fd, 0, 0, (off_t)len);
#else
    (void)fd;
    (void)len;
#endif
}

/* The temporary files of the write in progress, for image_write_abort (called from a
 * signal handler): fixed storage, so the handler reads no heap and calls only unlink.
 * A slot's name is complete before `live` is set, and `live` is cleared before the
 * name changes. */
enum { TMP_NAME_MAX = 4096 + 32 };
static char g_tmp_name[IMAGE_MAX_OUTPUTS][TMP_NAME_MAX];
static volatile sig_atomic_t g_tmp_live[IMAGE_MAX_OUTPUTS];
/* 1 while temporary files are being written, 2 while they are renamed into place. */
static volatile sig_atomic_t g_write_phase;

bool image_write_abort(void)
{
    if (g_write_phase != 1)
        return false;
    for (int i = 0; i < IMAGE_MAX_OUTPUTS; i++)
        if (g_tmp_live[i])
            unlink(g_tmp_name[i]);
    return true;
}

/* Blocks the signals a user sends to stop a run (and restores them), so a temporary
 * file is never created unregistered nor a set of renames cut in half. */
static void block_stop_signals(sigset_t *old)
{
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGHUP);
    pthread_sigmask(SIG_BLOCK, &set, old);
}

static void restore_signals(const sigset_t *old) { pthread_sigmask(SIG_SETMASK, old, NULL); }

/* One output of image_write_all on its way to its file. */
typedef struct Pending {
    const char *path;       /* as the user gave it (messages); IMAGE_STDOUT */
    const char *format;     /* ImageOutput.format */
    char *target;           /* where the bytes go: path, or a symbolic link's target */
    bool direct;            /* an existing device or pipe: written in place */
    uint8_t *data;
    size_t len;
    bool borrowed;          /* data is the caller's (ImageOutput.encoded) */
    int slot;               /* its temporary file's slot, -1 while it has none */
    ImageEncoding *streamed; /* already in its temporary file (image_encoding_stream) */
} Pending;

/* A slot for a new temporary file: the first not in use (only the main thread makes
 * them), -1 when all are. */
static int free_slot(void)
{
    for (int i = 0; i < IMAGE_MAX_OUTPUTS; i++)
        if (!g_tmp_live[i])
            return i;
    return -1;
}

/* Creates the temporary file "<dir>/.<name>.XXXXXX" for target in slot (registered for
 * image_write_abort) with the permissions of the file it will replace, or those a plain
 * fopen would give; its descriptor, or -1 with errno set. */
static int make_temp(const char *target, int slot)
{
    size_t plen = strlen(target);
    const char *slash = strrchr(target, '/');
    size_t dirlen = slash ? (size_t)(slash - target) + 1 : 0;
    /* The temporary's own name is the target's and 8 bytes more: of a name near the
     * longest a folder takes (NAME_MAX, 255), only the start is kept, or a valid
     * -output name was refused after the whole render ("File name too long"). */
    size_t keep = plen - dirlen;
    if (keep > NAME_MAX - 8)
        keep = NAME_MAX - 8;
    if (dirlen + keep + 9 > TMP_NAME_MAX) {
        errno = ENAMETOOLONG;
        return -1;
    }
    char *tmp = g_tmp_name[slot];
    snprintf(tmp, TMP_NAME_MAX, "%.*s.%.*s.XXXXXX", (int)dirlen, target, (int)keep,
             target + dirlen);

    sigset_t old;
    block_stop_signals(&old);
    int fd = mkstemp(tmp);
    int e = errno;
    if (fd >= 0)
        g_tmp_live[slot] = 1;
    restore_signals(&old);
    if (fd < 0) {
        errno = e;
        return -1;
    }
    /* mkstemp creates the file 0600. A file it will replace keeps its permission bits
     * (a private 0600 image stays private, a 0444 one read-only: the rename must not
     * widen or change them); a new file gets what a plain fopen would give. Only the
     * rwx bits are carried over, never set-id or sticky bits. */
    mode_t mode;
    struct stat st;
    if (stat(target, &st) == 0 && S_ISREG(st.st_mode)) {
        mode = st.st_mode & 0777;
    } else {
        mode_t mask = umask(0);
        umask(mask);
        mode = 0666 & ~mask;
    }
    if (fchmod(fd, mode) != 0) {
        e = errno;
        close(fd);
        errno = e;
        return -2; /* made, so still to be removed */
    }
    return fd;
}

/* Removes slot's temporary file, if any. */
static void drop_temp(int slot)
{
    if (slot < 0 || !g_tmp_live[slot])
        return;
    sigset_t old;
    block_stop_signals(&old);
    unlink(g_tmp_name[slot]);
    g_tmp_live[slot] = 0;
    restore_signals(&old);
}

/* Writes p's bytes to "<dir>/.<name>.XXXXXX" in a free slot; rename(2) within one
 * folder is atomic, so readers (and a crash) later see either no file or the whole
 * file. A streamed output is already there: only its descriptor is closed (the error
 * of any of its writes is reported here). */
static bool stage(Pending *p, Diag *diag)
{
    if (p->streamed) {
        ImageEncoding *e = p->streamed;
        int err = atomic_load(&e->err);
        int fd = e->fd;
        e->fd = -1;
        if (close(fd) != 0 && !err)
            err = errno;
        if (err)
            report(diag, p->path, "cannot write image: ", strerror(err));
        return err == 0;
    }
    int slot = free_slot();
    if (slot < 0) {
        report(diag, p->path, "cannot write image: ", "too many outputs");
        return false;
    }
    int fd = make_temp(p->target, slot);
    if (fd < 0) {
        int e = errno;
        if (fd == -2)
            p->slot = slot;
        report(diag, p->path, "cannot write image: ", strerror(e));
        return false;
    }
    p->slot = slot;
    preallocate(fd, p->len);
    bool ok = write_all(fd, p->data, p->len);
    int e = errno;
    if (close(fd) != 0 && ok) {
        ok = false;
        e = errno;
    }
    if (!ok)
        report(diag, p->path, "cannot write image: ", strerror(e));
    return ok;
}

/* Writes straight into an existing non-regular file (a pipe, /dev/stdout, /dev/null):
 * renaming over it would replace the device node instead of writing to it. */
static bool write_direct(const Pending *p, Diag *diag)
{
    if (is_stdout(p->path)) {
        /* stdio may hold bytes of its own for standard output: they go first. */
        if (fflush(stdout) != 0 || !write_all(STDOUT_FILENO, p->data, p->len)) {
            report(diag, p->path, "cannot write image: ", strerror(errno));
            return false;
        }
        return true;
    }
    int fd = open(p->path, O_WRONLY | O_TRUNC);
    if (fd < 0) {
        report(diag, p->path, "cannot write image: ", strerror(errno));
        return false;
    }
    bool ok = write_all(fd, p->data, p->len);
    int e = errno;
    if (close(fd) != 0 && ok) {
        ok = false;
        e = errno;
    }
    if (!ok)
        report(diag, p->path, "cannot write image: ", strerror(e));
    return ok;
}

bool image_is_null_device(const char *path)
{
    struct stat st, null;
    return !is_stdout(path) && stat(path, &st) == 0 && S_ISCHR(st.st_mode) &&
           stat("/dev/null", &null) == 0 && S_ISCHR(null.st_mode) &&
           st.st_rdev == null.st_rdev;
}

/* The codec that writes path in format (NULL: by its extension; TGA for standard
 * output and for the null device when its name has no extension), or NULL with the
 * reason reported. */
static const ImageCodec *codec_for_writing(const char *path, const char *format, Diag *diag)
{
    const ImageCodec *codec = format ? image_codec_find(format)
                              : is_stdout(path) ? image_codec_find("tga")
                                                : image_codec_for_path(path);
    if (!codec && !format && image_is_null_device(path))
        codec = image_codec_find("tga");
    if (!codec) {
        if (diag) {
            char list[128];
            image_format_list(list, sizeof list);
            SrcLoc loc = {shown(path), 0, 0};
            if (format)
                diag_error(diag, &loc, "unknown image format '%s'", format);
            else
                diag_error(diag, &loc, "unknown image format (file name must end in one "
                           "of %s)", list);
        }
        return NULL;
    }
    if (format && !is_stdout(path) && image_codec_for_path(path) != codec) {
        if (diag) {
            SrcLoc loc = {path, 0, 0};
            diag_error(diag, &loc, "the file name does not end in the extension of the "
                       "format %s (%s)", codec->name, codec->extensions[0]);
        }
        return NULL;
    }
    if (!codec->encode) {
        if (diag) {
            char name[16], list[128];
            codec_upper_name(codec, name, sizeof name);
            image_format_list(list, sizeof list);
            SrcLoc loc = {shown(path), 0, 0};
            diag_error(diag, &loc, "%s output is not built in: %s, or write one of %s", name,
                       codec->missing, list);
        }
        return NULL;
    }
    return codec;
}

static bool check_target(const char *path, const char *target, bool exists,
                         const struct stat *st, const char *format, Diag *diag);

static bool g_stdout_forwarded;

void image_stdout_forwarded(bool forwarded) { g_stdout_forwarded = forwarded; }

bool image_check_output(const char *path, const char *format, Diag *diag)
{
    struct stat st;
    if (is_stdout(path)) {
        if (!codec_for_writing(path, format, diag))
            return false;
        if (fstat(STDOUT_FILENO, &st) != 0) {
            report(diag, path, "cannot write image: ", strerror(errno));
            return false;
        }
        if (!g_stdout_forwarded && isatty(STDOUT_FILENO)) {
            report(diag, path, "cannot write image: ", "standard output is a terminal "
                   "(pipe it into a program or redirect it into a file)");
            return false;
        }
        return true;
    }
    bool exists = stat(path, &st) == 0;
    /* stat follows links; the folder checks below concern where the file will be made:
     * beside a link's final target (file_link_target), not beside the link. */
    int e = 0;
    char *target = file_link_target(path, &e);
    if (!target) {
        report(diag, path, "cannot write image: ", strerror(e));
        return false;
    }
    bool ok = check_target(path, target, exists, &st, format, diag);
    free(target);
    return ok;
}

/* image_check_output for a file: target is where it will be made (file_link_target); st
 * path's stat when it exists. */
static bool check_target(const char *path, const char *target, bool exists,
                         const struct stat *st, const char *format, Diag *diag)
{
    if (exists && S_ISDIR(st->st_mode)) {
        report(diag, path, "cannot write image: ", "it is a folder");
        return false;
    }
    if (!codec_for_writing(path, format, diag))
        return false;
    if (exists) {
        /* A pipe or a device is written in place: it must take writes itself. */
        if (!S_ISREG(st->st_mode)) {
            if (access(path, W_OK) != 0) {
                report(diag, path, "cannot write image: ", strerror(errno));
                return false;
            }
            return true;
        }
    }
    /* A file (new or replaced) is made in its folder and renamed: the folder must exist
     * and take new files, and its name fit in a folder (else the write failed only
     * after the render). */
    const char *slash = strrchr(target, '/');
    if (strlen(slash ? slash + 1 : target) > NAME_MAX) {
        report(diag, path, "cannot write image: ", strerror(ENAMETOOLONG));
        return false;
    }
    char *dir = slash ? strndup(target, slash == target ? 1 : (size_t)(slash - target))
                      : strdup(".");
    if (!dir) {
        report(diag, path, "cannot write image: ", strerror(ENOMEM));
        return false;
    }
    bool ok = true;
    char why[64 + PATH_MAX];
    struct stat dst;
    if (stat(dir, &dst) != 0) {
        snprintf(why, sizeof why, "folder '%s': %s", dir, strerror(errno));
        ok = false;
    } else if (!S_ISDIR(dst.st_mode)) {
        snprintf(why, sizeof why, "'%s' is not a folder", dir);
        ok = false;
    } else if (access(dir, W_OK | X_OK) != 0) {
        snprintf(why, sizeof why, "folder '%s' is not writable: %s", dir, strerror(errno));
        ok = false;
    }
    if (!ok)
        report(diag, path, "cannot write image: ", why);
    free(dir);
    return ok;
}

/* Encodes img for path by its extension into p->data. */
static bool encode(const Image *img, const char *path, Pending *p, Diag *diag)
{
    bool ok = false;
    if (!img || (!img->pixels && !img->bytes) || img->width <= 0 || img->height <= 0) {
        report(diag, path, "cannot write image: ", "empty image");
        return false;
    }
    const ImageCodec *codec = codec_for_writing(path, p->format, diag);
    if (!codec)
        return false;
    ok = codec->encode(img, &p->data, &p->len);
    if (!ok)
        report(diag, path, "cannot write image: ", strerror(ENOMEM));
    return ok;
}

static bool plan(Pending *p, Diag *diag);

bool image_encoding_begin(ImageEncoding *e, const Image *img, const char *path,
                          const char *format)
{
    memset(e, 0, sizeof *e);
    if (!img || img->width <= 0 || img->height <= 0 || !path)
        return false;
    const ImageCodec *codec = codec_for_writing(path, format, NULL);
    if (!codec || !codec->layout)
        return false;
    if (!codec->layout(img, &e->data, &e->len, &e->top, &e->bgr)) {
        memset(e, 0, sizeof *e);
        return false;
    }
    e->width = img->width;
    e->height = img->height;
    e->fd = e->slot = -1;
    return true;
}

void image_encoding_row(const ImageEncoding *e, const Image *img, int y)
{
    if (!e->data || e->head_only || y < 0 || y >= e->height)
        return;
    size_t row = (size_t)e->width * 3;
    image_row_bytes(img, y, e->bgr, e->data + e->top + (size_t)(e->height - 1 - y) * row);
}

void image_encoding_free(ImageEncoding *e)
{
    if (e->data && e->fd >= 0)
        close(e->fd);
    if (e->data && e->slot >= 0)
        drop_temp(e->slot);
    bigmem_free(e->data);
    free(e->target);
    memset(e, 0, sizeof *e);
    e->fd = e->slot = -1;
}

/* pwrite of all n bytes at off. */
static bool pwrite_all(int fd, const uint8_t *p, size_t n, off_t off)
{
    while (n > 0) {
        ssize_t w = pwrite(fd, p, n, off);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return false;
        }
        if (w == 0) {
            errno = EIO;
            return false;
        }
        p += w;
        n -= (size_t)w;
        off += w;
    }
    return true;
}

/* Keeps a streamed file's first failed write (errno e; 0 counts as EIO) for
 * image_write_all's report. */
static void encoding_failed(ImageEncoding *e, int err)
{
    int expected = 0;
    atomic_compare_exchange_strong(&e->err, &expected, err ? err : EIO);
}

int image_encoding_error(const ImageEncoding *e)
{
    return e->data && e->fd >= 0 ? atomic_load(&e->err) : 0;
}

void image_report_write_error(const char *path, int err, Diag *diag)
{
    report(diag, path, "cannot write image: ", strerror(err ? err : EIO));
}

bool image_encoding_stream(ImageEncoding *e, const char *path)
{
    if (!e->data || e->fd >= 0 || !path)
        return false;
    Pending p;
    memset(&p, 0, sizeof p);
    p.path = path;
    if (!plan(&p, NULL) || p.direct) {
        free(p.target);
        return false;
    }
    int slot = free_slot();
    int fd = slot < 0 ? -1 : make_temp(p.target, slot);
    if (fd == -2)
        drop_temp(slot);
    if (fd >= 0)
        preallocate(fd, e->len);
    if (fd < 0 || !pwrite_all(fd, e->data, e->top, 0)) {
        if (fd >= 0) {
            close(fd);
            drop_temp(slot);
        }
        free(p.target);
        return false;
    }
    e->fd = fd;
    e->slot = slot;
    e->target = p.target;
    atomic_init(&e->err, 0);
    return true;
}

void image_encoding_flush(ImageEncoding *e, int y_lo, int y_hi)
{
    if (!e->data || e->head_only || e->fd < 0 || y_lo < 0 || y_hi >= e->height || y_lo > y_hi)
        return;
    size_t row = (size_t)e->width * 3;
    image_encoding_flush_rows(e, y_lo, y_hi,
                              e->data + e->top + (size_t)(e->height - 1 - y_hi) * row);
}

void image_encoding_flush_rows(ImageEncoding *e, int y_lo, int y_hi, const uint8_t *rows)
{
    if (!e->data || e->fd < 0 || y_lo < 0 || y_hi >= e->height || y_lo > y_hi)
        return;
    size_t row = (size_t)e->width * 3;
    size_t off = e->top + (size_t)(e->height - 1 - y_hi) * row;
    if (!pwrite_all(e->fd, rows, (size_t)(y_hi - y_lo + 1) * row, (off_t)off))
        encoding_failed(e, errno);
}

bool image_encoding_stream_only(ImageEncoding *e, const Image *img, const char *path,
                                const char *format)
{
    memset(e, 0, sizeof *e);
    e->fd = e->slot = -1;
    if (!img || img->width <= 0 || img->height <= 0 || !path)
        return false;
    const ImageCodec *codec = codec_for_writing(path, format, NULL);
    uint8_t head[IMAGE_HEAD_MAX];
    size_t top = 0, len = 0;
    bool bgr = false;
    if (!codec || !codec->head || !codec->head(img, head, &top, &len, &bgr))
        return false;
    e->data = bigmem_alloc(top);
    if (!e->data)
        return false;
    memcpy(e->data, head, top);
    e->len = len;
    e->top = top;
    e->bgr = bgr;
    e->width = img->width;
    e->height = img->height;
    e->head_only = true;
    if (!image_encoding_stream(e, path)) {
        image_encoding_free(e);
        return false;
    }
    return true;
}

bool image_encoding_stream_raw(ImageEncoding *e, const Image *img, const char *path)
{
    memset(e, 0, sizeof *e);
    e->fd = e->slot = -1;
    if (!img || img->width <= 0 || img->height <= 0 || !path)
        return false;
    /* No header yet (top 0): the file's bytes all come through image_encoding_append. */
    e->data = bigmem_alloc(0);
    if (!e->data)
        return false;
    e->width = img->width;
    e->height = img->height;
    e->head_only = true;
    if (!image_encoding_stream(e, path)) {
        image_encoding_free(e);
        return false;
    }
    return true;
}

void image_encoding_append(ImageEncoding *e, const uint8_t *p, size_t n)
{
    if (!e->data || e->fd < 0 || atomic_load(&e->err))
        return;
    if (!pwrite_all(e->fd, p, n, (off_t)e->appended))
        encoding_failed(e, errno);
    e->appended += n;
}

bool image_output_streams(const char *path, const char *format)
{
    if (!path || is_stdout(path))
        return false;
    const ImageCodec *codec = codec_for_writing(path, format, NULL);
    struct stat st;
    /* As plan(): an existing file that is not regular (a pipe, a device) is written in
     * place, after the render; a folder was refused before (image_check_output). */
    return codec && codec->head && (stat(path, &st) != 0 || S_ISREG(st.st_mode));
}

/* Rows of image_encoding_put's buffer: whole rows are written this many bytes at a time
 * at most (a strip of a 6000-wide image, 18 KB a row, in one or two writes). */
enum { PUT_BYTES = 256 << 10 };

void image_encoding_put(ImageEncoding *e, const Image *part, int x, int y)
{
    if (!e->data || e->fd < 0 || !part || x < 0 || y < 0 || part->width <= 0 ||
        part->height <= 0 || part->width > e->width - x || part->height > e->height - y)
        return;
    size_t row = (size_t)part->width * 3, file_row = (size_t)e->width * 3;
    /* Whole rows lie one after the other in the file (its top row first), so several go
     * in one write; a narrower part's rows are apart, one write each. */
    int batch = 1;
    if (part->width == e->width) {
        size_t fit = PUT_BYTES / row;
        batch = fit < 1 ? 1 : fit > (size_t)part->height ? part->height : (int)fit;
    }
    uint8_t *buf = malloc(row * (size_t)batch);
    if (!buf) {
        encoding_failed(e, ENOMEM);
        return;
    }
    for (int top = part->height - 1; top >= 0; top -= batch) {
        int n = top + 1 < batch ? top + 1 : batch;
        for (int k = 0; k < n; k++)
            image_row_bytes(part, top - k, e->bgr, buf + (size_t)k * row);
        size_t off = e->top + (size_t)(e->height - 1 - (y + top)) * file_row + (size_t)x * 3;
        if (!pwrite_all(e->fd, buf, (size_t)n * row, (off_t)off)) {
            encoding_failed(e, errno);
            break;
        }
    }
    free(buf);
}

/* Decides how the bytes reach path: in place for existing devices and pipes; through a
 * temporary file and rename otherwise, following a symbolic link to its target so the
 * link stays a link. */
static bool plan(Pending *p, Diag *diag)
{
    struct stat st;
    if (is_stdout(p->path) ||
        (stat(p->path, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode))) {
        p->direct = true;
        return true;
    }
    int e = 0;
    p->target = file_link_target(p->path, &e);
    if (!p->target) {
        report(diag, p->path, "cannot write image: ", strerror(e));
        return false;
    }
    return true;
}

/* Whether e holds the file of img (ImageOutput.encoded). */
static bool encoding_usable(const ImageEncoding *e, const Image *img)
{
    return e && e->data && img && e->width == img->width && e->height == img->height;
}

bool image_write_all(const ImageOutput *outs, int n, Diag *diag)
{
    if (n < 0 || n > IMAGE_MAX_OUTPUTS) {
        report(diag, n > 0 ? outs[0].path : "", "cannot write image: ", "too many outputs");
        return false;
    }
    Pending pend[IMAGE_MAX_OUTPUTS];
    memset(pend, 0, sizeof pend);
    bool ok = true;
    /* The streamed outputs' temporary files first: whatever fails below, they are
     * renamed or removed with the others. */
    for (int i = 0; i < n; i++) {
        pend[i].slot = -1;
        ImageEncoding *pre = outs[i].encoded;
        if (encoding_usable(pre, outs[i].image) && pre->fd >= 0 && pre->slot >= 0 &&
            g_tmp_live[pre->slot]) {
            pend[i].slot = pre->slot;
            pre->slot = -1; /* image_write_all's now */
        }
    }
    for (int i = 0; i < n && ok; i++) {
        pend[i].path = outs[i].path;
        pend[i].format = outs[i].format;
        ImageEncoding *pre = outs[i].encoded;
        /* A file held only as its header is of use only as the streamed file. */
        if (encoding_usable(pre, outs[i].image) && (!pre->head_only || pend[i].slot >= 0)) {
            pend[i].data = pre->data;
            pend[i].len = pre->len;
            pend[i].borrowed = true;
            if (pend[i].slot >= 0) {
                pend[i].streamed = pre;
                pend[i].target = strdup(pre->target);
                ok = pend[i].target != NULL;
                if (!ok)
                    report(diag, pend[i].path, "cannot write image: ", strerror(ENOMEM));
            } else {
                ok = plan(&pend[i], diag);
            }
        } else {
            ok = encode(outs[i].image, outs[i].path, &pend[i], diag) && plan(&pend[i], diag);
        }
    }
    /* 1. Every file-backed image into its temporary file; 2. the pipes and devices;
     * 3. only when all of that worked, the renames (with the stop signals held, so a
     * signal sees either every temporary file or none). */
    g_write_phase = 1;
    for (int i = 0; i < n && ok; i++)
        if (!pend[i].direct)
            ok = stage(&pend[i], diag);
    for (int i = 0; i < n && ok; i++)
        if (pend[i].direct)
            ok = write_direct(&pend[i], diag);
    sigset_t old;
    block_stop_signals(&old);
    g_write_phase = 2;
    for (int i = 0; i < n; i++) {
        int slot = pend[i].slot;
        if (slot < 0 || !g_tmp_live[slot])
            continue;
        if (ok && rename(g_tmp_name[slot], pend[i].target) != 0) {
            report(diag, pend[i].path, "cannot write image: ", strerror(errno));
            ok = false;
        }
        if (!ok)
            unlink(g_tmp_name[slot]);
        g_tmp_live[slot] = 0;
    }
    g_write_phase = 0;
    restore_signals(&old);
    for (int i = 0; i < n; i++) {
        if (!pend[i].borrowed)
            bigmem_free(pend[i].data);
        free(pend[i].target);
    }
    return ok;
}

bool image_write(const Image *img, const char *path, Diag *diag)
{
    ImageOutput one = {img, path, NULL, NULL};
    return image_write_all(&one, 1, diag);
}

/* ---- reading ------------------------------------------------------------------- */

/* The longest file image_read takes. A 32768 x 32768 image (the largest -size) is
 * 3 GiB of pixels as TGA or PPM and a little more as PNG (a filter byte a row, the
 * deflate blocks' headers); 64 MiB more covers those and the headers and part record.
 * A longer input (/dev/zero, a pipe that never ends) is refused instead of filling
 * the memory until the system kills the process
 * (IMAGE_READ_MAX_BYTES, src/io/codec.h) */

/* The file's first bytes, checked by their codec's header function when there is one:
 * false with the reason in why when they cannot begin an image it decodes; else *limit
 * is lowered to the longest file they can begin. */
bool codec_header_ok(const uint8_t *data, size_t len, size_t *limit, char *why,
                     size_t whylen)
{
    const ImageCodec *codec = image_codec_for_data(data, len);
    size_t max = SIZE_MAX;
    if (!codec->header || !codec->decode)
        return true;
    if (!codec->header(data, len, &max, why, whylen))
        return false;
    if (max < *limit)
        *limit = max;
    return true;
}

/* Reads a whole file (or standard input); on failure sets err (an errno value: EFBIG
 * past IMAGE_READ_MAX_BYTES), or leaves it 0 with the reason in why: the first bytes
 * are no header of a format it reads, or the file goes on past the length its header
 * declares. Those are checked as soon as the first 64 KiB are in, so an endless input
 * (-merge out.tga /dev/zero) is refused at once, not after 3 GiB. */
static bool read_file(const char *path, uint8_t **out, size_t *out_len, int *err, char *why,
                      size_t whylen)
{
    /* "-": standard input, through a duplicate so that fclose leaves it open. */
    int in = is_stdout(path) ? dup(STDIN_FILENO) : -1;
    FILE *f = in >= 0 ? fdopen(in, "rb") : fopen(path, "rb");
    if (!f) {
        *err = errno;
        if (in >= 0)
            close(in);
        return false;
    }
    struct stat st;
    bool regular = fstat(fileno(f), &st) == 0 && S_ISREG(st.st_mode);
    if (regular && (uintmax_t)st.st_size > IMAGE_READ_MAX_BYTES) {
        fclose(f);
        *err = EFBIG;
        return false;
    }
    size_t cap = IMAGE_HEAD_PEEK, len = 0, limit = IMAGE_READ_MAX_BYTES;
    bool checked = false, too_long = false;
    uint8_t *buf = malloc(cap);
    if (!buf) {
        fclose(f);
        *err = ENOMEM;
        return false;
    }
    for (;;) {
        if (len == cap) {
            /* Never more than the limit and one byte: that byte read means too long. */
            if ((too_long = cap > limit))
                break;
            size_t next = cap * 2 > limit + 1 ? limit + 1 : cap * 2;
            uint8_t *nb = realloc(buf, next);
            if (!nb) {
                free(buf);
                fclose(f);
                *err = ENOMEM;
                return false;
            }
            buf = nb;
            cap = next;
        }
        size_t n = fread(buf + len, 1, cap - len, f);
        len += n;
        if (n == 0) {
            if (ferror(f)) {
                *err = errno ? errno : EIO;
                free(buf);
                fclose(f);
                return false;
            }
            break;
        }
        /* The first 64 KiB are in and more may follow: the header decides how much
         * more can belong to the image (a shorter file is read whole and decoded). */
        if (!checked && len == cap) {
            checked = true;
            if (!codec_header_ok(buf, len, &limit, why, whylen)) {
                free(buf);
                fclose(f);
                *err = 0;
                return false;
            }
            /* A regular file's length is known: no need to read it to the limit. */
            if ((too_long = len > limit || (regular && (uintmax_t)st.st_size > limit)))
                break;
        }
    }
    fclose(f);
    if (too_long) {
        const ImageCodec *codec = image_codec_for_data(buf, len);
        char name[16];
        codec_upper_name(codec, name, sizeof name);
        free(buf);
        if (limit == IMAGE_READ_MAX_BYTES) {
            *err = EFBIG;
        } else {
            *err = 0;
            snprintf(why, whylen, "the file goes on past the %zu bytes its %s header "
                     "allows", limit, name);
        }
        return false;
    }
    *out = buf;
    *out_len = len;
    return true;
}

bool image_read(Image *img, const char *path, Diag *diag)
{
    uint8_t *data = NULL;
    size_t len = 0;
    int e = 0;
    char why[256] = "";
    bool ok;

    memset(img, 0, sizeof *img);   /* every field, so image_free is safe on failure */
    if (!read_file(path, &data, &len, &e, why, sizeof why)) {
        report(diag, is_stdout(path) ? "<stdin>" : path, "cannot read image: ",
               e ? strerror(e) : why);
        return false;
    }
    const ImageCodec *codec = image_codec_for_data(data, len);
    if (!codec->decode) {
        char name[16];
        codec_upper_name(codec, name, sizeof name);
        snprintf(why, sizeof why, "%s input is not built in: %s", name, codec->missing);
        ok = false;
    } else {
        ok = codec->decode(data, len, img, why, sizeof why);
    }
    free(data);
    if (!ok)
        report(diag, is_stdout(path) ? "<stdin>" : path, "cannot read image: ", why);
    return ok;
}
