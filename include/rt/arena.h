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

#endif
