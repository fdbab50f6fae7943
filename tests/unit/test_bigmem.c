/* Unit tests of rt/bigmem.h: zeroed, aligned memory on every path (malloc below
 * BIGMEM_POOL_MIN_BYTES, the shared pool up to BIGMEM_MIN_BYTES, a 2 MB-aligned mapping
 * with huge-page advice above), resizes that keep the contents across the paths, and
 * refused absurd sizes. */
#include "harness.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "rt/bigmem.h"

static bool all_zero(const unsigned char *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (p[i])
            return false;
    return true;
}

static void fill(unsigned char *p, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; i++)
        p[i] = (unsigned char)(i * 31u + seed);
}

static bool filled(const unsigned char *p, size_t n, unsigned seed)
{
    for (size_t i = 0; i < n; i++)
        if (p[i] != (unsigned char)(i * 31u + seed))
            return false;
    return true;
}

/* Whether the page at p is mapped (mincore fails with ENOMEM on unmapped memory). */
static bool page_mapped(const void *p)
{
    long ps = sysconf(_SC_PAGESIZE);
    uintptr_t a = (uintptr_t)p & ~(uintptr_t)(ps - 1);
    unsigned char v;
    return mincore((void *)a, (size_t)ps, &v) == 0 || errno != ENOMEM;
}

static void test_alloc_sizes(void)
{
    const size_t sizes[] = {0, 1, 100, 4096, BIGMEM_MIN_BYTES - 1, BIGMEM_MIN_BYTES,
                            BIGMEM_MIN_BYTES + 1, (2u << 20) - 64, 2u << 20, 5u << 20};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        size_t n = sizes[k];
        unsigned char *p = bigmem_alloc(n);
        CHECK_MSG(p != NULL, "size %zu", n);
        if (!p)
            continue;
        CHECK_MSG((uintptr_t)p % 64 == 0, "size %zu not 64-aligned", n);
        CHECK_MSG(all_zero(p, n), "size %zu not zeroed", n);
        bool big = n >= BIGMEM_MIN_BYTES && bigmem_maps_large();
        CHECK_MSG(bigmem_is_mapped(p) == big, "size %zu mapped %d", n, bigmem_is_mapped(p));
        if (big) /* the data starts on a 2 MB boundary (no header in front of it) */
            CHECK_MSG((uintptr_t)p % (2u << 20) == 0, "size %zu not on 2 MB", n);
        fill(p, n, 7);
        CHECK(filled(p, n, 7));
        bigmem_free(p);
    }
    bigmem_free(NULL);
    unsigned char *a = bigmem_calloc(1000, 1000);
    CHECK(a && all_zero(a, 1000000));
    bigmem_free(a);
}

static void test_resize_keeps_contents(void)
{
    /* Across the paths and back: small -> small -> mapped -> inside the slack -> beyond
     * it -> shrunk -> small. */
    const size_t steps[] = {100, 5000, BIGMEM_MIN_BYTES + 10, (2u << 20) - 100,
                            (3u << 20) + 7, 6u << 20, (2u << 20) + 1, 300, 0};
    size_t have = 0;
    unsigned char *p = NULL;
    for (size_t k = 0; k < sizeof steps / sizeof steps[0]; k++) {
        size_t n = steps[k];
        unsigned char *q = bigmem_resize(p, n);
        CHECK_MSG(q != NULL, "resize to %zu", n);
        if (!q)
            break;
        size_t keep = have < n ? have : n;
        CHECK_MSG(filled(q, keep, 3), "resize %zu -> %zu lost bytes", have, n);
        CHECK((uintptr_t)q % 64 == 0);
        fill(q, n, 3);
        p = q;
        have = n;
    }
    bigmem_free(p);

    /* Growing inside a mapping's slack keeps the pointer. */
    if (bigmem_maps_large()) {
        unsigned char *m = bigmem_alloc(BIGMEM_MIN_BYTES);
        CHECK(m != NULL);
        unsigned char *g = bigmem_resize(m, BIGMEM_MIN_BYTES + 4096);
        CHECK(g == m);
        bigmem_free(g);
    }
}

/* Middle sizes come from the shared pool: zeroed even right after a block of the same
 * size was filled and freed (the same bytes, handed out again from the pool's top:
 * test_pool_stack), 64-aligned, never a mapping of their own, and resizable across the
 * paths like the others. */
static void test_middle_sizes(void)
{
    const size_t sizes[] = {BIGMEM_POOL_MIN_BYTES - 1, BIGMEM_POOL_MIN_BYTES, 100000,
                            BIGMEM_MIN_BYTES - 64};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        size_t n = sizes[k];
        for (int round = 0; round < 3; round++) {
            unsigned char *p = bigmem_alloc(n);
            CHECK_MSG(p != NULL, "size %zu", n);
            if (!p)
                continue;
            CHECK_MSG((uintptr_t)p % 64 == 0, "size %zu not 64-aligned", n);
            CHECK_MSG(all_zero(p, n), "size %zu round %d not zeroed", n, round);
            CHECK(!bigmem_is_mapped(p));
            CHECK(bigmem_capacity(p) >= n);
            fill(p, n, 5);
            bigmem_free(p);
        }
    }
    unsigned char *a = bigmem_alloc(BIGMEM_POOL_MIN_BYTES);
    CHECK(a != NULL);
    if (!a)
        return;
    fill(a, BIGMEM_POOL_MIN_BYTES, 11);
    unsigned char *b = bigmem_resize(a, 200000);
    CHECK(b && filled(b, BIGMEM_POOL_MIN_BYTES, 11));
    unsigned char *c = b ? bigmem_resize(b, BIGMEM_MIN_BYTES + 5) : NULL;
    CHECK(c && filled(c, BIGMEM_POOL_MIN_BYTES, 11));
    unsigned char *d = c ? bigmem_resize(c, 100) : NULL;
    CHECK(d && filled(d, 100, 11));
    bigmem_free(d ? d : c ? c : b);
}

/* The pool is used like a stack: its top block grows and shrinks in place and, freed,
 * is handed out again with all the bytes it ever had cleared; a block freed below the
 * top stays taken. */
static void test_pool_stack(void)
{
    if (!bigmem_maps_large())
        return; /* AddressSanitizer builds: every block is malloc'd */
    size_t n = 100000;
    unsigned char *a = bigmem_alloc(n);
    CHECK(a != NULL && !bigmem_is_mapped(a));
    if (!a)
        return;
    fill(a, n, 1);
    unsigned char *g = bigmem_resize(a, 3 * n); /* the top: grows in place */
    CHECK(g == a && filled(g, n, 1));
    fill(g, 3 * n, 2);
    unsigned char *s = bigmem_resize(g, n / 2); /* and shrinks in place */
    CHECK(s == a && filled(s, n / 2, 2));
    bigmem_free(s);
    unsigned char *b = bigmem_alloc(2 * n); /* the same bytes again, every one cleared */
    CHECK(b == a && all_zero(b, 2 * n));
    unsigned char *c = bigmem_alloc(3 * n); /* bytes a once had, cleared too */
    CHECK(c == a + 2 * n + 64 && all_zero(c, 3 * n));
    fill(b, 2 * n, 3);
    fill(c, 3 * n, 4);
    unsigned char *m = bigmem_resize(b, 2 * n + 4096); /* b is not the top: it moves */
    CHECK(m && m != b && filled(m, 2 * n, 3));
    bigmem_free(c); /* c was the top before m came: m is, so c stays taken */
    unsigned char *d = bigmem_alloc(n);
    CHECK(d && d != c && all_zero(d, n));
    bigmem_free(d);
    bigmem_free(m);
}

/* Mapped blocks freed are kept as spares: a later big allocation that fits one (up to
 * twice its size) takes it, with every byte any earlier block wrote there cleared;
 * beyond BIGMEM_SPARE_BYTES of spares, a freed mapping is unmapped. */
static void test_spares(void)
{
    if (!bigmem_maps_large())
        return; /* AddressSanitizer builds: every block is malloc'd */
    size_t mb = 1u << 20;
    unsigned char *a = bigmem_alloc(3 * mb - 100); /* a 4 MB mapping */
    CHECK(a != NULL);
    if (!a)
        return;
    fill(a, 3 * mb - 100, 1);
    bigmem_free(a);
    CHECK(page_mapped(a));
    unsigned char *b = bigmem_alloc(mb); /* fits (4 MB is at most twice its 2 MB) */
    CHECK(b == a && all_zero(b, mb) && bigmem_capacity(b) == 4 * mb);
    CHECK(filled(b + 2 * mb, mb - 100, (unsigned)(2 * mb * 31u + 1))); /* not cleared */
    unsigned char *c = bigmem_alloc(mb); /* no spare left: a fresh mapping */
    CHECK(c && c != b && all_zero(c, mb));
    bigmem_free(c);
    bigmem_free(b);
    /* The bytes past b's size that a wrote are cleared when a bigger block takes it. */
    unsigned char *d = bigmem_alloc(4 * mb - 64);
    CHECK(d == a && all_zero(d, 4 * mb - 64));
    fill(d, 4 * mb - 64, 5);
    /* The smallest spare that fits: c's 2 MB, not the 4 MB one. */
    bigmem_free(d);
    unsigned char *e = bigmem_alloc(BIGMEM_MIN_BYTES);
    CHECK(e == c && all_zero(e, BIGMEM_MIN_BYTES));
    bigmem_free(e);
    /* A block bigger than BIGMEM_SPARE_MAX_BYTES is never kept: unmapped at once. */
    unsigned char *big = bigmem_alloc(BIGMEM_SPARE_MAX_BYTES + 1);
    CHECK(big != NULL);
    if (!big)
        return;
    bigmem_free(big);
    CHECK(!page_mapped(big));
    /* The budget: blocks of the largest size kept, never touched; with the 4 and 2 MB
     * spares above, the spares' slots (8) and bytes (BIGMEM_SPARE_BYTES) allow
     * (64 - 6) / 8 = 7 of them by bytes but 6 by slots: the seventh and eighth are
     * unmapped at once. */
    enum { N = 8 };
    unsigned char *p[N];
    for (int i = 0; i < N; i++) {
        p[i] = bigmem_alloc(BIGMEM_SPARE_MAX_BYTES);
        CHECK(p[i] != NULL);
        if (!p[i])
            return;
    }
    for (int i = 0; i < N; i++)
        bigmem_free(p[i]);
    for (int i = 0; i < N; i++)
        CHECK_MSG(page_mapped(p[i]) == (i < 6), "8 MB block %d mapped %d", i,
                  page_mapped(p[i]));
}

static void test_absurd_sizes(void)
{
    CHECK(bigmem_alloc(SIZE_MAX) == NULL);
    CHECK(bigmem_alloc(SIZE_MAX / 2 + 1) == NULL);
    CHECK(bigmem_calloc(SIZE_MAX / 2, 4) == NULL);
    CHECK(bigmem_calloc(4, SIZE_MAX / 2) == NULL);
    unsigned char *p = bigmem_alloc(64);
    CHECK(p != NULL);
    fill(p, 64, 9);
    CHECK(bigmem_resize(p, SIZE_MAX) == NULL);
    CHECK(filled(p, 64, 9)); /* untouched, still ours to free */
    bigmem_free(p);
}

/* On Linux the big path asks for huge pages: the mapping's VmFlags in /proc/self/smaps
 * carry "hg" (MADV_HUGEPAGE). Kernels without transparent huge pages have no such
 * folder and refuse the advice; there the memory is ordinary pages and works the same. */
static void test_huge_page_advice(void)
{
    if (!bigmem_maps_large())
        harness_skip("AddressSanitizer build: big arrays come from malloc");
    FILE *thp = fopen("/sys/kernel/mm/transparent_hugepage/enabled", "r");
    if (!thp)
        harness_skip("no transparent huge pages in this kernel");
    fclose(thp);
    unsigned char *p = bigmem_alloc(4u << 20);
    CHECK(p != NULL);
    FILE *f = fopen("/proc/self/smaps", "r");
    CHECK(f != NULL);
    if (!f || !p)
        return;
    char line[512];
    bool in_ours = false, found = false, advised = false;
    uintptr_t start = (uintptr_t)p;
    while (fgets(line, sizeof line, f)) {
        unsigned long lo, hi;
        if (sscanf(line, "%lx-%lx ", &lo, &hi) == 2 && strchr(line, '-') < strchr(line, ' ')) {
            in_ours = lo == start;
            found = found || in_ours;
        } else if (in_ours && strncmp(line, "VmFlags:", 8) == 0) {
            advised = strstr(line, " hg") != NULL;
        }
    }
    fclose(f);
    CHECK_MSG(found, "no mapping starts at the block's data");
    CHECK_MSG(advised, "the mapping lacks the huge-page advice (hg)");
    bigmem_free(p);
}

/* bigmem_leave_to_exit: a mapped block freed before it is unmapped (one bigger than
 * the spares' budget, which is never kept); after it, its mapping stays (with its bytes)
 * for the exit to take, and is no spare; smaller blocks are freed and handed out again
 * as before. */
static void test_leave_to_exit(void)
{
    if (!bigmem_maps_large())
        return; /* AddressSanitizer builds: every block is malloc'd */
    size_t big = BIGMEM_SPARE_BYTES + 1;   /* never touched: no memory spent on it */
    unsigned char *a = bigmem_alloc(big);
    CHECK(a != NULL && bigmem_is_mapped(a));
    CHECK(page_mapped(a + big / 2));
    bigmem_free(a);
    CHECK(!page_mapped(a + big / 2)); /* unmapped at once */
    unsigned char *b = bigmem_alloc(big);
    CHECK(b != NULL && bigmem_is_mapped(b));
    fill(b, big, 7);
    bigmem_leave_to_exit();
    bigmem_free(b);
    CHECK(page_mapped(b + big / 2));
    CHECK(filled(b, big, 7)); /* left as it was */
    /* A small mapped block is not kept as a spare either: the next one is fresh. */
    unsigned char *s = bigmem_alloc(BIGMEM_MIN_BYTES);
    CHECK(s != NULL);
    if (s)
        s[0] = 1;
    bigmem_free(s);
    unsigned char *t = bigmem_alloc(BIGMEM_MIN_BYTES);
    CHECK(t != NULL && t != s && t[0] == 0);
    bigmem_free(t);
    unsigned char *c = bigmem_alloc(100); /* malloc'd: freed and usable as ever */
    CHECK(c != NULL && all_zero(c, 100));
    bigmem_free(c);
}

/* Whether the page at p is in memory (mincore's residency bit; false when unmapped). */
static bool page_resident(const void *p)
{
    long ps = sysconf(_SC_PAGESIZE);
    uintptr_t a = (uintptr_t)p & ~(uintptr_t)(ps - 1);
    unsigned char v = 0;
    return mincore((void *)a, (size_t)ps, &v) == 0 && (v & 1);
}

/* A fresh mapped block has none of its data in memory: it carries no header, so
 * allocating it faults in no 2 MB page (the threads that fill it do, where they write,
 * or bigmem_prefault, its range only). Freed, its mapping goes; a shrink gives its tail
 * back and keeps the rest. */
static void test_fresh_block_untouched(void)
{
    if (!bigmem_maps_large())
        return; /* AddressSanitizer builds: every block is malloc'd */
    size_t big = 6u << 20;
    unsigned char *p = bigmem_alloc(big);
    CHECK(p != NULL && bigmem_is_mapped(p));
    if (!p)
        return;
    /* An empty range touches nothing (not the byte before it: at a block's start on
     * its 2 MB boundary, that byte is not mapped). */
    bigmem_prefault(p, 0, 0);
    bigmem_prefault(p, 4u << 20, 0);
    long ps = sysconf(_SC_PAGESIZE);
    size_t resident = 0;
    for (size_t off = 0; off < big; off += (size_t)ps)
        resident += page_resident(p + off);
    CHECK_MSG(resident == 0, "%zu pages of a fresh block are in memory", resident);
    /* bigmem_prefault brings in just its range, bytes unchanged (clipped at the end). */
    p[(3u << 20) + 5] = 42;
    bigmem_prefault(p, 3u << 20, 1u << 20);
    bigmem_prefault(p, big - 100, 1u << 20);
    size_t missing = 0, extra = 0; /* huge pages may bring in the rest of their 2 MB */
    for (size_t off = 3u << 20; off < 4u << 20; off += (size_t)ps)
        missing += !page_resident(p + off);
    for (size_t off = 0; off < 2u << 20; off += (size_t)ps)
        extra += page_resident(p + off);
    CHECK_MSG(missing == 0 && extra == 0, "prefaulted range: %zu pages missing; %zu pages "
              "of an untouched 2 MB in memory", missing, extra);
    CHECK(page_resident(p + big - 1));
    CHECK(p[(3u << 20) + 5] == 42 && all_zero(p + (3u << 20) + 6, 100));
    p[(3u << 20) + 5] = 0;
    p[0] = 1;
    CHECK(page_resident(p));
    CHECK(bigmem_capacity(p) >= big && bigmem_capacity(p) < big + (2u << 20));
    unsigned char *q = bigmem_resize(p, 3u << 20); /* shrinks in place to 4 MB */
    CHECK(q == p && q[0] == 1);
    CHECK(bigmem_capacity(q) == 4u << 20);
    CHECK(!page_mapped(q + (4u << 20)));
    CHECK(page_mapped(q + (4u << 20) - 1));
    /* A shrink to 0 keeps one 2 MB step: the pointer stays a live block (its slot
     * must not name a mapping that is gone, which a later mapping could take). */
    q = bigmem_resize(q, 0);
    CHECK(q == p && page_mapped(q));
    CHECK(bigmem_capacity(q) == 2u << 20);
    unsigned char *r = bigmem_resize(q, 4096); /* within the capacity: in place */
    CHECK(r == q && page_mapped(r));
    if (r)
        r[4095] = 7;
    bigmem_free(r);
    CHECK(page_mapped(r)); /* a spare now (test_spares) */
}

/* More mapped blocks than the table of mappings holds: the rest carry their header in
 * front of their data (64 bytes past the 2 MB boundary), and every block works the same
 * way (zeroed, mapped, resized in place, freed), whichever kind it is. */
static void test_many_mappings(void)
{
    if (!bigmem_maps_large())
        return;
    enum { N = 300 };
    static unsigned char *p[N];
    int headed = 0;
    for (int i = 0; i < N; i++) {
        p[i] = bigmem_alloc(BIGMEM_MIN_BYTES + (size_t)i);
        CHECK(p[i] != NULL);
        if (!p[i])
            return;
        uintptr_t off = (uintptr_t)p[i] % (2u << 20);
        CHECK_MSG(off == 0 || off == 64, "block %d at %lu past 2 MB", i, (unsigned long)off);
        headed += off == 64;
        CHECK(bigmem_is_mapped(p[i]));
        CHECK(bigmem_capacity(p[i]) >= BIGMEM_MIN_BYTES + (size_t)i);
        if (off == 64 || i % 50 == 0) { /* a touch brings in 2 MB: a few of each kind */
            CHECK(all_zero(p[i], 4096));
            fill(p[i], 4096, (unsigned)i);
        }
    }
    CHECK_MSG(headed > 0 && headed < N, "%d of %d blocks with a header", headed, N);
    for (int i = 0; i < N; i++) {
        bool written = (uintptr_t)p[i] % (2u << 20) == 64 || i % 50 == 0;
        unsigned char *q = bigmem_resize(p[i], 1000000); /* grows in place */
        CHECK(q == p[i] && (!written || filled(q, 4096, (unsigned)i)));
        bigmem_free(q);
    }
    unsigned char *again = bigmem_alloc(BIGMEM_MIN_BYTES); /* slots are free again */
    CHECK(again && (uintptr_t)again % (2u << 20) == 0);
    bigmem_free(again);
}

static const TestCase tests[] = {
    {"bigmem: a fresh big block faults nothing in; freed, it is a spare",
     test_fresh_block_untouched},
    {"bigmem: more mappings than the table holds work alike", test_many_mappings},
    {"bigmem: left to the exit, mappings stay; before, they go", test_leave_to_exit},
    {"bigmem: sizes on both paths, zeroed and aligned", test_alloc_sizes},
    {"bigmem: resize keeps the contents across the paths", test_resize_keeps_contents},
    {"bigmem: middle sizes from the pool, zeroed", test_middle_sizes},
    {"bigmem: the pool's top block grows, shrinks and is reused, cleared", test_pool_stack},
    {"bigmem: freed mappings kept as spares, reused cleared, within a budget", test_spares},
    {"bigmem: absurd sizes refused, the block kept", test_absurd_sizes},
    {"bigmem: big blocks carry the huge-page advice", test_huge_page_advice},
};
RT_TEST_MAIN(tests)
