/* Arena allocator: big blocks carved linearly; the scene frees them all at once. */
#include "rt/arena.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

struct ArenaBlock {
    ArenaBlock *next;
    size_t size, used;
    /* data follows, 16-aligned */
};

enum { ARENA_ALIGN = 16, ARENA_MIN_BLOCK = 64 * 1024 };

static size_t header_size(void)
{
    return (sizeof(ArenaBlock) + ARENA_ALIGN - 1) & ~(size_t)(ARENA_ALIGN - 1);
}

void arena_init(Arena *a)
{
    a->head = NULL;
    a->total = 0;
}

void *arena_alloc(Arena *a, size_t size)
{
    if (size == 0)
        size = 1;
    if (size > SIZE_MAX / 2)
        return NULL;
    size = (size + ARENA_ALIGN - 1) & ~(size_t)(ARENA_ALIGN - 1);
    ArenaBlock *b = a->head;
    if (!b || b->size - b->used < size) {
        /* Blocks grow with the arena so a 1M-triangle mesh needs few mallocs. */
        size_t want = ARENA_MIN_BLOCK;
        if (a->total / 4 > want)
            want = a->total / 4;
        if (want < size)
            want = size;
        /* Zeroed blocks, no memset per allocation: blocks are never reused, so zeroed
         * once is zeroed for good, and big blocks come from mmap already zero (a
         * 40k-triangle mesh is one 4.8 MB block, not written twice). */
        b = big_alloc(header_size() + want);
        if (!b)
            return NULL;
        b->size = want;
        b->used = 0;
        b->next = a->head;
        a->head = b;
    }
    void *p = (char *)b + header_size() + b->used;
    b->used += size;
    a->total += size;
    return p;
}

void *arena_calloc(Arena *a, size_t n, size_t size)
{
    if (size && n > SIZE_MAX / size)
        return NULL;
    return arena_alloc(a, n * size);
}

char *arena_strdup(Arena *a, const char *s)
{
    size_t n = strlen(s) + 1;
    char *p = arena_alloc(a, n);
    if (p)
        memcpy(p, s, n);
    return p;
}

void arena_free(Arena *a)
{
    ArenaBlock *b = a->head;
    while (b) {
        ArenaBlock *n = b->next;
        big_free(b);
        b = n;
    }
    a->head = NULL;
    a->total = 0;
}

/* ---- big buffers ---- */

/* Every big buffer starts with this header (BIG_HEADER bytes, keeps 16-alignment). */
typedef struct BigHeader {
    void *base;       /* what to munmap or free */
    size_t map_len;   /* bytes mapped; 0: from calloc */
    size_t size;      /* bytes the caller asked for */
} BigHeader;

enum { BIG_HEADER = 64 };
#define BIG_MIN ((size_t)256 << 10)
#define BIG_HUGE ((size_t)2 << 20)

/* Under AddressSanitizer every buffer comes from calloc, so overruns stay detected. */
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RT_NO_BIG_MAP 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define RT_NO_BIG_MAP 1
#endif
#if defined(MAP_ANONYMOUS) && defined(MADV_HUGEPAGE) && !defined(RT_NO_BIG_MAP)
#define RT_BIG_MAP 1
#endif

static BigHeader *big_header(void *p) { return (BigHeader *)((char *)p - BIG_HEADER); }

void *big_alloc(size_t size)
{
    if (size > SIZE_MAX / 2)
        return NULL;
#ifdef RT_BIG_MAP
    if (size >= BIG_MIN) {
        /* A 2 MB-aligned run of whole 2 MB pages: map one page more, trim both ends. */
        size_t len = (size + BIG_HEADER + BIG_HUGE - 1) & ~(BIG_HUGE - 1);
        size_t map_len = len + BIG_HUGE;
        char *base = mmap(NULL, map_len, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS,
                          -1, 0);
        if (base != MAP_FAILED) {
            char *start = (char *)(((uintptr_t)base + BIG_HUGE - 1) & ~(uintptr_t)(BIG_HUGE - 1));
            size_t head = (size_t)(start - base), tail = map_len - head - len;
            if (head)
                munmap(base, head);
            if (tail)
                munmap(start + len, tail);
            (void)madvise(start, len, MADV_HUGEPAGE); /* advice: small pages if refused */
            BigHeader *h = (BigHeader *)start;
            h->base = start;
            h->map_len = len;
            h->size = size;
            return start + BIG_HEADER;
        }
    }
#endif
    char *p = calloc(1, size + BIG_HEADER);
    if (!p)
        return NULL;
    BigHeader *h = (BigHeader *)p;
    h->base = p;
    h->map_len = 0;
    h->size = size;
    return p + BIG_HEADER;
}

void *big_realloc(void *p, size_t size)
{
    if (!p)
        return big_alloc(size);
    BigHeader *h = big_header(p);
    if (h->map_len && size + BIG_HEADER <= h->map_len) {
        h->size = size; /* still fits the mapping */
        return p;
    }
    void *q = big_alloc(size);
    if (!q)
        return NULL;
    memcpy(q, p, h->size < size ? h->size : size);
    big_free(p);
    return q;
}

void big_free(void *p)
{
    if (!p)
        return;
    BigHeader *h = big_header(p);
#ifdef RT_BIG_MAP
    if (h->map_len) {
        munmap(h->base, h->map_len);
        return;
    }
#endif
    free(h->base);
}
