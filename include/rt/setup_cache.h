/* The set-up cache of split renders (-cache FILE, docs/distributed.md): the heavy flat
 * arrays a process builds before its first ray (the meshes parsed from OBJ files, the
 * uniform grid's cells and packed triangles), kept in one file so that the other
 * processes of the same split render read them instead of building them again.
 *
 * The file is a list of sections, each found by a tag and a 128-bit key that the user
 * of the section makes from everything its arrays depend on (file bytes, options). The
 * whole file is checked when it is opened: a header naming this build (format version,
 * endianness, word size, the executable's identity), its length and a checksum of every
 * byte. A file that fails any check is not used (the caller builds instead); nothing in
 * it is trusted beyond those checks and the caller's own bounds checks.
 *
 * Sections found are read-only memory holding the file's bytes (read whole when it is
 * opened, in rt/bigmem.h memory), valid until the last reference is
 * released (setup_cache_release). Sections added are copied; setup_cache_write writes
 * them (temporary file + rename, so readers see the old file or the new one whole). */
#ifndef RT_SETUP_CACHE_H
#define RT_SETUP_CACHE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "rt/diag.h"

typedef struct SetupCache SetupCache;

/* At most this many arrays per section. */
enum { SETUP_CACHE_MAX_PARTS = 8 };

typedef struct SetupKey {
    uint64_t a, b;
} SetupKey;

/* The section tags. SETUP_TAG_FILE: the key of a file's bytes (one SetupKey), found by
 * the key of its identity (rt/file.h), so that a process can skip reading it. */
enum { SETUP_TAG_MESH = 1, SETUP_TAG_GRID = 2, SETUP_TAG_FILE = 3 };

/* Opens path: reads it when it is a valid cache of this build (a missing file is simply
 * empty). Never fails for a bad file: why it was not used is kept for
 * setup_cache_note. NULL only when out of memory. The caller holds one reference. */
SetupCache *setup_cache_open(const char *path);
void setup_cache_retain(SetupCache *c);
void setup_cache_release(SetupCache *c);    /* NULL allowed; the last one frees */

/* Why the file was not used ("" when it was, or was absent: then nothing to say). */
const char *setup_cache_rejected(const SetupCache *c);
/* How many lookups found their section; of them, how many had tag (0 for others). */
int setup_cache_hits(const SetupCache *c);
int setup_cache_hits_of(const SetupCache *c, uint32_t tag);
/* Whether a lookup missed or something was added (setup_cache_write has work). */
bool setup_cache_dirty(const SetupCache *c);

/* The parts of section (tag, key): *nparts arrays, part[i] of len[i] bytes, each
 * 64-byte aligned. False when the file has no such section (counted as a miss). */
bool setup_cache_find(SetupCache *c, uint32_t tag, SetupKey key, const void **part,
                      size_t *len, int *nparts);
/* Records a section to write (the bytes are copied). False when out of memory (then
 * nothing will be written). */
bool setup_cache_add(SetupCache *c, uint32_t tag, SetupKey key, const void *const *part,
                     const size_t *len, int nparts);
/* Writes the file when setup_cache_dirty: every section added (the sections found are
 * not kept: one file holds one scene's set-up). False (with why, for a warning) when it
 * cannot be written. */
bool setup_cache_write(SetupCache *c, char *why, size_t why_len);

/* A 128-bit hash of len bytes, chained from seed (the key of a section is the hash of
 * its inputs, in order). */
SetupKey setup_hash(const void *data, size_t len, SetupKey seed);
/* Chains a value into a key. */
SetupKey setup_hash_u64(SetupKey seed, uint64_t v);

#endif
