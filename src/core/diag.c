/* Compiler-style diagnostics ("file:line:col: error: ..."), kept for tests in last[]. */
#include "rt/diag.h"

#include <stdarg.h>
#include <string.h>

static const char *g_program = "raytracer";

void diag_set_program(const char *name) { g_program = name; }
const char *diag_program(void) { return g_program; }

void diag_init(Diag *d, FILE *stream)
{
    memset(d, 0, sizeof *d);
    d->stream = stream;
}

/* The format attribute lets the compiler check fmt where diag_error/diag_warning are
 * called (they carry the same attribute in rt/diag.h) instead of here. */
static void diag_emit(Diag *d, const SrcLoc *loc, const char *kind, const char *fmt,
                      va_list ap) __attribute__((format(printf, 4, 0)));
static void diag_emit(Diag *d, const SrcLoc *loc, const char *kind, const char *fmt,
                      va_list ap)
{
    char msg[768];
    vsnprintf(msg, sizeof msg, fmt, ap);
    if (loc && loc->file && loc->line > 0)
        snprintf(d->last, sizeof d->last, "%s:%d:%d: %s: %s", loc->file, loc->line,
                 loc->col, kind, msg);
    else if (loc && loc->file)
        snprintf(d->last, sizeof d->last, "%s: %s: %s", loc->file, kind, msg);
    else
        snprintf(d->last, sizeof d->last, "%s: %s: %s", g_program, kind, msg);
    if (d->stream) {
        fprintf(d->stream, "%s\n", d->last);
        fflush(d->stream);
    }
}

void diag_error(Diag *d, const SrcLoc *loc, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    diag_emit(d, loc, "error", fmt, ap);
    va_end(ap);
    d->errors++;
}

void diag_warning(Diag *d, const SrcLoc *loc, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    diag_emit(d, loc, "warning", fmt, ap);
    va_end(ap);
    d->warnings++;
}
