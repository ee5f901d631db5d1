/* libFuzzer target for frame and message parsing (scripts/fuzz.sh builds and runs it; the
 * daemon's handlers themselves are fuzz_daemon.c). Feeds arbitrary bytes through the
 * header decoder, the JSON part parser and the field checks the daemon applies, and the
 * socket reader on a socket pair; ASan/UBSan must stay quiet. */
#include "vsd_proto.h"
#include <cjson/cJSON.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    vsd_frame_header h;
    int sv[2];
    if (size < VSD_PROTO_HEADER_SIZE) return 0;
    if (vsd_proto_unpack_header(data, &h) == 0) {
        size_t rest = size - VSD_PROTO_HEADER_SIZE;
        size_t jl = h.json_len < rest ? h.json_len : rest;
        cJSON *m = cJSON_ParseWithLength((const char *)data + VSD_PROTO_HEADER_SIZE, jl);
        (void)vsd_msg_name(h.type);
        if (m && cJSON_IsObject(m)) {
            const cJSON *hs = cJSON_GetObjectItemCaseSensitive(m, "hashes"), *it;
            const cJSON *hash = cJSON_GetObjectItemCaseSensitive(m, "hash");
            if (cJSON_IsArray(hs)) cJSON_ArrayForEach(it, hs) if (cJSON_IsString(it)) (void)vsd_hash_kind_of(it->valuestring);
            if (cJSON_IsString(hash)) (void)vsd_hash_kind_of(hash->valuestring);
        }
        cJSON_Delete(m);
    }
    /* the blocking reader on real bytes: never reads past what was written */
    if (size < 65536 && socketpair(AF_UNIX, SOCK_STREAM, 0, sv) == 0) {
        unsigned char hdr[VSD_PROTO_HEADER_SIZE];
        if (write(sv[0], data, size) == (ssize_t)size) {
            close(sv[0]);
            if (vsd_proto_read_full(sv[1], hdr, sizeof hdr, 100) == 0 && vsd_proto_unpack_header(hdr, &h) == 0)
                (void)vsd_proto_skip(sv[1], h.json_len, 100);
        } else {
            close(sv[0]);
        }
        close(sv[1]);
    }
    return 0;
}
