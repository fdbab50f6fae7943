/* Reading whole input files: one read into one NUL-terminated buffer, which the scene
 * lexer and the OBJ reader scan with the '\0' as their end sentinel. */
#ifndef RT_FILE_H
#define RT_FILE_H

#include <stdbool.h>
#include <stddef.h>

/* Inputs above this are refused (EFBIG) rather than exhausting memory: /dev/zero or an
 * endless pipe given as a file must end in an error, not in the OOM killer. 256 MiB is
 * an OBJ of several million triangles. */
#define RT_FILE_MAX_BYTES ((size_t)256 << 20)

/* Regular files from this size on are read in parallel chunks (rt/par.h); the OBJ
 * reader parses them in pieces from the same size on. */
#define RT_FILE_PAR_MIN_BYTES ((size_t)256 << 10)

/* Reads a whole file into a malloc'd, NUL-terminated buffer; *len excludes the NUL.
 * The path "-" reads standard input (the scene of -input -).
 * False with errno set (EISDIR, EFBIG past RT_FILE_MAX_BYTES, ENOMEM, or fopen's). */
bool file_read_all(const char *path, char **out, size_t *len);
/* The same into an arena buffer (rt/arena.h; arena_buffer_free), which
 * objfile_build_group can reuse for the triangles. */
bool file_read_reusable(const char *path, char **out, size_t *len);

/* True when a and b name one existing file: the same device and inode, so another
 * spelling of the path ("dir/../a.tga") or a link to it counts. False when either
 * cannot be looked up (stat). */
bool file_same(const char *a, const char *b);

#endif
