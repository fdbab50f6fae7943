/* The program's one wall clock (-timings, -stats' total time, the progress line) and the
 * calling thread's CPU clock (-timings). */
#ifndef RT_CLOCK_H
#define RT_CLOCK_H

/* Seconds on the monotonic clock (CLOCK_MONOTONIC) from an unspecified start: only
 * differences mean anything; never goes back when the system time is set. */
double clock_now(void);

/* Seconds of CPU time the calling thread has used (CLOCK_THREAD_CPUTIME_ID), 0 when the
 * system cannot tell: with one render thread, the whole cost of a phase however busy
 * the machine is (-timings, the benchmarks). */
double clock_thread_cpu(void);

#endif
