/* The set-up cache file (rt/setup_cache.h): open and check, look up, collect, write.
 *
 * Layout (native byte order: the header's marker rejects a file of another one):
 *   header      CacheHeader (128 bytes)
 *   sections    num_sections x CacheSection
 *   parts       each 64-byte aligned, in section order
 * body_sum is the hash of every byte after the header; head_sum the hash of the header
 * up to head_sum. */
#include "rt/setup_cache.h"
#include "rt/bigmem.h"
#include "rt/file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#ifndef RT_VERSION
#define RT_VERSION "unknown"
#endif

/* Bump when the layout of any cached array changes (here or in a section's user). */
#define CACHE_FORMAT 1u
#define CACHE_MAGIC "RTSETUP\n"
#define CACHE_ENDIAN 0x01020304u

typedef struct CacheHeader {
    char magic[8];
    uint32_t format, endian;
    uint32_t word_size, header_size;
    uint32_t section_size, num_sections;
    SetupKey build;          /* version, compiler layout and the executable's identity */
    uint64_t length;         /* of the whole file */
    SetupKey body_sum;
    uint8_t reserved[40];
    SetupKey head_sum;       /* of the bytes before it */
} CacheHeader;

typedef struct CacheSection {
    uint32_t tag, nparts;
    SetupKey key;
    uint64_t off[SETUP_CACHE_MAX_PARTS], len[SETUP_CACHE_MAX_PARTS];
} CacheSection;

typedef struct Pending {
    CacheSection sec;        /* off[] unused */
    unsigned char *data;     /* the parts back to back, malloc'd */
} Pending;

struct SetupCache {
    atomic_int refs;
    char *path;
    const unsigned char *map;    /* the valid file's bytes (bigmem), or NULL */
    size_t map_len;
    const CacheSection *sections;
    uint32_t num_sections;
    char rejected[160];
    bool replaceable;            /* the path is absent, empty or holds a cache of ours */
    bool missed;
    int hits;
    int tag_hits[4];             /* hits by tag (SETUP_TAG_*) */
    uint32_t used[64];           /* sections found (kept when the file is rewritten) */
    int num_used;
    bool add_failed;
    Pending *pending;
    int num_pending, cap_pending;
};

/* ---- hashing: four 64-bit lanes over 32-byte blocks, then a 128-bit finish ---- */

#define P1 0x9E3779B185EBCA87ull
#define P2 0xC2B2AE3D27D4EB4Full
#define P3 0x165667B19E3779F9ull

static inline uint64_t rotl(uint64_t x, int r) { return (x << r) | (x >> (64 - r)); }

static inline uint64_t load64(const unsigned char *p)
{
    uint64_t v;
    memcpy(&v, p, sizeof v);
    return v;
}

static inline uint64_t lane(uint64_t acc, uint64_t w) { return rotl(acc + w * P2, 31) * P1; }

static inline uint64_t fmix(uint64_t x)
{
    x ^= x >> 33;
    x *= 0xFF51AFD7ED558CCDull;
    x ^= x >> 33;
    x *= 0xC4CEB9FE1A85EC53ull;
    x ^= x >> 33;
    return x;
}

SetupKey setup_hash(const void *data, size_t len, SetupKey seed)
{
    const unsigned char *p = data;
    uint64_t l0 = seed.a + P1, l1 = seed.b + P2, l2 = seed.a ^ P3, l3 = seed.b - P1;
    size_t i = 0;
    for (; i + 32 <= len; i += 32) {
        l0 = lane(l0, load64(p + i));
        l1 = lane(l1, load64(p + i + 8));
        l2 = lane(l2, load64(p + i + 16));
        l3 = lane(l3, load64(p + i + 24));
    }
    unsigned char tail[32] = {0};
    if (i < len)
        memcpy(tail, p + i, len - i);
    l0 = lane(l0, load64(tail));
    l1 = lane(l1, load64(tail + 8));
    l2 = lane(l2, load64(tail + 16));
    l3 = lane(l3, load64(tail + 24) ^ (uint64_t)len);
    SetupKey k;
    k.a = fmix(rotl(l0, 1) + rotl(l1, 7) + rotl(l2, 12) + rotl(l3, 18));
    k.b = fmix((l0 ^ rotl(l2, 29)) * P3 + (l1 ^ rotl(l3, 41)) + k.a);
    return k;
}

SetupKey setup_hash_u64(SetupKey seed, uint64_t v) { return setup_hash(&v, sizeof v, seed); }

/* This build: its version, the layout of what it caches, and the executable file (a
 * rebuilt binary has another mtime or size; on systems without /proc, the version). */
static SetupKey build_key(void)
{
    static const char what[] = RT_VERSION " " __DATE__ " " __TIME__;
    SetupKey k = setup_hash(what, sizeof what, (SetupKey){CACHE_FORMAT, sizeof(void *)});
    struct stat st;
    if (stat("/proc/self/exe", &st) == 0) {
        uint64_t id[6] = {(uint64_t)st.st_dev, (uint64_t)st.st_ino, (uint64_t)st.st_size,
                          (uint64_t)st.st_mtim.tv_sec, (uint64_t)st.st_mtim.tv_nsec,
                          (uint64_t)st.st_ctim.tv_sec};
        k = setup_hash(id, sizeof id, k);
    }
    return k;
}

static bool key_eq(SetupKey x, SetupKey y) { return x.a == y.a && x.b == y.b; }

/* ---- open and check ---- */

static bool reject(SetupCache *c, const char *why)
{
    snprintf(c->rejected, sizeof c->rejected, "%s", why);
    return false;
}

/* Checks the mapped file; false (with the reason) when any check fails. */
static bool check(SetupCache *c, const unsigned char *m, size_t n)
{
    /* Only a file that starts as a cache does may be replaced: any other (the scene
     * named by mistake, an image, an OBJ file) is somebody's data. */
    if (n < sizeof(CacheHeader)) {
        size_t magic = sizeof CACHE_MAGIC - 1;
        c->replaceable = n >= magic && memcmp(m, CACHE_MAGIC, magic) == 0;
        return reject(c, c->replaceable ? "truncated (shorter than its header)"
                                        : "not a set-up cache");
    }
    CacheHeader h;
    memcpy(&h, m, sizeof h);
    if (memcmp(h.magic, CACHE_MAGIC, sizeof h.magic) != 0)
        return reject(c, "not a set-up cache");
    c->replaceable = true;
    SetupKey hs = setup_hash(m, offsetof(CacheHeader, head_sum), (SetupKey){0, 0});
    if (!key_eq(hs, h.head_sum))
        return reject(c, "damaged header");
    if (h.format != CACHE_FORMAT || h.endian != CACHE_ENDIAN ||
        h.word_size != sizeof(void *) || h.header_size != sizeof h ||
        h.section_size != sizeof(CacheSection))
        return reject(c, "written by another version or machine");
    if (!key_eq(h.build, build_key()))
        return reject(c, "written by another build of raytracer");
    if (h.length != n)
        return reject(c, "truncated or extended");
    if (h.num_sections > (n - sizeof h) / sizeof(CacheSection))
        return reject(c, "damaged section table");
    if (!key_eq(setup_hash(m + sizeof h, n - sizeof h, (SetupKey){0, 0}), h.body_sum))
        return reject(c, "checksum mismatch");
    const CacheSection *s = (const CacheSection *)(m + sizeof h);
    for (uint32_t i = 0; i < h.num_sections; i++) {
        if (s[i].nparts > SETUP_CACHE_MAX_PARTS)
            return reject(c, "damaged section table");
        for (uint32_t k = 0; k < s[i].nparts; k++)
            if (s[i].off[k] % 64 != 0 || s[i].off[k] > n || s[i].len[k] > n - s[i].off[k])
                return reject(c, "damaged section table");
    }
    c->sections = s;
    c->num_sections = h.num_sections;
    return true;
}

SetupCache *setup_cache_open(const char *path)
{
    SetupCache *c = calloc(1, sizeof *c);
    if (!c)
        return NULL;
    atomic_init(&c->refs, 1);
    c->path = strdup(path);
    if (!c->path) {
        free(c);
        return NULL;
    }
    /* O_NONBLOCK: a FIFO named as the cache is opened without waiting for a writer
     * (the run hung there for good, deaf to SIGTERM) and refused below as no regular
     * file; the open and reads of a regular file do not change. */
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) {
        if (errno != ENOENT)
            snprintf(c->rejected, sizeof c->rejected, "cannot be read: %s", strerror(errno));
        c->replaceable = errno == ENOENT;
        return c;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        reject(c, "not a regular file");
    } else if (st.st_size > 0 && (uint64_t)st.st_size < SIZE_MAX / 2) {
        /* Read into memory of our own rather than mapped: the file's pages would be
         * mapped one fault at a time (on the virtual machines we measure, 4 MB cost
         * 2.5-3 ms mapped and touched, 1.1 ms read into huge pages), and a copy cannot
         * change under us after the checks (another program writing the file in
         * place). */
        size_t n = (size_t)st.st_size;
        unsigned char *m = bigmem_alloc(n);
        size_t got = 0;
        while (m && got < n) {
            ssize_t r = read(fd, m + got, n - got);
            if (r < 0 && errno == EINTR)
                continue;
            if (r <= 0)
                break;
            got += (size_t)r;
        }
        if (!m) {
            reject(c, "too big for the memory left");
        } else if (got < n) {
            reject(c, "cannot be read whole (truncated while reading?)");
            bigmem_free(m);
        } else if (!check(c, m, n)) {
            bigmem_free(m);
        } else {
            c->map = m;
            c->map_len = n;
        }
    } else {
        c->replaceable = st.st_size == 0; /* an empty file holds nothing to lose */
        reject(c, "truncated (empty)");
    }
    close(fd);
    return c;
}

void setup_cache_retain(SetupCache *c)
{
    if (c)
        atomic_fetch_add(&c->refs, 1);
}

void setup_cache_release(SetupCache *c)
{
    if (!c || atomic_fetch_sub(&c->refs, 1) != 1)
        return;
    bigmem_free((void *)c->map);
    for (int i = 0; i < c->num_pending; i++)
        free(c->pending[i].data);
    free(c->pending);
    free(c->path);
    free(c);
}

const char *setup_cache_rejected(const SetupCache *c) { return c->rejected; }

int setup_cache_hits(const SetupCache *c) { return c->hits; }

int setup_cache_hits_of(const SetupCache *c, uint32_t tag)
{
    return tag < sizeof c->tag_hits / sizeof c->tag_hits[0] ? c->tag_hits[tag] : 0;
}

bool setup_cache_dirty(const SetupCache *c) { return (c->missed || c->num_pending) && !c->add_failed; }

bool setup_cache_find(SetupCache *c, uint32_t tag, SetupKey key, const void **part,
                      size_t *len, int *nparts)
{
    for (uint32_t i = 0; c->map && i < c->num_sections; i++) {
        const CacheSection *s = &c->sections[i];
        if (s->tag != tag || !key_eq(s->key, key))
            continue;
        for (uint32_t k = 0; k < s->nparts; k++) {
            part[k] = c->map + s->off[k];
            len[k] = (size_t)s->len[k];
        }
        *nparts = (int)s->nparts;
        c->hits++;
        if (tag < sizeof c->tag_hits / sizeof c->tag_hits[0])
            c->tag_hits[tag]++;
        bool seen = false;
        for (int u = 0; u < c->num_used; u++)
            seen = seen || c->used[u] == i;
        if (!seen && c->num_used < 64)
            c->used[c->num_used++] = i;
        return true;
    }
    c->missed = true;
    return false;
}

bool setup_cache_add(SetupCache *c, uint32_t tag, SetupKey key, const void *const *part,
                     const size_t *len, int nparts)
{
    if (nparts < 0 || nparts > SETUP_CACHE_MAX_PARTS)
        return false;
    if (c->num_pending == c->cap_pending) {
        int cap = c->cap_pending ? 2 * c->cap_pending : 4;
        Pending *p = realloc(c->pending, (size_t)cap * sizeof *p);
        if (!p) {
            c->add_failed = true;
            return false;
        }
        c->pending = p;
        c->cap_pending = cap;
    }
    Pending *p = &c->pending[c->num_pending];
    memset(p, 0, sizeof *p);
    p->sec.tag = tag;
    p->sec.key = key;
    p->sec.nparts = (uint32_t)nparts;
    size_t total = 0;
    for (int k = 0; k < nparts; k++) {
        p->sec.len[k] = len[k];
        total += len[k];
    }
    p->data = malloc(total ? total : 1);
    if (!p->data) {
        c->add_failed = true;
        return false;
    }
    size_t at = 0;
    for (int k = 0; k < nparts; k++) {
        if (len[k])
            memcpy(p->data + at, part[k], len[k]);
        at += len[k];
    }
    c->num_pending++;
    return true;
}

static size_t align64(size_t x) { return (x + 63) & ~(size_t)63; }

static bool write_all(int fd, const unsigned char *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return false;
        }
        p += w;
        n -= (size_t)w;
    }
    return true;
}

bool setup_cache_write(SetupCache *c, char *why, size_t why_len)
{
    if (!setup_cache_dirty(c))
        return true;
    /* The rename below would replace whatever the path names: a scene or an image given
     * as -cache by mistake, even a device node when run as root. */
    if (!c->replaceable) {
        bool plain = strcmp(c->rejected, "not a set-up cache") == 0;
        snprintf(why, why_len, "'%s' is not a set-up cache%s%s%s: left as it is", c->path,
                 plain ? "" : " (", plain ? "" : c->rejected, plain ? "" : ")");
        return false;
    }
    /* The sections this process used stay in the new file. */
    for (int u = 0; u < c->num_used; u++) {
        const CacheSection *s = &c->sections[c->used[u]];
        const void *part[SETUP_CACHE_MAX_PARTS];
        size_t len[SETUP_CACHE_MAX_PARTS];
        for (uint32_t k = 0; k < s->nparts; k++) {
            part[k] = c->map + s->off[k];
            len[k] = (size_t)s->len[k];
        }
        if (!setup_cache_add(c, s->tag, s->key, part, len, (int)s->nparts)) {
            snprintf(why, why_len, "out of memory");
            return false;
        }
    }
    c->num_used = 0;
    size_t n = sizeof(CacheHeader) + (size_t)c->num_pending * sizeof(CacheSection);
    for (int i = 0; i < c->num_pending; i++)
        for (uint32_t k = 0; k < c->pending[i].sec.nparts; k++)
            n = align64(n) + c->pending[i].sec.len[k];
    n = align64(n);
    unsigned char *buf = bigmem_alloc(n);
    if (!buf) {
        snprintf(why, why_len, "out of memory");
        return false;
    }
    CacheSection *sec = (CacheSection *)(buf + sizeof(CacheHeader));
    size_t at = sizeof(CacheHeader) + (size_t)c->num_pending * sizeof(CacheSection);
    for (int i = 0; i < c->num_pending; i++) {
        const Pending *p = &c->pending[i];
        sec[i] = p->sec;
        size_t from = 0;
        for (uint32_t k = 0; k < p->sec.nparts; k++) {
            at = align64(at);
            sec[i].off[k] = at;
            memcpy(buf + at, p->data + from, p->sec.len[k]);
            from += p->sec.len[k];
            at += p->sec.len[k];
        }
    }
    CacheHeader h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, CACHE_MAGIC, sizeof h.magic);
    h.format = CACHE_FORMAT;
    h.endian = CACHE_ENDIAN;
    h.word_size = sizeof(void *);
    h.header_size = sizeof h;
    h.section_size = sizeof(CacheSection);
    h.num_sections = (uint32_t)c->num_pending;
    h.build = build_key();
    h.length = n;
    h.body_sum = setup_hash(buf + sizeof h, n - sizeof h, (SetupKey){0, 0});
    memcpy(buf, &h, sizeof h);
    h.head_sum = setup_hash(buf, offsetof(CacheHeader, head_sum), (SetupKey){0, 0});
    memcpy(buf, &h, sizeof h);

    /* A private temporary name in the same folder, then rename: readers (and racing
     * writers of the same content) see one whole file or the other. Through a symbolic
     * link (existing target or dangling) both go to the link's target, as the image
     * outputs do: a rename onto the link replaced it with a regular file. */
    int lerr = 0;
    char *target = file_link_target(c->path, &lerr);
    if (!target) {
        snprintf(why, why_len, "cannot follow the link '%s': %s", c->path, strerror(lerr));
        bigmem_free(buf);
        return false;
    }
    size_t tl = strlen(target) + 64;
    char *tmp = malloc(tl);
    bool ok = false;
    if (tmp) {
        static atomic_uint serial;
        snprintf(tmp, tl, "%s.tmp.%ld.%u", target, (long)getpid(),
                 atomic_fetch_add(&serial, 1u));
        int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
        if (fd < 0) {
            snprintf(why, why_len, "cannot create '%s': %s", tmp, strerror(errno));
        } else {
            bool wrote = write_all(fd, buf, n);
            int err = errno;
            if (close(fd) != 0 && wrote) {
                wrote = false;
                err = errno;
            }
            if (!wrote)
                snprintf(why, why_len, "cannot write '%s': %s", tmp, strerror(err));
            else if (rename(tmp, target) != 0)
                snprintf(why, why_len, "cannot rename '%s' to '%s': %s", tmp, target,
                         strerror(errno));
            else
                ok = true;
            if (!ok)
                unlink(tmp);
        }
        free(tmp);
    } else {
        snprintf(why, why_len, "out of memory");
    }
    free(target);
    bigmem_free(buf);
    return ok;
}
