/* SceneFiles: the files a scene load reads, kept in memory so that another process can
 * build the same scene without a shared file system (raytracer-mpi broadcasts them). */
#include "rt/scene.h"

#include <errno.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rt/file.h"

typedef struct SceneFile {
    char *name;         /* the path the loader tried, as it tried it */
    int error;          /* 0: read; else the errno of the failed read */
    char *data;         /* malloc'd, len bytes (+ NUL) */
    size_t len;
} SceneFile;

struct SceneFiles {
    bool record;
    int count, cap;
    SceneFile *files;
};

SceneFiles *scene_files_new(bool record)
{
    SceneFiles *f = calloc(1, sizeof *f);
    if (f)
        f->record = record;
    return f;
}

void scene_files_free(SceneFiles *f)
{
    if (!f)
        return;
    for (int i = 0; i < f->count; i++) {
        free(f->files[i].name);
        free(f->files[i].data);
    }
    free(f->files);
    free(f);
}

static const SceneFile *find(const SceneFiles *f, const char *name)
{
    for (int i = 0; i < f->count; i++)
        if (strcmp(f->files[i].name, name) == 0)
            return &f->files[i];
    return NULL;
}

/* Adds an entry taking over name and data; false when out of memory. */
static bool add(SceneFiles *f, char *name, int error, char *data, size_t len)
{
    if (f->count == f->cap) {
        int cap = f->cap ? f->cap * 2 : 8;
        SceneFile *nf = realloc(f->files, (size_t)cap * sizeof *nf);
        if (!nf)
            return false;
        f->files = nf;
        f->cap = cap;
    }
    f->files[f->count++] = (SceneFile){name, error, data, len};
    return true;
}

static char *copy_bytes(const char *src, size_t len, bool reusable)
{
    char *b = reusable ? arena_buffer_new(len + 1) : malloc(len + 1);
    if (!b)
        return NULL;
    memcpy(b, src, len);
    b[len] = '\0';
    return b;
}

bool scene_files_read(SceneFiles *f, const char *path, bool reusable, char **out, size_t *len)
{
    if (!f)
        return reusable ? file_read_reusable(path, out, len) : file_read_all(path, out, len);
    const SceneFile *e = find(f, path);
    if (!f->record || e) {
        /* Replay (or a file read twice): exactly what the recording process saw. */
        if (!e) {
            errno = ENOENT;
            return false;
        }
        if (e->error) {
            errno = e->error;
            return false;
        }
        *out = copy_bytes(e->data, e->len, reusable);
        *len = e->len;
        if (!*out)
            errno = ENOMEM;
        return *out != NULL;
    }
    bool ok = reusable ? file_read_reusable(path, out, len) : file_read_all(path, out, len);
    int error = ok ? 0 : errno;
    char *name = malloc(strlen(path) + 1);
    char *data = ok ? copy_bytes(*out, *len, false) : NULL;
    if (name)
        strcpy(name, path);
    if (!name || (ok && !data) || !add(f, name, error, data, ok ? *len : 0)) {
        free(name);
        free(data);
        if (ok) {
            if (reusable)
                arena_buffer_free(*out);
            else
                free(*out);
        }
        errno = ENOMEM;
        return false;
    }
    errno = error;
    return ok;
}

/* Packed layout: u64 count, then per file u64 name length, the name, i64 error, u64
 * data length, the data; integers in this machine's byte order (the ranks of one job
 * run the same binary). */
static void put_u64(uint8_t **p, uint64_t v)
{
    memcpy(*p, &v, sizeof v);
    *p += sizeof v;
}

bool scene_files_pack(const SceneFiles *f, uint8_t **out, size_t *out_len)
{
    size_t len = 8;
    for (int i = 0; i < f->count; i++)
        len += 24 + strlen(f->files[i].name) + f->files[i].len;
    uint8_t *b = malloc(len), *p = b;
    if (!b)
        return false;
    put_u64(&p, (uint64_t)f->count);
    for (int i = 0; i < f->count; i++) {
        const SceneFile *e = &f->files[i];
        size_t n = strlen(e->name);
        put_u64(&p, n);
        memcpy(p, e->name, n);
        p += n;
        put_u64(&p, (uint64_t)(int64_t)e->error);
        put_u64(&p, e->len);
        if (e->len)
            memcpy(p, e->data, e->len);
        p += e->len;
    }
    *out = b;
    *out_len = len;
    return true;
}

static bool get_u64(const uint8_t **p, const uint8_t *end, uint64_t *v)
{
    if ((size_t)(end - *p) < sizeof *v)
        return false;
    memcpy(v, *p, sizeof *v);
    *p += sizeof *v;
    return true;
}

SceneFiles *scene_files_unpack(const uint8_t *data, size_t len)
{
    SceneFiles *f = scene_files_new(false);
    if (!f)
        return NULL;
    const uint8_t *p = data, *end = data + len;
    uint64_t count;
    if (!get_u64(&p, end, &count) || count > len)
        goto bad;
    for (uint64_t i = 0; i < count; i++) {
        uint64_t n, error, dlen;
        if (!get_u64(&p, end, &n) || n > (uint64_t)(end - p))
            goto bad;
        char *name = malloc(n + 1);
        if (!name)
            goto bad;
        memcpy(name, p, n);
        name[n] = '\0';
        p += n;
        if (!get_u64(&p, end, &error) || !get_u64(&p, end, &dlen) ||
            dlen > (uint64_t)(end - p)) {
            free(name);
            goto bad;
        }
        char *d = copy_bytes((const char *)p, dlen, false);
        p += dlen;
        if (!d || !add(f, name, (int)(int64_t)error, d, dlen)) {
            free(name);
            free(d);
            goto bad;
        }
    }
    if (p == end)
        return f;
bad:
    scene_files_free(f);
    return NULL;
}
