/* clock.h — the one monotonic clock the library times its stages with (stats, the
 * distance map's and dense grid's build times). */
#ifndef VSD_CLOCK_H
#define VSD_CLOCK_H

/* Seconds on CLOCK_MONOTONIC: only differences mean anything. */
double vsd_clock_seconds(void);

#endif
