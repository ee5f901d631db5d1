/* Frame header packing and blocking socket I/O for protocol v1. */
#define _POSIX_C_SOURCE 200809L
#include "vsd_proto.h"
#include <errno.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <time.h>
#include <unistd.h>

const char *vsd_msg_name(unsigned type)
{
    static const char *const names[] = {NULL, "HELLO", "HAS", "PUT", "RENDER", "PROGRESS",
                                        "RESULT", "ERROR", "CANCEL", "STATS", "BYE"};
    return type < sizeof names / sizeof names[0] ? names[type] : NULL;
}

void vsd_proto_pack_header(const vsd_frame_header *h, unsigned char out[VSD_PROTO_HEADER_SIZE])
{
    int i;
    memcpy(out, VSD_PROTO_MAGIC, 4);
    out[4] = (unsigned char)(h->version >> 8);
    out[5] = (unsigned char)h->version;
    out[6] = (unsigned char)(h->type >> 8);
    out[7] = (unsigned char)h->type;
    for (i = 0; i < 4; i++) out[8 + i] = (unsigned char)(h->json_len >> (24 - 8 * i));
    for (i = 0; i < 8; i++) out[12 + i] = (unsigned char)(h->bin_len >> (56 - 8 * i));
}

int vsd_proto_unpack_header(const unsigned char in[VSD_PROTO_HEADER_SIZE], vsd_frame_header *h)
{
    int i;
    memset(h, 0, sizeof *h);
    if (memcmp(in, VSD_PROTO_MAGIC, 4) != 0) return -1;
    h->version = (uint16_t)((in[4] << 8) | in[5]);
    h->type = (uint16_t)((in[6] << 8) | in[7]);
    for (i = 0; i < 4; i++) h->json_len = (h->json_len << 8) | in[8 + i];
    for (i = 0; i < 8; i++) h->bin_len = (h->bin_len << 8) | in[12 + i];
    return 0;
}

static long long now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (long long)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

int vsd_proto_read_full(int fd, void *buf, size_t n, int timeout_ms)
{
    unsigned char *p = buf;
    size_t got = 0;
    long long deadline = timeout_ms >= 0 ? now_ms() + timeout_ms : 0;
    while (got < n) {
        ssize_t r;
        if (timeout_ms >= 0) {
            struct pollfd pfd;
            long long left = deadline - now_ms();
            int pr;
            if (left <= 0) return -2;
            pfd.fd = fd;
            pfd.events = POLLIN;
            pfd.revents = 0;
            pr = poll(&pfd, 1, (int)(left > 1000000 ? 1000000 : left));
            if (pr < 0) {
                if (errno == EINTR) continue;
                return -1;
            }
            if (pr == 0) return -2;
        }
        r = read(fd, p + got, n - got);
        if (r < 0) {
            if (errno == EINTR || errno == EAGAIN) continue;
            return -1;
        }
        if (r == 0) return got == 0 ? 1 : -1;
        got += (size_t)r;
    }
    return 0;
}

int vsd_proto_write_full(int fd, const void *buf, size_t n)
{
    const unsigned char *p = buf;
    while (n > 0) {
        ssize_t w = send(fd, p, n, MSG_NOSIGNAL);
        if (w < 0 && errno == ENOTSOCK) w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR) continue;
            return -1;
        }
        p += w;
        n -= (size_t)w;
    }
    return 0;
}

int vsd_proto_skip(int fd, uint64_t n, int timeout_ms)
{
    unsigned char buf[65536];
    while (n > 0) {
        size_t chunk = n > sizeof buf ? sizeof buf : (size_t)n;
        int r = vsd_proto_read_full(fd, buf, chunk, timeout_ms);
        if (r) return r > 0 ? -1 : r;
        n -= chunk;
    }
    return 0;
}

int vsd_proto_send(int fd, unsigned type, const char *json, size_t json_len, const void *bin, size_t bin_len)
{
    vsd_frame_header h;
    unsigned char hdr[VSD_PROTO_HEADER_SIZE];
    if (json_len > 0xffffffffu) return -1;
    h.version = VSD_PROTO_VERSION;
    h.type = (uint16_t)type;
    h.json_len = (uint32_t)json_len;
    h.bin_len = bin_len;
    vsd_proto_pack_header(&h, hdr);
    if (vsd_proto_write_full(fd, hdr, sizeof hdr)) return -1;
    if (json_len && vsd_proto_write_full(fd, json, json_len)) return -1;
    if (bin_len && vsd_proto_write_full(fd, bin, bin_len)) return -1;
    return 0;
}
