/* Diagnostics sink: located, compiler-style messages ("file:line:col: error: ...").
 * Below main nothing exits; errors are reported here and failure is returned. */
#ifndef RT_DIAG_H
#define RT_DIAG_H

#include <stdio.h>

typedef struct SrcLoc {
    const char *file;   /* borrowed; NULL for messages about no file */
    int line, col;      /* 1-based; 0 = unknown (then omitted from the message) */
} SrcLoc;

typedef struct Diag {
    FILE *stream;       /* where messages are printed; NULL = print nothing (tests) */
    int errors;         /* errors reported so far */
    int warnings;
    char last[1024];    /* the last message, without the trailing newline */
} Diag;

/* The name the program's own messages start with ("raytracer: ..."): the binary the
 * user ran, ./raytracer or ./raytracer-mpi. main sets it first thing from its src/dist
 * object's dist_program_name (so it is fixed per binary when linked, not taken from
 * argv[0], which may be a whole path or anything a launcher put there). Until then, and
 * in tests linking the library alone, "raytracer". */
void diag_set_program(const char *name);
const char *diag_program(void);

void diag_init(Diag *d, FILE *stream);
/* "file:line:col: error: <msg>", or "file: error: <msg>" without a line, or
 * "<program>: error: <msg>" without a file. */
void diag_error(Diag *d, const SrcLoc *loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
void diag_warning(Diag *d, const SrcLoc *loc, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

#endif
