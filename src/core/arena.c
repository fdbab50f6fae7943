/* Arena allocator: big blocks carved linearly; the scene frees them all at once. */
#include "rt/arena.h"

#include "rt/bigmem.h"

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
        /* A request of a quarter of BIGMEM_MIN_BYTES or more (a mesh's child pointers)
         * gets a block big enough for a huge-page mapping: one 2 MB fault instead of 32
         * or more 4 KB ones, at 10-17 us each on the virtual machines we measure
         * (rt/bigmem.h); the rest of the block serves the allocations after it. */
        if (size >= BIGMEM_MIN_BYTES / 4 && want < BIGMEM_MIN_BYTES)
            want = BIGMEM_MIN_BYTES;
        /* Zeroed once when allocated, not per allocation: the blocks are never reused,
         * and big blocks are fresh huge-page mappings, already zero (rt/bigmem.h). */
        b = bigmem_alloc(header_size() + want);
        if (!b)
            return NULL;
        b->size = want;
        b->used = 0;
        /* The block with more room left serves what comes next: a big request (a mesh's
         * triangles) fills its block, and the small ones after it should not need a
         * new block (of a quarter of the arena: a huge page zeroed) while the old head
         * still has room. */
        if (a->head && want - size < a->head->size - a->head->used) {
            b->next = a->head->next;
            a->head->next = b;
        } else {
            b->next = a->head;
            a->head = b;
        }
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
        bigmem_free(b);
        b = n;
    }
    a->head = NULL;
    a->total = 0;
}

/* An arena buffer is an ArenaBlock in waiting: the header is reserved in front. */
static ArenaBlock *buffer_block(void *buf) { return (ArenaBlock *)((char *)buf - header_size()); }

void *arena_buffer_new(size_t size)
{
    if (size > SIZE_MAX / 2)
        return NULL;
    char *b = bigmem_alloc(header_size() + size);
    return b ? b + header_size() : NULL;
}

void *arena_buffer_resize(void *buf, size_t size)
{
    if (!buf)
        return arena_buffer_new(size);
    if (size > SIZE_MAX / 2)
        return NULL;
    char *b = bigmem_resize(buffer_block(buf), header_size() + size);
    return b ? b + header_size() : NULL;
}

void arena_buffer_free(void *buf)
{
    if (buf)
        bigmem_free(buffer_block(buf));
}

void *arena_adopt_buffer(Arena *a, void *buf, size_t size, bool *zeroed)
{
    if (size == 0)
        size = 1;
    *zeroed = false;
    if (buf && size <= SIZE_MAX / 2 && header_size() + size > bigmem_capacity(buffer_block(buf))) {
        *zeroed = true;
        void *fresh = arena_alloc(a, size);
        /* buf is freed now: bigmem keeps its mapping as a spare (no munmap), and the
         * next array of its size takes it instead of a fresh mapping whose huge page
         * the kernel must zero (line 07: the grid's primitive list, 2 MB pages 10 -> 9
         * at one thread). Kept with the arena, its page sat unused to the end. */
        arena_buffer_free(buf);
        return fresh;
    }
    char *data = arena_buffer_resize(buf, size);
    if (!data) {
        arena_buffer_free(buf);
        return NULL;
    }
    ArenaBlock *b = buffer_block(data);
    b->size = size;
    b->used = size;
    /* Behind the head: the head keeps serving small allocations from its free space. */
    if (a->head) {
        b->next = a->head->next;
        a->head->next = b;
    } else {
        b->next = NULL;
        a->head = b;
    }
    a->total += size;
    return data;
}
