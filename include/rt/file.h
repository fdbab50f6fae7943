/* Reading whole input files: one read into one NUL-terminated buffer, which the scene
 * lexer and the OBJ reader scan with the '\0' as their end sentinel. */
#ifndef RT_FILE_H
#define RT_FILE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Inputs above this are refused (EFBIG) rather than exhausting memory: /dev/zero or an
 * endless pipe given as a file must end in an error, not in the OOM killer. 256 MiB is
 * an OBJ of several million triangles. */
#define RT_FILE_MAX_BYTES ((size_t)256 << 20)

/* Regular files from this size on are read in parallel chunks (rt/par.h); the OBJ
 * reader parses them in pieces from the same size on. */
#define RT_FILE_PAR_MIN_BYTES ((size_t)256 << 10)

/* A read by one thread looks at the stop request before each of its reads of this
 * many bytes at most: a 100 MB OBJ file on a slow disk or network file system took
 * seconds in one fread, and a Ctrl-C waited for all of it. */
#define RT_FILE_STOP_BYTES ((size_t)4 << 20)

/* Reads a whole file into a malloc'd, NUL-terminated buffer; *len excludes the NUL.
 * The path "-" reads standard input (the scene of -input -).
 * False with errno set (EISDIR, EFBIG past RT_FILE_MAX_BYTES, ENOMEM, or fopen's), or
 * EINTR when a stop was requested (rt/par.h: looked at before every RT_FILE_STOP_BYTES
 * read, and every parallel chunk), which the caller does not report. These reads
 * and the next two all look at it. */
bool file_read_all(const char *path, char **out, size_t *len);
/* Whether one of the reads above is at work on a pipe, a FIFO or a terminal (its open
 * included), where it may wait for input for ever. Async-signal-safe: the stop-signal
 * handler ends the run at once then (nothing has been written yet), since a signal does
 * not cut such a wait under SA_RESTART. */
bool file_input_waiting(void);
/* The same into an arena buffer (rt/arena.h; arena_buffer_free), which
 * objfile_build_group can reuse for the triangles. */
bool file_read_reusable(const char *path, char **out, size_t *len);

/* What the file system says of a regular file: device, inode, size, and the times of
 * the last change of its bytes (mtime) and of its inode (ctime), to the nanosecond.
 * Rule: two equal identities name the same bytes when the identity was settled (below)
 * and the file lives on a file system that keeps ctime the POSIX way. Every write,
 * truncation, rename or time change sets ctime to the clock's time, and no program can
 * set it back (only setting the system clock back could); so a file changed after a
 * settled identity was taken has a later ctime, whatever its size and mtime. */
typedef struct FileIdentity {
    uint64_t dev, ino, size;
    int64_t mtime_s, mtime_ns, ctime_s, ctime_ns;
} FileIdentity;

/* Opens path for reading (so a file that cannot be read gives no identity, as it would
 * give no bytes) and takes its identity. False with errno set: not openable, not a
 * regular file (EINVAL), or on a file system not known to keep ctime (ENOTSUP: FAT
 * and the like, whose ctime follows mtime). */
bool file_identity(const char *path, FileIdentity *id);
/* Whether id's mtime and ctime both lie at least RT_FILE_SETTLED_SECONDS before the
 * clock's time now: file systems stamp times from a clock that moves in ticks of up to
 * a few ms, so a write right after the identity was taken could otherwise keep the same
 * stamps. */
#define RT_FILE_SETTLED_SECONDS 2
bool file_identity_settled(const FileIdentity *id);
/* file_read_reusable that also gives the identity of the file it read, taken before
 * the read, and *stable: the same identity after the read (nothing changed the file
 * meanwhile). *stable false for anything but a known regular file (see file_identity). */
bool file_read_reusable_identified(const char *path, char **out, size_t *len, FileIdentity *id,
                                   bool *stable);

/* True when a and b name one existing file: the same device and inode, so another
 * spelling of the path ("dir/../a.tga") or a link to it counts. False when either
 * cannot be looked up (stat). */
bool file_same(const char *a, const char *b);

/* Where a file written to path by "temporary file, then rename" must be renamed to so
 * that a symbolic link stays a link: path itself when it is not a link (or does not
 * exist); else the file the chain of links ends at, existing or not (a dangling link's
 * target is what gets created), as a malloc'd name. Renaming onto the link itself would
 * replace it with a regular file. Used by the image outputs and the -cache file. NULL
 * with *err set (ENOMEM, ELOOP past 40 links, a readlink error). */
char *file_link_target(const char *path, int *err);

#endif
