/* Constant tables in program memory. On the AVR, `ROM` puts a table in flash (the
 * linker places `.progmem*` with the vectors, below 64 KB, so LPM with a 16-bit Z
 * reaches it) and leaves SRAM to the estimators; elsewhere it is ordinary const data.
 * A table in flash is read only through these readers: on the AVR a plain load from
 * its address would read SRAM instead. The readers are LPM on the AVR and plain loads
 * elsewhere, so both builds see the same bits.
 *
 * Scalar tables are declared with ROM_TABLE, which wraps the array in a struct: a
 * direct `table[i]` does not compile, and ROM_AT(table, i) is the only way to the
 * element's address, which the readers take. Tables of structs (param_range_t) name
 * their fields so that they are read through their own accessors. */
#ifndef VEHIL_ROM_ROM_H
#define VEHIL_ROM_ROM_H

#include <stddef.h>
#include <stdint.h>

#if defined(__AVR__)
#define ROM __attribute__((__progmem__))
#else
#define ROM
#endif

/* `static const ROM ROM_TABLE(uint16_t, 65) name = {{...}};` */
#define ROM_TABLE(type, n) \
    struct {               \
        type in_rom[n];    \
    }
#define ROM_AT(table, i) (&(table).in_rom[(i)])

static inline uint8_t rom_u8(const uint8_t *p)
{
#if defined(__AVR__)
    uint8_t v;
    __asm__("lpm %0, Z" : "=r"(v) : "z"(p));
    return v;
#else
    return *p;
#endif
}

static inline uint16_t rom_u16(const uint16_t *p)
{
#if defined(__AVR__)
    uint16_t v;
    __asm__("lpm %A0, Z+\n\t"
            "lpm %B0, Z"
            : "=r"(v), "+z"(p));
    return v;
#else
    return *p;
#endif
}

static inline uint32_t rom_u32(const uint32_t *p)
{
#if defined(__AVR__)
    uint32_t v;
    __asm__("lpm %A0, Z+\n\t"
            "lpm %B0, Z+\n\t"
            "lpm %C0, Z+\n\t"
            "lpm %D0, Z"
            : "=r"(v), "+z"(p));
    return v;
#else
    return *p;
#endif
}

static inline int32_t rom_i32(const int32_t *p) { return (int32_t)rom_u32((const uint32_t *)p); }

static inline float rom_float(const float *p)
{
#if defined(__AVR__)
    union {
        uint32_t u;
        float f;
    } v;
    v.u = rom_u32((const uint32_t *)p);
    return v.f;
#else
    return *p;
#endif
}

/* A pointer stored in flash (a table of addresses). */
static inline const void *rom_ptr(const void *const *p)
{
#if defined(__AVR__)
    return (const void *)rom_u16((const uint16_t *)p);
#else
    return *p;
#endif
}

/* n bytes from flash to RAM. */
static inline void rom_copy(void *dst, const void *src, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    const uint8_t *s = (const uint8_t *)src;
    while (n-- > 0u) {
        *d++ = rom_u8(s++);
    }
}

#endif
