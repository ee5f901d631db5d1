/* Protocol v1 building blocks: the frame header, hash names and values, socket I/O. */
#define _GNU_SOURCE
#include "test_common.h"
#include "vsd_proto.h"
#include <stdlib.h>
#include <sys/socket.h>
#include <unistd.h>

int main(void)
{
    unsigned char buf[VSD_PROTO_HEADER_SIZE];
    vsd_frame_header h = {1, VSD_MSG_RENDER, 0x01020304u, 0x0102030405060708ull}, g;
    char hex[VSD_HASH_HEX_MAX], hex2[VSD_HASH_HEX_MAX];
    int sv[2];

    /* header: big-endian, round trip, magic checked */
    vsd_proto_pack_header(&h, buf);
    CHECK(memcmp(buf, "VSDP\x00\x01\x00\x04\x01\x02\x03\x04\x01\x02\x03\x04\x05\x06\x07\x08", 20) == 0);
    CHECK(vsd_proto_unpack_header(buf, &g) == 0);
    CHECK(g.version == 1 && g.type == VSD_MSG_RENDER && g.json_len == h.json_len && g.bin_len == h.bin_len);
    buf[0] = 'X';
    CHECK(vsd_proto_unpack_header(buf, &g) == -1);
    CHECK(strcmp(vsd_msg_name(VSD_MSG_HELLO), "HELLO") == 0 && strcmp(vsd_msg_name(VSD_MSG_BYE), "BYE") == 0);
    CHECK(vsd_msg_name(0) == NULL && vsd_msg_name(11) == NULL && vsd_msg_name(65535) == NULL);

    /* hash names */
    CHECK(vsd_hash_kind_of("0123456789abcdef0123456789abcdef") == VSD_HASH_XXH3_128);
    CHECK(vsd_hash_kind_of("0123456789abcdef0123456789abcdef0123456789abcdef0123456789abcdef") == VSD_HASH_SHA256);
    CHECK(vsd_hash_kind_of("0123456789ABCDEF0123456789abcdef") == VSD_HASH_NONE);
    CHECK(vsd_hash_kind_of("../../../../etc/passwd") == VSD_HASH_NONE);
    CHECK(vsd_hash_kind_of("") == VSD_HASH_NONE && vsd_hash_kind_of(NULL) == VSD_HASH_NONE);
    CHECK(vsd_hash_kind_of("0123456789abcdef0123456789abcde") == VSD_HASH_NONE);

    /* SHA-256 test vectors (FIPS 180-2) */
    vsd_hash_buffer(VSD_HASH_SHA256, "abc", 3, hex);
    CHECK(strcmp(hex, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad") == 0);
    vsd_hash_buffer(VSD_HASH_SHA256, "", 0, hex);
    CHECK(strcmp(hex, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855") == 0);
    vsd_hash_buffer(VSD_HASH_SHA256, "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq", 56, hex);
    CHECK(strcmp(hex, "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1") == 0);
    {
        /* one million 'a', fed in odd-sized pieces */
        char *a = malloc(1000000);
        vsd_hasher *hs = vsd_hasher_new(VSD_HASH_SHA256);
        size_t off = 0, step = 1;
        memset(a, 'a', 1000000);
        while (off < 1000000) {
            size_t n = off + step > 1000000 ? 1000000 - off : step;
            vsd_hasher_update(hs, a + off, n);
            off += n;
            step = step * 3 + 1;
        }
        vsd_hasher_final(hs, hex);
        CHECK(strcmp(hex, "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0") == 0);
        /* XXH3-128: streaming equals one-shot; file equals buffer */
        hs = vsd_hasher_new(VSD_HASH_XXH3_128);
        vsd_hasher_update(hs, a, 12345);
        vsd_hasher_update(hs, a + 12345, 1000000 - 12345);
        vsd_hasher_final(hs, hex);
        vsd_hash_buffer(VSD_HASH_XXH3_128, a, 1000000, hex2);
        CHECK(strcmp(hex, hex2) == 0 && strlen(hex) == 32);
        {
            FILE *f = fopen(test_tmp("proto_blob.bin"), "wb");
            uint64_t size = 0;
            char err[256];
            fwrite(a, 1, 1000000, f);
            fclose(f);
            CHECK(vsd_hash_file(VSD_HASH_XXH3_128, test_tmp("proto_blob.bin"), hex2, &size, err, sizeof err) == 0);
            CHECK(strcmp(hex, hex2) == 0 && size == 1000000);
            CHECK(vsd_hash_file(VSD_HASH_XXH3_128, test_tmp("no_such_file.bin"), hex2, &size, err, sizeof err) == -1);
            CHECK_CONTAINS(err, "no_such_file.bin");
        }
        free(a);
    }
    /* XXH3-128 of "" is the library's well-known value */
    vsd_hash_buffer(VSD_HASH_XXH3_128, "", 0, hex);
    CHECK(strcmp(hex, "99aa06d3014798d86001c324468d497f") == 0);

    /* I/O: a frame through a socket pair; EOF before a frame = 1; EOF inside = -1; timeout = -2 */
    CHECK(socketpair(AF_UNIX, SOCK_STREAM, 0, sv) == 0);
    CHECK(vsd_proto_send(sv[0], VSD_MSG_HAS, "{\"id\":1}", 8, "xyz", 3) == 0);
    CHECK(vsd_proto_read_full(sv[1], buf, VSD_PROTO_HEADER_SIZE, 1000) == 0);
    CHECK(vsd_proto_unpack_header(buf, &g) == 0 && g.type == VSD_MSG_HAS && g.json_len == 8 && g.bin_len == 3);
    {
        char body[12];
        CHECK(vsd_proto_read_full(sv[1], body, 11, 1000) == 0 && memcmp(body, "{\"id\":1}xyz", 11) == 0);
    }
    CHECK(vsd_proto_read_full(sv[1], buf, 4, 50) == -2);
    CHECK(vsd_proto_write_full(sv[0], "ab", 2) == 0);
    close(sv[0]);
    CHECK(vsd_proto_read_full(sv[1], buf, 4, 1000) == -1);
    CHECK(vsd_proto_read_full(sv[1], buf, 4, 1000) == 1);
    close(sv[1]);
    return test_finish("test_protocol");
}
