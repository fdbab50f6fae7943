/* Arena allocator: one per scene; freeing the scene frees everything it built. */
#ifndef RT_ARENA_H
#define RT_ARENA_H

#include <stdbool.h>
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

/* Buffers that may later become arena memory without their pages being touched twice:
 * the OBJ reader reads the file text into one, and the mesh's triangles are then built
 * in the same pages (faulting a fresh 4 KB page in costs 2 to 17 us on the virtual
 * machines we measure on, depending on what ran just before). From rt/bigmem.h; data 16-aligned; NULL when out of memory.
 * arena_buffer_resize keeps the first min(old, new) bytes (NULL: buf unchanged). */
void *arena_buffer_new(size_t size);
void *arena_buffer_resize(void *buf, size_t size);
void arena_buffer_free(void *buf);            /* NULL allowed */
/* Makes buf (from arena_buffer_new) size bytes of a's memory, freed with the arena from
 * now on, when its pages hold that many; else size fresh bytes of the arena are returned
 * (a move would copy bytes the caller overwrites anyway, into pages that are new all the
 * same) and buf is freed (rt/bigmem.h keeps a freed mapping of its size as a spare for
 * the next big array, so this is no munmap in the middle of the set-up).
 * *zeroed says which: true for fresh (zero) memory; false for buf's pages, whose old
 * contents the caller overwrites. NULL when out of memory (buf is then freed). */
void *arena_adopt_buffer(Arena *a, void *buf, size_t size, bool *zeroed);

#endif
