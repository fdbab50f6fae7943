/* Arena allocator: one per scene; freeing the scene frees everything it built. */
#ifndef RT_ARENA_H
#define RT_ARENA_H

#include <stddef.h>

typedef struct ArenaBlock ArenaBlock;

typedef struct Arena {
    ArenaBlock *head;
    size_t total;       /* bytes handed out */
} Arena;

void arena_init(Arena *a);
/* Zeroed memory aligned to 16 bytes; NULL when out of memory or size overflows. */
void *arena_alloc(Arena *a, size_t size);
/* n * size with overflow check. */
void *arena_calloc(Arena *a, size_t n, size_t size);
char *arena_strdup(Arena *a, const char *s);
void arena_free(Arena *a);

/* Large set-up buffers (arena blocks, OBJ text and arrays, grid build arrays). From
 * 256 KB up they are mapped on their own with transparent huge pages advised: a 4 KB
 * page fault costs about 2 us on the virtual machines we measure on, and one 2 MB
 * fault replaces 512 of them (a 40k-triangle mesh touches 5 MB). Below that, or where
 * mmap/madvise are missing, they come from calloc. big_alloc returns zeroed memory
 * aligned to 16 bytes, NULL when out of memory. big_realloc keeps the first
 * min(old, new) bytes (NULL: the old buffer is untouched). Free only with big_free
 * (NULL is allowed). */
void *big_alloc(size_t size);
void *big_realloc(void *p, size_t size);
void big_free(void *p);

#endif
