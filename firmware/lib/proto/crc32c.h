/* CRC-32C (Castagnoli: reflected polynomial 0x82F63B78, init and final xor
 * 0xFFFFFFFF), one byte at a time from a 1 KB table. On the AVR the table stays in
 * flash, split by byte, and the update is 13 instructions of assembly (21 cycles);
 * elsewhere it is the C below, which gives the same bits (every frame between the
 * board and the host's Python codec checks it). */
#ifndef VEHIL_PROTO_CRC32C_H
#define VEHIL_PROTO_CRC32C_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" { /* C linkage for C++ wrappers of vendored libraries */
#endif

#define CRC32C_INIT 0xFFFFFFFFu
#define CRC32C_XOROUT 0xFFFFFFFFu
/* The register after a frame's bytes followed by its own CRC (little-endian): a
 * receiver runs the CRC over everything it decodes and compares with this. */
#define CRC32C_RESIDUE 0xB798B438u

#if defined(__AVR__)
/* In program memory below 64 KB, which the linker keeps with the vectors, so LPM
 * reaches it without RAMPZ; byte k of entry i is crc32c_planes[k][i]. */
extern const uint8_t crc32c_planes[4][256] __attribute__((__progmem__));

static inline uint32_t crc32c_update(uint32_t crc, uint8_t byte)
{
    uint16_t z;
    __asm__("mov %A[z], %A[c]\n\t"
            "eor %A[z], %[b]\n\t"
            "ldi %B[z], hi8(%[t])\n\t"
            "lpm %A[c], Z\n\t"
            "eor %A[c], %B[c]\n\t"
            "inc %B[z]\n\t"
            "lpm %B[c], Z\n\t"
            "eor %B[c], %C[c]\n\t"
            "inc %B[z]\n\t"
            "lpm %C[c], Z\n\t"
            "eor %C[c], %D[c]\n\t"
            "inc %B[z]\n\t"
            "lpm %D[c], Z"
            : [c] "+r"(crc), [z] "=&z"(z)
            : [b] "r"(byte), [t] "i"(crc32c_planes));
    return crc;
}
#else
extern const uint32_t crc32c_table[256];

static inline uint32_t crc32c_update(uint32_t crc, uint8_t byte)
{
    return crc32c_table[(uint8_t)(crc ^ byte)] ^ (crc >> 8);
}
#endif

#ifdef __cplusplus
}
#endif

#endif
