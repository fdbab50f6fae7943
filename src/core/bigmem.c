/* Big arrays in their own 2 MB-aligned mappings, marked for transparent huge pages
 * (contract in rt/bigmem.h). */
#include "rt/bigmem.h"

#include <stdatomic.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

/* The header in front of the data of a malloc'd or pooled block (and of a mapping when
 * the table of mappings is full): one cache line, so the data stays 64-aligned. */
typedef struct BigmemHeader {
    size_t map_len;   /* length of the mapping that starts at the header (a mapping not in
                         the table, map_aligned); 0: malloc'd or pooled */
    size_t size;      /* bytes the caller asked for */
    size_t pooled;    /* 1: carved from the pool (reused only from its top: pool_alloc) */
    unsigned char pad[64 - 3 * sizeof(size_t)];
} BigmemHeader;

enum { HEADER = sizeof(BigmemHeader), HUGE_PAGE = 2 << 20 };

/* The pool for middle sizes (BIGMEM_POOL_MIN_BYTES up to BIGMEM_MIN_BYTES): one 2 MB-
 * aligned mapping with huge-page advice, handed out front to back by an atomic bump.
 * Why: a 40k-triangle scene's set-up makes a dozen arrays of 16-500 KB (the OBJ reader's
 * growing vertex and face arrays, per-cell counts and starts, binning scratch), each
 * malloc'd, zeroed by memset and so faulted in 4 KB at a time: ~550 faults, 6 ms of the
 * 30 ms set-up on this VM. From the pool they share a few huge pages and need no memset
 * where the pool was never handed out before. The pool is a budget of POOL_BYTES per
 * process, after which these sizes come from malloc again as before. A block is reused
 * only from the pool's top, like a stack: the top block grows and shrinks in place
 * (bigmem_resize), and freeing it gives its bytes back to the next allocation, which
 * clears what of them was handed out before (g_pool_dirty). Why: the OBJ reader's
 * arrays grow by doubling, one at a time, and the binning's scratch is freed right
 * after it is made; without reuse those steps took 1.5 MB of the 40k bunny's 3.2 MB of
 * pool, so two huge pages were zeroed by the kernel where one now is. Blocks freed
 * below the top stay taken. */
enum { POOL_BYTES = 16 << 20 };

static _Atomic(uintptr_t) g_pool_base;   /* 0: not made yet; 1: failed or in the making */
static atomic_size_t g_pool_used;        /* the bump: the top's offset */
static atomic_size_t g_pool_dirty;       /* bytes from the base handed out at some time */

/* Raises g_pool_dirty to end; the value before. */
static size_t pool_dirty_raise(size_t end)
{
    size_t old = atomic_load(&g_pool_dirty);
    while (old < end && !atomic_compare_exchange_weak(&g_pool_dirty, &old, end))
        ;
    return old;
}

/* A pooled block's length in the pool, header included. */
static size_t pool_len(size_t size) { return (HEADER + size + 63) & ~(size_t)63; }

#if defined(__SANITIZE_ADDRESS__)
#define BIGMEM_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define BIGMEM_SANITIZED 1
#endif
#endif

static BigmemHeader *header_of(const void *p)
{
    return (BigmemHeader *)((char *)(uintptr_t)p - HEADER);
}

bool bigmem_maps_large(void)
{
#ifdef BIGMEM_SANITIZED
    return false;   /* AddressSanitizer checks malloc'd memory, not our mappings */
#else
    return true;
#endif
}

static bool want_mapping(size_t size) { return bigmem_maps_large() && size >= BIGMEM_MIN_BYTES; }

/* The mappings whose data starts on their first byte, header-less: their lengths and
 * sizes are kept here instead. Why: a header written in front of the data faulted the
 * mapping's first 2 MB page in (zeroing it: 0.1-0.2 ms on the virtual machines
 * measured) on the allocating thread, at once; a 1080p render's set-up makes about ten
 * such blocks on its main thread, most of them filled later by several threads
 * (grid_pack's arrays, the frame buffer and its file), which now fault their pages in
 * where they write them, in parallel. (A header in a 4 KB page of its own below the
 * data was tried: that page's fault, the first of its page table, cost 0.1 ms too.)
 * A slot is taken under a spin lock; when all are taken, a block carries its header in
 * front of its data as before (map_aligned). */
enum { MAP_SLOTS = 256 };
static struct {
    void *data;       /* NULL: free slot */
    size_t map_len;   /* the mapping's length, starting at data */
    size_t size;      /* bytes the caller asked for */
    size_t dirty;     /* bytes from data on that may have been written (spares below) */
} g_maps[MAP_SLOTS];
static atomic_flag g_maps_lock = ATOMIC_FLAG_INIT;

/* Spare mappings: table mappings freed during the run, kept (pages and all) for the
 * next allocation they fit instead of unmapped. Why: a fresh 2 MB page is zeroed by the
 * kernel on its first touch, and on this project's virtual machines that cost 5-48% of
 * course line 07's run (perf: clear_page_erms; the host backs the page then too), while
 * set-up frees mappings that a later step could use: the OBJ reader's face array
 * (freed once the mesh is built) before the primitive table, the binning's pairs before
 * the packed grid. A spare is handed out with only its written front (dirty) cleared,
 * by memset, in memory the process has touched already. At most SPARE_SLOTS spares and
 * SPARE_BYTES in all (a process keeps no more than that resident for reuse), each of
 * at most BIGMEM_SPARE_MAX_BYTES: a bigger freed mapping (the 1.3M-triangle blob's read
 * text and face arrays, which nothing later fits) or one beyond the budget is unmapped
 * as before; kept, those raised the blob's peak memory by 15-29 MB for no reuse.
 * Under maps_lock. */
enum { SPARE_SLOTS = 8 };
#define SPARE_BYTES BIGMEM_SPARE_BYTES
static struct {
    void *data;       /* NULL: free slot */
    size_t map_len, dirty;
} g_spare[SPARE_SLOTS];
static size_t g_spare_bytes;   /* sum of the spares' map_len */

static void maps_lock(void)
{
    while (atomic_flag_test_and_set_explicit(&g_maps_lock, memory_order_acquire))
        ;
}

static void maps_unlock(void) { atomic_flag_clear_explicit(&g_maps_lock, memory_order_release); }

/* p's slot, or -1 (under the lock). Only 2 MB-aligned pointers can be in the table. */
static int map_slot(const void *p)
{
    if ((uintptr_t)p & (uintptr_t)(HUGE_PAGE - 1))
        return -1;
    for (int i = 0; i < MAP_SLOTS; i++)
        if (g_maps[i].data == p)
            return i;
    return -1;
}

/* p's mapping length and size when it is in the table (false otherwise). */
static bool map_lookup(const void *p, size_t *map_len, size_t *size)
{
    if ((uintptr_t)p & (uintptr_t)(HUGE_PAGE - 1))
        return false;
    maps_lock();
    int i = map_slot(p);
    if (i >= 0) {
        *map_len = g_maps[i].map_len;
        *size = g_maps[i].size;
    }
    maps_unlock();
    return i >= 0;
}

/* A zeroed mapping for size bytes starting on a 2 MB boundary, so the kernel can back
 * all of it with huge pages: its data starts at that boundary and its length and size
 * go into the table; when the table is full, the header goes in front of the data (the
 * mapping's first 64 bytes) as it did before the table. */
static void *map_aligned(size_t size)
{
    size_t data_len = (size + HUGE_PAGE - 1) & ~(size_t)(HUGE_PAGE - 1);
    size_t head_len = (HEADER + size + HUGE_PAGE - 1) & ~(size_t)(HUGE_PAGE - 1);
    if (data_len < size || head_len < size || head_len > SIZE_MAX - HUGE_PAGE)
        return NULL;
    /* A slot first: its length decides the mapping's. */
    maps_lock();
    int slot = -1;
    for (int i = 0; i < MAP_SLOTS && slot < 0; i++)
        if (!g_maps[i].data) {
            slot = i;
            g_maps[i].data = (void *)(uintptr_t)1; /* taken, filled below */
        }
    /* With a slot, the smallest spare that holds data_len, and not more than twice it
     * (a big spare waits for a big block). */
    int spare = -1;
    for (int i = 0; i < SPARE_SLOTS && slot >= 0; i++)
        if (g_spare[i].data && g_spare[i].map_len >= data_len &&
            g_spare[i].map_len / 2 <= data_len &&
            (spare < 0 || g_spare[i].map_len < g_spare[spare].map_len))
            spare = i;
    if (spare >= 0) {
        char *data = g_spare[spare].data;
        size_t dirty = g_spare[spare].dirty;
        g_maps[slot].data = data;
        g_maps[slot].map_len = g_spare[spare].map_len;
        g_maps[slot].size = size;
        g_maps[slot].dirty = dirty > size ? dirty : size;
        g_spare_bytes -= g_spare[spare].map_len;
        g_spare[spare].data = NULL;
        maps_unlock();
        memset(data, 0, dirty < size ? dirty : size);
        return data;
    }
    maps_unlock();
    size_t len = slot >= 0 ? data_len : head_len;
    char *raw = mmap(NULL, len + HUGE_PAGE, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (raw == MAP_FAILED) {
        if (slot >= 0) {
            maps_lock();
            g_maps[slot].data = NULL;
            maps_unlock();
        }
        return NULL;
    }
    char *base = (char *)(((uintptr_t)raw + HUGE_PAGE - 1) & ~(uintptr_t)(HUGE_PAGE - 1));
    if (base > raw)
        munmap(raw, (size_t)(base - raw));
    if (raw + len + HUGE_PAGE > base + len)
        munmap(base + len, (size_t)(raw + len + HUGE_PAGE - (base + len)));
#ifdef MADV_HUGEPAGE
    (void)madvise(base, len, MADV_HUGEPAGE);   /* a hint: without it, 4 KB pages */
#endif
    if (slot >= 0) {
        maps_lock();
        g_maps[slot].data = base;
        g_maps[slot].map_len = len;
        g_maps[slot].size = size;
        g_maps[slot].dirty = size;
        maps_unlock();
        return base;
    }
    BigmemHeader *h = (BigmemHeader *)(void *)base;
    h->map_len = len;
    h->size = size;
    return base + HEADER;
}

/* The pool's base, made on first use; 0 when it cannot be had. Two threads racing to make
 * it: one maps, the other goes to malloc this time. */
static char *pool_base(void)
{
    uintptr_t b = atomic_load_explicit(&g_pool_base, memory_order_acquire);
    if (b > 1)
        return (char *)b;
    uintptr_t none = 0;
    if (b == 1 || !atomic_compare_exchange_strong(&g_pool_base, &none, (uintptr_t)1))
        return NULL;
    char *raw = mmap(NULL, POOL_BYTES + HUGE_PAGE, PROT_READ | PROT_WRITE,
                     MAP_PRIVATE | MAP_ANONYMOUS | MAP_NORESERVE, -1, 0);
    if (raw == MAP_FAILED)
        return NULL;   /* stays 1: malloc from now on */
    char *base = (char *)(((uintptr_t)raw + HUGE_PAGE - 1) & ~(uintptr_t)(HUGE_PAGE - 1));
    if (base > raw)
        munmap(raw, (size_t)(base - raw));
    if (raw + POOL_BYTES + HUGE_PAGE > base + POOL_BYTES)
        munmap(base + POOL_BYTES, (size_t)(raw + POOL_BYTES + HUGE_PAGE - (base + POOL_BYTES)));
#ifdef MADV_HUGEPAGE
    (void)madvise(base, POOL_BYTES, MADV_HUGEPAGE);
#endif
    atomic_store_explicit(&g_pool_base, (uintptr_t)base, memory_order_release);
    return base;
}

/* A zeroed block from the pool, or NULL when the pool is spent (or cannot be made). */
static void *pool_alloc(size_t size)
{
    char *base = pool_base();
    if (!base)
        return NULL;
    size_t len = pool_len(size);
    size_t at = atomic_fetch_add(&g_pool_used, len);
    if (at > POOL_BYTES || len > POOL_BYTES - at)
        return NULL;   /* the budget is spent; the top is past it now, so it stays so */
    /* Bytes below the old mark were another block's (freed from the top): cleared. The
     * mark was raised by that block's allocation, before its free gave the bytes back
     * (sequentially consistent atomics), so it is seen here. */
    size_t dirty = pool_dirty_raise(at + len);
    if (dirty > at)
        memset(base + at, 0, (dirty < at + len ? dirty : at + len) - at);
    BigmemHeader *h = (BigmemHeader *)(void *)(base + at);
    h->map_len = 0;
    h->size = size;
    h->pooled = 1;
    return (char *)h + HEADER;
}

void *bigmem_alloc(size_t size)
{
    if (size > SIZE_MAX / 2)
        return NULL;
    if (want_mapping(size))
        return map_aligned(size);
    if (bigmem_maps_large() && size >= BIGMEM_POOL_MIN_BYTES) {
        void *p = pool_alloc(size);
        if (p)
            return p;
    }
    size_t len = (HEADER + size + 63) & ~(size_t)63;   /* aligned_alloc wants a multiple */
    BigmemHeader *h = aligned_alloc(64, len);
    if (!h)
        return NULL;
    memset(h, 0, len);
    h->map_len = 0;
    h->size = size;
    h->pooled = 0;
    return (char *)h + HEADER;
}

void *bigmem_calloc(size_t n, size_t size)
{
    if (size && n > SIZE_MAX / size)
        return NULL;
    return bigmem_alloc(n * size);
}

void *bigmem_resize(void *p, size_t size)
{
    if (!p)
        return bigmem_alloc(size);
    if (size > SIZE_MAX / 2)
        return NULL;
    size_t map_len, old_size;
    if (map_lookup(p, &map_len, &old_size)) {
        /* Growing inside the mapping's slack (up to the next 2 MB) costs nothing. */
        if (size <= map_len) {
            /* At least one step: a size of 0 must not unmap the whole block while its
             * slot still names it (a later mapping could be placed there). */
            size_t keep = size ? (size + HUGE_PAGE - 1) & ~(size_t)(HUGE_PAGE - 1) : HUGE_PAGE;
            maps_lock();
            int i = map_slot(p);
            if (keep < map_len) {   /* shrinking: give whole 2 MB steps back */
                munmap((char *)p + keep, map_len - keep);
                g_maps[i].map_len = keep;
                if (g_maps[i].dirty > keep)
                    g_maps[i].dirty = keep;
            }
            g_maps[i].size = size;
            if (g_maps[i].dirty < size)
                g_maps[i].dirty = size;
            maps_unlock();
            return p;
        }
        void *q = bigmem_alloc(size);
        if (!q)
            return NULL;
        memcpy(q, p, old_size < size ? old_size : size);
        bigmem_free(p);
        return q;
    }
    BigmemHeader *h = header_of(p);
    if (h->map_len) {
        /* Growing inside the mapping's slack (up to the next 2 MB) costs nothing. */
        if (HEADER + size <= h->map_len) {
            size_t keep = (HEADER + size + HUGE_PAGE - 1) & ~(size_t)(HUGE_PAGE - 1);
            if (keep < h->map_len) {   /* shrinking: give whole 2 MB steps back */
                munmap((char *)h + keep, h->map_len - keep);
                h->map_len = keep;
            }
            h->size = size;
            return p;
        }
    }
    /* The pool's top block, staying a pool size: in place, when no block was carved
     * after it meanwhile (bytes past the old size unspecified, as the contract says). */
    if (h->pooled && !want_mapping(size)) {
        char *base = (char *)atomic_load(&g_pool_base);
        size_t off = (size_t)((char *)h - base), end = off + pool_len(h->size);
        if (pool_len(size) <= POOL_BYTES - off &&
            atomic_compare_exchange_strong(&g_pool_used, &end, off + pool_len(size))) {
            pool_dirty_raise(off + pool_len(size));
            h->size = size;
            return p;
        }
    }
    /* Elsewhere: a fresh block and a copy (realloc would not keep the 64-alignment). */
    void *q = bigmem_alloc(size);
    if (!q)
        return NULL;
    memcpy(q, p, h->size < size ? h->size : size);
    bigmem_free(p);
    return q;
}

/* Set once by bigmem_leave_to_exit; read by any thread that frees. */
static atomic_bool g_leave_to_exit;

void bigmem_leave_to_exit(void)
{
    atomic_store_explicit(&g_leave_to_exit, true, memory_order_relaxed);
}

void bigmem_free(void *p)
{
    if (!p)
        return;
    if (!((uintptr_t)p & (uintptr_t)(HUGE_PAGE - 1))) {
        bool leave = atomic_load_explicit(&g_leave_to_exit, memory_order_relaxed);
        maps_lock();
        int i = map_slot(p);
        size_t len = i >= 0 ? g_maps[i].map_len : 0;
        bool kept = false;
        if (i >= 0) {
            /* A spare for the allocations to come (g_spare), when there is room. */
            for (int k = 0; k < SPARE_SLOTS && !leave && !kept; k++)
                if (!g_spare[k].data && len <= BIGMEM_SPARE_MAX_BYTES &&
                    len <= SPARE_BYTES - g_spare_bytes) {
                    g_spare[k].data = p;
                    g_spare[k].map_len = len;
                    g_spare[k].dirty = g_maps[i].dirty;
                    g_spare_bytes += len;
                    kept = true;
                }
            g_maps[i].data = NULL;
        }
        maps_unlock();
        if (i >= 0) {
            if (!leave && !kept)
                munmap(p, len);
            return;
        }
    }
    BigmemHeader *h = header_of(p);
    if (h->map_len) {
        if (!atomic_load_explicit(&g_leave_to_exit, memory_order_relaxed))
            munmap(h, h->map_len);
    }
    else if (!h->pooled)
        free(h);
    else {
        /* The pool's top block gives its bytes back (a block carved after it, or the
         * budget spent, makes the exchange fail: the bytes stay taken). */
        char *base = (char *)atomic_load(&g_pool_base);
        size_t off = (size_t)((char *)h - base), end = off + pool_len(h->size);
        atomic_compare_exchange_strong(&g_pool_used, &end, off);
    }
}

size_t bigmem_capacity(const void *p)
{
    size_t map_len, size;
    if (map_lookup(p, &map_len, &size))
        return map_len;
    const BigmemHeader *h = header_of(p);
    return h->map_len ? h->map_len - HEADER : h->size;
}

bool bigmem_is_mapped(const void *p)
{
    size_t map_len, size;
    return p && (map_lookup(p, &map_len, &size) || header_of(p)->map_len != 0);
}

void bigmem_prefault(void *p, size_t off, size_t len)
{
    if (!p)
        return;
    size_t map_len, size;
    if (!map_lookup(p, &map_len, &size))
        size = header_of(p)->size;
    if (off >= size || len == 0) /* nothing to do (and no a[len - 1] below) */
        return;
    if (len > size - off)
        len = size - off;
    /* A write per 4 KB (at most the page size: every page is reached), not
     * MADV_POPULATE_WRITE: that holds the address space's lock for the whole range,
     * and another thread's mmap or munmap meanwhile waited for it (2 ms when this
     * thread lost its CPU under load), while a fault locks only its own mapping. */
    volatile char *a = (char *)p + off;
    for (size_t i = 0; i < len; i += 4096)
        a[i] = a[i];
    a[len - 1] = a[len - 1];
}
