/* Frame ranges as pipelines write them: "A-B" (inclusive) or "N". One parser for
 * `vsd render --frames`, `vsd export pov --frames` and `vsd farm --frames`. */
#ifndef VSD_PIPELINE_FRAME_RANGE_H
#define VSD_PIPELINE_FRAME_RANGE_H
#include <stddef.h>

/* Parses `text` into *first..*last (negative frames allowed: "-5--1"). Returns 0, or -1
 * with a message naming the text in err ("expected A-B or N, got 'x'", "end 3 before
 * start 5"). */
int vsd_parse_frame_range(const char *text, int *first, int *last, char *err, size_t errlen);

#endif
