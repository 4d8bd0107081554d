/* A minimal Arduino.h for vendored libraries written for the Arduino core that need only
 * its types, constants and math macros (docs/extending.md, "A library you did not
 * write"): the same source then compiles for the chip and for the host. There is no
 * clock, no I/O and no Serial: an estimator takes its time from its sample time and its
 * data from its step. A library that calls millis(), micros() or delay() fails to build,
 * saying so.
 *
 * The constants are float literals: on the AVR double is float, so the Arduino core's
 * double literals compute in float32 there; written as float here they compute the same
 * way on the host, which keeps the native board the chip's twin. */
#ifndef VEHIL_ARDUINO_SHIM_H
#define VEHIL_ARDUINO_SHIM_H

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef uint8_t byte;
typedef bool boolean;
typedef uint16_t word;

#define HIGH 0x1
#define LOW 0x0

#define PI 3.1415926535897932384626433832795f
#define HALF_PI 1.5707963267948966192313216916398f
#define TWO_PI 6.283185307179586476925286766559f
#define DEG_TO_RAD 0.017453292519943295769236907684886f
#define RAD_TO_DEG 57.295779513082320876798154814105f
#define EULER 2.718281828459045235360287471352f

/* As the Arduino core has them: macros, each argument evaluated twice. */
#ifdef abs
#undef abs
#endif
#define min(a, b) ((a) < (b) ? (a) : (b))
#define max(a, b) ((a) > (b) ? (a) : (b))
#define abs(x) ((x) > 0 ? (x) : -(x))
#define constrain(amt, low, high) ((amt) < (low) ? (low) : ((amt) > (high) ? (high) : (amt)))
#define round(x) ((x) >= 0 ? (long)((x) + 0.5f) : (long)((x) - 0.5f))
#define radians(deg) ((deg) * DEG_TO_RAD)
#define degrees(rad) ((rad) * RAD_TO_DEG)
#define sq(x) ((x) * (x))

#define lowByte(w) ((uint8_t)((w) & 0xff))
#define highByte(w) ((uint8_t)((w) >> 8))
#define bitRead(value, bit) (((value) >> (bit)) & 0x01)
#define bitSet(value, bit) ((value) |= (1UL << (bit)))
#define bitClear(value, bit) ((value) &= ~(1UL << (bit)))
#define bitToggle(value, bit) ((value) ^= (1UL << (bit)))
#define bitWrite(value, bit, bitvalue) ((bitvalue) ? bitSet(value, bit) : bitClear(value, bit))
#define bit(b) (1UL << (b))

/* long, as the core's: 32 bits on the AVR, 64 on most hosts; the sums fit in both. */
static inline long map(long x, long in_min, long in_max, long out_min, long out_max)
{
    return (x - in_min) * (out_max - out_min) / (in_max - in_min) + out_min;
}

/* Declared so that a call names the problem instead of an undefined symbol. */
#define VEHIL_NO_CLOCK __attribute__((error( \
    "an estimator has no clock: take time from the sample time parameter (docs/extending.md)")))
unsigned long millis(void) VEHIL_NO_CLOCK;
unsigned long micros(void) VEHIL_NO_CLOCK;
void delay(unsigned long ms) VEHIL_NO_CLOCK;
void delayMicroseconds(unsigned int us) VEHIL_NO_CLOCK;

#ifdef __cplusplus
}
#endif

#endif
