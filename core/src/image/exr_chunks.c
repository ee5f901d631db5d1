/* The pixel chunks of an EXR on several threads (exr_chunks.h). ZIP is zlib's deflate of
 * each 16-row chunk: 77% of a 1280x720 result's encode (perf), 0.67 s on one core for 17
 * float channels. Chunks compress independently, so workers claim them in increasing y and
 * compress at once; OpenEXR's scanline files take their chunks in order (the chunk table
 * and the file offsets follow the writes), so each worker's write waits for its turn. The
 * encode pipeline is OpenEXR's per-thread object for exactly this (openexr_encode.h). */
#define _POSIX_C_SOURCE 200809L
#include "src/image/exr_chunks.h"
#include "src/common/cpu_count.h"
#include <Imath/half.h>
#include <pthread.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define MAX_THREADS 32

typedef struct chunk_job {
    exr_context_t ctxt;
    const vsd_framebuffer *fb;
    const exr_chan *chans;
    int n, lines, chunk_count;
    pthread_mutex_t mu;
    pthread_cond_t turn;
    int next_claim;                   /* the next chunk a worker takes */
    int next_write;                   /* the chunk whose write is due */
    exr_result_t rv;                  /* the first failure; stops every worker */
} chunk_job;

typedef struct chunk_worker {
    exr_encode_pipeline_t enc;        /* first: ordered_write finds the worker from it */
    exr_result_t (*library_write)(exr_encode_pipeline_t *);
    chunk_job *job;
} chunk_worker;

/* Copy rows [y0, y0+rows) of one channel out of its interleaved pass into a planar buffer
 * of the stored type: the library's packer then only has to byte-swap and compress. */
static void stage_channel(const vsd_framebuffer *fb, const exr_chan *c, int y0, int rows, void *dst)
{
    int nc = vsd_pass_channels(c->pass);
    size_t w = (size_t)fb->width;
    const float *src = fb->pass[c->pass] + (size_t)y0 * w * (size_t)nc + (size_t)c->comp;
    size_t n = (size_t)rows * w;
    if (c->half) {
        uint16_t *h = dst;
        for (size_t i = 0; i < n; i++)
            h[i] = imath_float_to_half(src[i * (size_t)nc]);
    } else {
        float *f = dst;
        for (size_t i = 0; i < n; i++)
            f[i] = src[i * (size_t)nc];
    }
}

/* Point each encoder channel at its staged rows. Returns EXR_ERR_INVALID_ARGUMENT if the
 * library names a channel we did not define (cannot happen unless the API changes). The
 * library sorts channels by name, so they are matched by name, never by position. */
static exr_result_t bind_channels(exr_encode_pipeline_t *enc, const vsd_framebuffer *fb, const exr_chan *chans,
                                  int n, unsigned char *staging, size_t plane_bytes)
{
    for (int i = 0; i < enc->channel_count; i++) {
        exr_coding_channel_info_t *ec = &enc->channels[i];
        const exr_chan *c = NULL;
        for (int k = 0; k < n && !c; k++)
            if (strcmp(chans[k].name, ec->channel_name) == 0)
                c = &chans[k];
        if (!c)
            return EXR_ERR_INVALID_ARGUMENT;
        int bpe = c->half ? 2 : 4;
        unsigned char *plane = staging + (size_t)i * plane_bytes;
        stage_channel(fb, c, enc->chunk.start_y, enc->chunk.height, plane);
        ec->encode_from_ptr = plane;
        ec->user_bytes_per_element = (int16_t)bpe;
        ec->user_data_type = (uint16_t)(c->half ? EXR_PIXEL_HALF : EXR_PIXEL_FLOAT);
        ec->user_pixel_stride = bpe;
        ec->user_line_stride = bpe * fb->width;
    }
    return EXR_ERR_SUCCESS;
}

static void fail(chunk_job *job, exr_result_t rv)
{
    pthread_mutex_lock(&job->mu);
    if (!job->rv) job->rv = rv;
    pthread_cond_broadcast(&job->turn);
    pthread_mutex_unlock(&job->mu);
}

/* The pipeline's wait before its write (the library's own returns an error unless this is
 * the next chunk, for one thread writing alone): wait until every earlier chunk is written,
 * or another worker failed. */
static exr_result_t wait_for_turn(exr_encode_pipeline_t *enc)
{
    chunk_job *job = ((chunk_worker *)((char *)enc - offsetof(chunk_worker, enc)))->job;
    exr_result_t rv;
    pthread_mutex_lock(&job->mu);
    while (!job->rv && job->next_write != enc->chunk.idx) pthread_cond_wait(&job->turn, &job->mu);
    rv = job->rv;
    pthread_mutex_unlock(&job->mu);
    return rv;
}

/* The pipeline's write step: the library's own write, once every earlier chunk is written
 * (or, after another worker's failure, not at all); then the next chunk's turn. */
static exr_result_t ordered_write(exr_encode_pipeline_t *enc)
{
    chunk_worker *w = (chunk_worker *)((char *)enc - offsetof(chunk_worker, enc));
    chunk_job *job = w->job;
    exr_result_t rv;
    pthread_mutex_lock(&job->mu);
    while (!job->rv && job->next_write != enc->chunk.idx) pthread_cond_wait(&job->turn, &job->mu);
    rv = job->rv ? job->rv : w->library_write(enc);
    if (rv && !job->rv) job->rv = rv;
    job->next_write++;
    pthread_cond_broadcast(&job->turn);
    pthread_mutex_unlock(&job->mu);
    return rv;
}

static void *encode_worker(void *arg)
{
    chunk_worker *w = arg;
    chunk_job *job = w->job;
    size_t plane_bytes = (size_t)job->lines * (size_t)job->fb->width * sizeof(float);
    unsigned char *staging = malloc(plane_bytes * (size_t)job->n);
    int started = 0;
    if (!staging) {
        fail(job, EXR_ERR_OUT_OF_MEMORY);
        return NULL;
    }
    for (;;) {
        exr_chunk_info_t cinfo;
        exr_result_t rv;
        int k;
        pthread_mutex_lock(&job->mu);
        k = job->rv ? job->chunk_count : job->next_claim++;
        /* the chunk's table entry and sizes: computed under the lock, as the context's
           write state is shared */
        rv = k < job->chunk_count ? exr_write_scanline_chunk_info(job->ctxt, 0, k * job->lines, &cinfo) : 0;
        pthread_mutex_unlock(&job->mu);
        if (k >= job->chunk_count) break;
        if (!rv) rv = started ? exr_encoding_update(job->ctxt, 0, &cinfo, &w->enc)
                              : exr_encoding_initialize(job->ctxt, 0, &cinfo, &w->enc);
        if (!rv && !started) {
            started = 1;
            rv = bind_channels(&w->enc, job->fb, job->chans, job->n, staging, plane_bytes);
            if (!rv) rv = exr_encoding_choose_default_routines(job->ctxt, 0, &w->enc);
            w->library_write = w->enc.write_fn;
            w->enc.write_fn = ordered_write;
            w->enc.yield_until_ready_fn = wait_for_turn;
        } else if (!rv) {
            rv = bind_channels(&w->enc, job->fb, job->chans, job->n, staging, plane_bytes);
        }
        if (!rv) rv = exr_encoding_run(job->ctxt, 0, &w->enc);
        if (rv) {
            fail(job, rv);
            break;
        }
    }
    if (started) exr_encoding_destroy(job->ctxt, &w->enc);
    free(staging);
    return NULL;
}

exr_result_t vsd_exr_write_chunks(exr_context_t ctxt, const vsd_framebuffer *fb, const exr_chan *chans, int n,
                                  int threads)
{
    chunk_job job;
    chunk_worker workers[MAX_THREADS];
    pthread_t tids[MAX_THREADS];
    int32_t lines = 1;
    int i, running = 0;
    exr_result_t rv = exr_get_scanlines_per_chunk(ctxt, 0, &lines);
    if (rv) return rv;
    memset(&job, 0, sizeof job);
    job.ctxt = ctxt;
    job.fb = fb;
    job.chans = chans;
    job.n = n;
    job.lines = lines;
    job.chunk_count = (fb->height + lines - 1) / lines;
    threads = vsd_cpu_thread_count(threads);
    if (threads > MAX_THREADS) threads = MAX_THREADS;
    if (threads > job.chunk_count) threads = job.chunk_count;
    pthread_mutex_init(&job.mu, NULL);
    pthread_cond_init(&job.turn, NULL);
    memset(workers, 0, sizeof workers);
    for (i = 0; i < threads; i++) {
        exr_encode_pipeline_t init = EXR_ENCODE_PIPELINE_INITIALIZER;
        workers[i].enc = init;
        workers[i].job = &job;
    }
    /* this thread is worker 0; a thread that cannot start leaves its share to the others */
    for (i = 1; i < threads; i++)
        if (pthread_create(&tids[i], NULL, encode_worker, &workers[i]) == 0) running = i;
        else break;
    encode_worker(&workers[0]);
    for (i = 1; i <= running; i++) pthread_join(tids[i], NULL);
    pthread_cond_destroy(&job.turn);
    pthread_mutex_destroy(&job.mu);
    return job.rv;
}
