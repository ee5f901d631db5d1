/* clock.h — the library's monotonic clock, declared publicly in vsd/clock.h. */
#ifndef VSD_CLOCK_H
#define VSD_CLOCK_H
#include "vsd/clock.h"
#endif
