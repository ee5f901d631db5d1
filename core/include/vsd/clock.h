/* vsd/clock.h — the one monotonic clock: the library times its stages with it, the CLI
 * its progress and ETA, the daemon its jobs. */
#ifndef VSD_PUBLIC_CLOCK_H
#define VSD_PUBLIC_CLOCK_H
#ifdef __cplusplus
extern "C" {
#endif

/* Seconds on CLOCK_MONOTONIC: only differences mean anything. */
double vsd_clock_seconds(void);

#ifdef __cplusplus
}
#endif
#endif
