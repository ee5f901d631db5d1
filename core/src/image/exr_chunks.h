/* The EXR writer's channel list and its pixel chunks (exr_write.c defines the file,
 * exr_chunks.c encodes and writes the chunks). */
#ifndef VSD_IMAGE_EXR_CHUNKS_H
#define VSD_IMAGE_EXR_CHUNKS_H
#include "vsd/image.h"
#include <openexr.h>

#define LAYER_MAX 200                 /* keeps every channel name within a fixed buffer */
#define EXR_SHORT_NAME_MAX 31         /* longer names need the EXR "long names" flag */

typedef struct exr_chan {
    char name[LAYER_MAX + VSD_PASS_NAME_MAX + 8];
    vsd_pass pass;
    int comp;                         /* index into the pass's interleaved channels */
    int half;                         /* stored as half (else float32) */
} exr_chan;

/* Encode and write every scanline chunk of part 0 (its header written) from fb's passes:
 * `threads` workers (0 = one per online CPU) pack and compress chunks at once and write
 * them in increasing y, so the file's bytes do not depend on the thread count. */
exr_result_t vsd_exr_write_chunks(exr_context_t ctxt, const vsd_framebuffer *fb, const exr_chan *chans, int n,
                                  int threads);
#endif
