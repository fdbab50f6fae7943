/* Arena allocator: big blocks carved linearly; the scene frees them all at once. */
#include "rt/arena.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

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
        /* calloc, not malloc + memset per allocation: the blocks are never reused, so
         * zeroed once is zeroed for good, and big blocks come from mmap already zero
         * (a 40k-triangle mesh is one 4.8 MB block, not written twice). */
        b = calloc(1, header_size() + want);
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
        free(b);
        b = n;
    }
    a->head = NULL;
    a->total = 0;
}
