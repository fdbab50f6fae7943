/* A progress line for long work: "rendering  37%  2.10 Mrays/s  0:05 elapsed, 0:08
 * left", redrawn in place on a terminal by one drawing thread at most 10 times a
 * second, and erased when the work ends. Into a file or a pipe (-progress 2> log) the
 * same text comes as whole lines instead: one when both 5% more is done and 30 s have
 * passed since the last, and a final one when the work ends. Workers only add to two
 * atomic counters, so it costs them nothing measurable; anything that counts units of
 * work (image rows, MPI tiles, samples) can use it. */
#ifndef RT_PROGRESS_H
#define RT_PROGRESS_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

typedef enum ProgressMode {
    PROGRESS_AUTO,     /* draw only when out is a terminal (pipes, files, tests stay clean) */
    PROGRESS_ALWAYS,   /* -progress: draw even into a pipe or a file */
    PROGRESS_NEVER     /* -quiet */
} ProgressMode;

typedef struct Progress Progress;

/* The log's cadence (out not a terminal): a line once both 1/PROGRESS_LOG_STEPS more of
 * the work is done and PROGRESS_LOG_SECONDS have passed since the last line (or the
 * start), and a final one. raytracer-mpi's "rows done" line keeps the same. */
#define PROGRESS_LOG_STEPS 20
#define PROGRESS_LOG_SECONDS 30.0

/* Whether mode draws on out (AUTO: out is a terminal). */
bool progress_wanted(ProgressMode mode, FILE *out);

/* Starts a line "<what> 0%" on out (a terminal; elsewhere nothing yet) for total
 * units of work (total > 0) and the thread that redraws it. Returns NULL when nothing
 * is to be drawn (progress_wanted is false, total is 0, or no memory or thread): every
 * function below accepts NULL and then does nothing, so callers need no test. what is
 * borrowed until progress_finish. */
Progress *progress_start(ProgressMode mode, FILE *out, const char *what, uint64_t total);

/* Adds units of finished work and the rays they traced (0 when rays are not the
 * measure: the line then shows no rate). Safe from any thread, lock-free. */
void progress_add(Progress *p, uint64_t units, uint64_t rays);

/* Units added so far (0 for NULL): for callers that check their totals, and tests. */
uint64_t progress_done(const Progress *p);

/* Stops the drawing thread, erases the line (out is left where the line began; not a
 * terminal: appends the final line) and frees p. Call it before anything else is
 * printed on out's terminal. */
void progress_finish(Progress *p);

/* The text of the line for the given state, into buf (for the drawer and the tests):
 * percentage of total done, rays per second when rays > 0, elapsed time and, once
 * something is done, an estimate of the time left. */
void progress_format(char *buf, size_t size, const char *what, uint64_t done, uint64_t total,
                     uint64_t rays, double elapsed_seconds);

#endif
