/* Reference receiver of the vision box <-> arm controller protocol, version 1 (arm/PROTOCOL.md).
 *
 * Plain C99, no allocation: arm_feed() takes one byte at a time (e.g. from the UART interrupt)
 * and returns ARM_FRAME when a frame with a good CRC is complete, or a negative ARM_E_* code
 * (the NACK reason) when a frame was rejected. The message fields are then read with the
 * little-endian helpers rd_u16/rd_i16/... from dec->body + ARM_HEADER.
 *
 * Built as a program it reads hex strings (one or more frames per line) on stdin and prints
 * one line per frame; tests/arm/test_reference_c.py checks it against the test vectors.
 *   cc -std=c99 -O2 -Wall -o arm_decode arm/reference/arm_decode.c
 */
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#define ARM_VERSION 1
#define ARM_HEADER 6
#define ARM_MAX_PAYLOAD 4096
#define ARM_MAX_ENCODED (ARM_HEADER + ARM_MAX_PAYLOAD + 2 + (ARM_HEADER + ARM_MAX_PAYLOAD + 2) / 254 + 1)

enum { ARM_NONE = 0, ARM_FRAME = 1 };
enum { ARM_E_CRC = -1, ARM_E_FRAME = -2, ARM_E_TYPE = -3, ARM_E_VERSION = -4, ARM_E_LENGTH = -5 };
enum { T_HELLO = 0x01, T_OBSTACLES = 0x02, T_HEARTBEAT = 0x03, T_ACK = 0x10, T_NACK = 0x11 };

typedef struct {
    uint8_t enc[ARM_MAX_ENCODED];           /* bytes since the last 0x00 */
    size_t n_enc;
    int overflow;
    uint8_t body[ARM_HEADER + ARM_MAX_PAYLOAD + 2]; /* decoded header + payload + crc */
    size_t n_body;
    uint8_t type;
    uint16_t seq, length;                   /* header fields of the last frame */
} arm_decoder;

static uint16_t rd_u16(const uint8_t *p) { return (uint16_t)(p[0] | p[1] << 8); }
static int16_t rd_i16(const uint8_t *p) { return (int16_t)rd_u16(p); }
static uint32_t rd_u32(const uint8_t *p) { return (uint32_t)rd_u16(p) | (uint32_t)rd_u16(p + 2) << 16; }
static uint64_t rd_u64(const uint8_t *p) { return (uint64_t)rd_u32(p) | (uint64_t)rd_u32(p + 4) << 32; }

uint16_t crc16_ccitt_false(const uint8_t *p, size_t n) {
    uint16_t crc = 0xFFFF;
    while (n--) {
        crc ^= (uint16_t)(*p++) << 8;
        for (int i = 0; i < 8; i++)
            crc = (crc & 0x8000) ? (uint16_t)((crc << 1) ^ 0x1021) : (uint16_t)(crc << 1);
    }
    return crc;
}

/* COBS-decode n bytes (no 0x00 among them) into out; returns the decoded length or -1. */
static long cobs_decode(const uint8_t *in, size_t n, uint8_t *out, size_t cap) {
    size_t i = 0, o = 0;
    while (i < n) {
        uint8_t code = in[i];
        if (code == 0 || i + code > n || o + code > cap + 1) return -1;
        memcpy(out + o, in + i + 1, code - 1u);
        o += code - 1u;
        i += code;
        if (code < 0xFF && i < n) {
            if (o >= cap) return -1;
            out[o++] = 0;
        }
    }
    return (long)o;
}

static int payload_size_ok(uint8_t type, const uint8_t *p, uint16_t len) {
    switch (type) {
    case T_HELLO: return len >= 4 && len == 4 + p[3];
    case T_OBSTACLES: return len >= 18 && len == 18 + 20 * rd_u16(p + 14);
    case T_HEARTBEAT: return len == 16;
    case T_ACK: return len == 2;
    case T_NACK: return len == 3;
    default: return 0;
    }
}

/* Feed one byte; ARM_FRAME: dec->type/seq/length/body hold a checked frame; < 0: rejected. */
int arm_feed(arm_decoder *dec, uint8_t byte) {
    if (byte != 0) {
        if (dec->n_enc < sizeof dec->enc) dec->enc[dec->n_enc++] = byte;
        else dec->overflow = 1;
        return ARM_NONE;
    }
    size_t n = dec->n_enc;
    int overflow = dec->overflow;
    dec->n_enc = 0;
    dec->overflow = 0;
    dec->seq = 0xFFFF;
    if (overflow) return ARM_E_LENGTH;
    if (n == 0) return ARM_NONE;                       /* empty frame: ignored */
    long m = cobs_decode(dec->enc, n, dec->body, sizeof dec->body);
    if (m < ARM_HEADER + 2) return ARM_E_FRAME;
    dec->n_body = (size_t)m;
    if (crc16_ccitt_false(dec->body, dec->n_body - 2) != rd_u16(dec->body + dec->n_body - 2)) return ARM_E_CRC;
    dec->type = dec->body[1];
    dec->seq = rd_u16(dec->body + 2);
    dec->length = rd_u16(dec->body + 4);
    if (dec->body[0] != ARM_VERSION) return ARM_E_VERSION;
    if (dec->length != dec->n_body - ARM_HEADER - 2) return ARM_E_LENGTH;
    if (dec->type != T_HELLO && dec->type != T_OBSTACLES && dec->type != T_HEARTBEAT && dec->type != T_ACK
        && dec->type != T_NACK)
        return ARM_E_TYPE;
    if (!payload_size_ok(dec->type, dec->body + ARM_HEADER, dec->length)) return ARM_E_LENGTH;
    return ARM_FRAME;
}

#ifndef ARM_DECODE_NO_MAIN
static void mm3(const uint8_t *p) {
    printf("%.2f,%.2f,%.2f", rd_i16(p) / 4.0, rd_i16(p + 2) / 4.0, rd_i16(p + 4) / 4.0);
}

static void print_frame(const arm_decoder *d) {
    const uint8_t *p = d->body + ARM_HEADER;
    printf("seq=%u ", d->seq);
    switch (d->type) {
    case T_HELLO:
        printf("HELLO protocol_version=%u lsb_um=%u app_version=%.*s", p[0], rd_u16(p + 1), p[3],
               (const char *)p + 4);
        break;
    case T_OBSTACLES:
        printf("OBSTACLES stamp_ns=%llu frame_seq=%lu flags=%u count=%u total=%u",
               (unsigned long long)rd_u64(p), (unsigned long)rd_u32(p + 8), p[12], rd_u16(p + 14), rd_u16(p + 16));
        for (unsigned i = 0; i < rd_u16(p + 14); i++) {
            const uint8_t *s = p + 18 + 20 * i;
            printf(" [p0=");
            mm3(s);
            printf(" p1=");
            mm3(s + 6);
            printf(" r=%.2f c=%.2f id=%u f=%u]", rd_u16(s + 12) / 4.0, rd_u16(s + 14) / 4.0, rd_u16(s + 16), s[18]);
        }
        break;
    case T_HEARTBEAT:
        printf("HEARTBEAT stamp_ns=%llu flags=%u rate_hz=%.2f dropped=%lu", (unsigned long long)rd_u64(p), p[8],
               rd_u16(p + 10) / 100.0, (unsigned long)rd_u32(p + 12));
        break;
    case T_ACK: printf("ACK seq=%u", rd_u16(p)); break;
    case T_NACK: printf("NACK seq=%u reason=%u", rd_u16(p), p[2]); break;
    }
    printf("\n");
}

static int hexval(int c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

int main(void) {
    static arm_decoder dec;
    int c, hi = -1;
    while ((c = getchar()) != EOF) {
        int v = hexval(c);
        if (v < 0) continue;
        if (hi < 0) { hi = v; continue; }
        int r = arm_feed(&dec, (uint8_t)(hi << 4 | v));
        hi = -1;
        if (r == ARM_FRAME) print_frame(&dec);
        else if (r < 0) printf("error=%d seq=%u\n", -r, dec.seq);
    }
    return 0;
}
#endif
