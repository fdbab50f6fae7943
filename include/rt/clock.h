/* The program's one wall clock (-timings, -stats' total time, the progress line). */
#ifndef RT_CLOCK_H
#define RT_CLOCK_H

/* Seconds on the monotonic clock (CLOCK_MONOTONIC) from an unspecified start: only
 * differences mean anything; never goes back when the system time is set. */
double clock_now(void);

#endif
