/* Little-endian field access for message bodies, byte by byte so the same
 * code is right on the AVR and on any host regardless of alignment. */
#ifndef VEHIL_PROTO_WIRE_H
#define VEHIL_PROTO_WIRE_H

#include <stdint.h>
#include <string.h>

static inline void put_u8(uint8_t *p, uint8_t v) { p[0] = v; }
static inline void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static inline void put_u32(uint8_t *p, uint32_t v)
{
    put_u16(p, (uint16_t)v);
    put_u16(p + 2, (uint16_t)(v >> 16));
}
static inline void put_i32(uint8_t *p, int32_t v) { put_u32(p, (uint32_t)v); }
/* float is IEEE-754 binary32 on both targets; only the byte order is fixed here. */
static inline void put_f32(uint8_t *p, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    put_u32(p, bits);
}

static inline uint8_t get_u8(const uint8_t *p) { return p[0]; }
static inline uint16_t get_u16(const uint8_t *p)
{
    return (uint16_t)(p[0] | ((uint16_t)p[1] << 8));
}
static inline uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)get_u16(p) | ((uint32_t)get_u16(p + 2) << 16);
}
static inline int32_t get_i32(const uint8_t *p) { return (int32_t)get_u32(p); }
static inline float get_f32(const uint8_t *p)
{
    uint32_t bits = get_u32(p);
    float v;
    memcpy(&v, &bits, sizeof v);
    return v;
}

#endif
