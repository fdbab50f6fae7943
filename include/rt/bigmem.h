/* Big arrays (meshes, primitive tables, grid cells, frame buffers) in transparent huge
 * pages where the system has them.
 *
 * Why: a fresh 4 KB page costs a page fault on first touch, and on the virtual machines
 * we measure on a fault costs 10-17 us; a 40k-triangle scene touches about 12 MB during
 * set-up, 3,000 faults, which was most of a process's start-up time. An allocation of
 * at least BIGMEM_MIN_BYTES is mapped on its own, aligned to 2 MB and marked for huge
 * pages (Linux MADV_HUGEPAGE), so it faults in 2 MB at a time. Smaller allocations, and
 * builds with AddressSanitizer (which cannot see inside a private mapping), use malloc:
 * below 512 KB a whole huge page is mostly waste, and blocks freed and allocated again
 * (the parts of -merge) are cheaper from malloc, which reuses its freed pages.
 * Middle sizes (BIGMEM_POOL_MIN_BYTES up to BIGMEM_MIN_BYTES) are carved from one shared
 * huge-page pool with a per-process budget (16 MB), used like a stack: the top block
 * grows and shrinks in place and, freed, is handed out again (cleared); a middle block
 * freed below the top is not reused, and once the budget is spent these sizes come from
 * malloc (bigmem.c says why).
 * A mapped block of at most BIGMEM_SPARE_MAX_BYTES freed is kept as a spare, up to
 * BIGMEM_SPARE_BYTES of them in all, and a later big allocation that fits one takes it
 * (its written bytes cleared) instead of a fresh mapping whose huge pages the kernel
 * must zero; a bigger block, or one beyond that budget, is unmapped at once (so a big
 * scene's set-up, whose large freed blocks nothing later fits, peaks no higher).
 *
 * Every pointer from bigmem_alloc/bigmem_resize must be released by bigmem_free (never
 * by free), and a malloc'd pointer never by bigmem_free. Data is 64-byte aligned. */
#ifndef RT_BIGMEM_H
#define RT_BIGMEM_H

#include <stdbool.h>
#include <stddef.h>

enum { BIGMEM_MIN_BYTES = 512 << 10, BIGMEM_POOL_MIN_BYTES = 16 << 10 };
#define BIGMEM_SPARE_BYTES ((size_t)64 << 20)
#define BIGMEM_SPARE_MAX_BYTES ((size_t)8 << 20)

/* size zeroed bytes (size 0 is allowed and gives a valid, unique pointer); NULL when out
 * of memory or when size is absurd (above SIZE_MAX / 2). */
void *bigmem_alloc(size_t size);
/* n * size zeroed bytes, NULL on overflow as well. */
void *bigmem_calloc(size_t n, size_t size);
/* Keeps the first min(old, new) bytes; bytes past the old size are unspecified. NULL
 * when out of memory, and p is then unchanged (still to be freed). p NULL: an alloc. */
void *bigmem_resize(void *p, size_t size);
/* How many bytes p's block holds without moving (bigmem_resize up to this size keeps p);
 * at least the size asked for. */
size_t bigmem_capacity(const void *p);
void bigmem_free(void *p);   /* NULL allowed */
/* For a process about to exit: from now on bigmem_free leaves a block's own mapping to
 * the kernel instead of unmapping it (malloc'd blocks are still freed, so leak checkers
 * see the same). Why: an munmap costs 0.1-0.3 ms on the virtual machines measured (the
 * other CPUs' TLBs are flushed by interrupt), a 1080p render's end frees a dozen such
 * mappings, and the exit tears the whole address space down at once anyway. */
void bigmem_leave_to_exit(void);

/* Faults in the pages of bytes [off, off + len) of block p (clipped to the block's size)
 * without changing them: for a thread with nothing else to do, so that the ones that
 * later write the block do not stop for its page faults (each page is read and written
 * back). The caller must be the only one using those bytes meanwhile. */
void bigmem_prefault(void *p, size_t off, size_t len);

/* True when p's memory is a mapping of its own; bigmem_maps_large: whether allocations
 * of BIGMEM_MIN_BYTES and more get one in this build (false under AddressSanitizer). */
bool bigmem_is_mapped(const void *p);
bool bigmem_maps_large(void);

#endif
