#include "estimators/accel_cond.h"

#include <stddef.h>

#include "fixmath/fixmath.h"

#define PI_F 3.14159265f
#define SQRT2_F 1.41421356f

const ROM param_range_t accel_cond_ranges[ACCEL_COND_N_PARAMS] = {
    {0.01f, 10.0f, 24}, {1.0f, 45.0f, 24}, {0.0f, 5.0f, 24}};

/* tan x for |x| < pi/2 by Lambert's continued fraction (8 levels: < 1e-9 at x = 1). */
static float tan_cf(float x)
{
    float x2 = x * x, d = 17.0f;
    for (int8_t k = 15; k >= 1; k -= 2) {
        d = (float)k - x2 / d;
    }
    return x / d;
}

biquad_f32_t butter2_lp(float fc, float T)
{
    float k = tan_cf(PI_F * fc * T);
    float norm = 1.0f / (1.0f + SQRT2_F * k + k * k);
    float b0 = k * k * norm;
    return (biquad_f32_t){b0, 2.0f * b0, 2.0f * (k * k - 1.0f) * norm,
                          (1.0f - SQRT2_F * k + k * k) * norm};
}

static hp_delta_f32_t butter2_hp(float fc, float T)
{
    float k = tan_cf(PI_F * fc * T);
    float g = 1.0f / (1.0f + SQRT2_F * k + k * k);
    return (hp_delta_f32_t){g, 2.0f * SQRT2_F * k * g, 4.0f * k * k * g};
}

void accel_cond_design_f32(accel_cond_f32_t *c, const uint8_t *params, uint8_t first,
                           uint8_t mode, float T)
{
    float f_hp = param_value(params, first, mode, 24);
    float f_lp = param_value(params, (uint8_t)(first + 1u), mode, 24);
    float f_post = param_value(params, (uint8_t)(first + 2u), mode, 24);
    c->hp = butter2_hp(f_hp, T);
    c->lp = butter2_lp(f_lp, T);
    c->half_T = 0.5f * T;
    if (f_post > 0.0f) {
        float rc = 1.0f / (2.0f * PI_F * f_post);
        c->alpha = rc / (rc + T);
        c->one_m_alpha = T / (rc + T); /* not 1 - α: α's rounding would be most of it */
    } else {
        c->alpha = 1.0f;
        c->one_m_alpha = 0.0f;
    }
}

uint8_t accel_cond_q_from_f32(accel_cond_q_t *q, const accel_cond_f32_t *c, uint8_t *status)
{
    if (c->hp.c12 >= 1.0f) {
        return 1u; /* f_hp T past ~0.22: c12 does not fit its Q32 */
    }
    /* c2 < 0.83 at any corner; both below 1, as 24 and 32 fraction bits (docs/estimators/eso.md) */
    q->hp = (hp_delta_q_t){(uint32_t)(c->hp.c2 * 16777216.0f + 0.5f),
                           (uint32_t)(c->hp.c12 * 4294967296.0f + 0.5f)};
    /* the poles as their distances from a1 = -2, a2 = 1 (a double pole at z = 1), which
     * keep 16 bits where the poles near 1 need them; b0 from the poles as kept, so that the
     * DC gain stays 1 */
    fx_xfactor_t p1 = fx_xfactor(c->lp.a1 + 2.0f, 0, status);
    fx_xfactor_t p2 = fx_xfactor(1.0f - c->lp.a2, 0, status);
    float b0 = 0.25f * (fx_factor_value(p1.f) - fx_factor_value(p2.f));
    /* the high-pass runs on h/g: its g goes into the low-pass's b0, and so does the first
     * trapezoid's β, so that the low-pass gives β l, the velocity's increment */
    float beta = c->alpha * c->half_T;
    q->lp = (biquad_q_t){fx_xfactor(b0 * c->hp.g * beta, 26 - (ACCEL_QH - 2), status), p1, p2};
    q->beta = fx_xfactor(beta, 2, status);
    q->gamma = fx_xfactor(c->one_m_alpha, 0, status);
    return 0u;
}

static float biquad_f32(const biquad_f32_t *b, float x, float x1, float x2, float y1, float y2)
{
    return b->b0 * x + b->b1 * x1 + b->b0 * x2 - b->a1 * y1 - b->a2 * y2;
}

float accel_cond_step_f32(const accel_cond_f32_t *c, accel_chan_f32_t *ch, float a)
{
    const hp_delta_f32_t *hp = &c->hp;
    ch->dh = (1.0f - hp->c2) * ch->dh + hp->g * ((a - ch->x1) - (ch->x1 - ch->x2)) - hp->c12 * ch->h1;
    float h = ch->h1 + ch->dh;
    float l = biquad_f32(&c->lp, h, ch->h1, ch->h2, ch->l1, ch->l2);
    /* Trapezoid, then the high-pass y = α (y1 + s - s1): only the increment s - s1 is kept. */
    float v = c->alpha * (ch->v + c->half_T * (l + ch->l1));
    ch->x = c->alpha * (ch->x + c->half_T * (v + ch->v));
    ch->x2 = ch->x1, ch->x1 = a;
    ch->l2 = ch->l1, ch->l1 = l;
    ch->h2 = ch->h1, ch->h1 = h;
    ch->v = v;
    return ch->x;
}

/* Direct form I, input ACCEL_QH, output Q26 (β l, m/s), each product rounded into Q26, the
 * poles as y = b0 (x + 2 x1 + x2) + 2 y1 - y2 - p1 y1 + p2 y2 (a1 = p1 - 2, a2 = 1 - p2). x + 2 x1 + x2
 * reaches 4 times the input's range: it is summed two bits coarser (Q19, ±4,096 m/s²), in
 * int32 without overflow; b0 β < 1 scales that rounding down. */
static int32_t biquad_q(const biquad_q_t *b, int32_t x, int32_t x1, int32_t x2, int32_t y1,
                        int32_t y2, uint8_t *s)
{
    int32_t sum = (x >> 2) + (x1 >> 1) + (x2 >> 2);
    int32_t y = fx_add(fx_mul_f(sum, b->b0.f, s), fx_sub(y1, y2, s), s);
    y = fx_add(y, fx_sub(y1, fx_mul_f(y1, b->p1.f, s), s), s);
    return fx_add(y, fx_mul_f(y2, b->p2.f, s), s);
}

#if defined(__AVR__)
/* accel_cond_avr.S reads the structs at these offsets */
FX_ASM_OFFSET(accel_chan_q_t, x1, 0);
FX_ASM_OFFSET(accel_chan_q_t, x2, 4);
FX_ASM_OFFSET(accel_chan_q_t, l1, 8);
FX_ASM_OFFSET(accel_chan_q_t, l2, 12);
FX_ASM_OFFSET(accel_chan_q_t, h1, 16);
FX_ASM_OFFSET(accel_chan_q_t, h2, 20);
FX_ASM_OFFSET(accel_chan_q_t, dh, 24);
FX_ASM_OFFSET(accel_chan_q_t, v, 28);
FX_ASM_OFFSET(accel_chan_q_t, x, 32);
FX_ASM_OFFSET(accel_chan_q_t, h1_lo, 36);
FX_ASM_OFFSET(accel_chan_q_t, dh_lo, 38);
FX_ASM_OFFSET(accel_cond_q_t, hp, 0);
FX_ASM_OFFSET(accel_cond_q_t, lp, 8);
FX_ASM_OFFSET(accel_cond_q_t, beta, 23);
FX_ASM_OFFSET(accel_cond_q_t, gamma, 28);
FX_ASM_OFFSET(hp_delta_q_t, c12, 4);
FX_ASM_OFFSET(biquad_q_t, p1, 5);
FX_ASM_OFFSET(biquad_q_t, p2, 10);
FX_ASM_OFFSET(fx_xfactor_t, entry, 3);
FX_ASM_OFFSET(fx_factor_t, sh, 2);
#endif

/* The high-pass's Q37 values (ACCEL_QH with 16 bits below) are 48-bit: a saturating add
 * clamps to ±2^47 and flags, as fx_add does at 2^31. */
#define Q37_MAX (((int64_t)1 << 47) - 1)

static int64_t add_q37(int64_t a, int64_t b, uint8_t *status)
{
    int64_t r = a + b;
    if (r > Q37_MAX || r < -Q37_MAX - 1) {
        *status |= STATUS_SATURATED;
        return r > 0 ? Q37_MAX : -Q37_MAX - 1;
    }
    return r;
}

/* -a c 2^-drop, rounded to Q37 with ties away from zero: a (ACCEL_QH) times c (Q24 or Q32,
 * below 1) leaves 2^-drop of Q37's unit. |a c| < 2^63, and the result's magnitude < 2^47. */
static int64_t neg_mul_q37(int32_t a, uint32_t c, uint8_t drop)
{
    uint64_t m = (uint64_t)(a < 0 ? 0u - (uint32_t)a : (uint32_t)a) * c;
    int64_t r = (int64_t)((m + ((uint64_t)1 << (drop - 1u))) >> drop);
    return a < 0 ? r : -r;
}

int32_t accel_cond_step_q_c(const accel_cond_q_t *c, accel_chan_q_t *ch, int32_t a,
                            uint8_t *status)
{
    const hp_delta_q_t *hp = &c->hp;
    int32_t d2 = fx_sub(fx_sub(a, ch->x1, status), fx_sub(ch->x1, ch->x2, status), status);
    /* dh <- dh - dh c2 + d2 - h1 c12 and h = h1 + dh in Q37; c2's operand is dh rounded to
     * ACCEL_QH, c12's h1 as it is (their roundings enter c2 and c12 times smaller) */
    int64_t dh = (int64_t)ch->dh * 65536 + ch->dh_lo;
    dh = add_q37(dh, neg_mul_q37(fx_add(ch->dh, ch->dh_lo >> 15, status), hp->c2, 8), status);
    dh = add_q37(dh, (int64_t)fx_rescale(d2, 16, ACCEL_QH, status) * 65536, status);
    dh = add_q37(dh, neg_mul_q37(ch->h1, hp->c12, 16), status);
    int64_t h = add_q37((int64_t)ch->h1 * 65536 + ch->h1_lo, dh, status);
    ch->dh = (int32_t)(dh >> 16), ch->dh_lo = (uint16_t)dh;
    int32_t h21 = (int32_t)(h >> 16); /* ACCEL_QH, its bits below dropped (floor) */
    int32_t l = biquad_q(&c->lp, h21, ch->h1, ch->h2, ch->l1, ch->l2, status);
    int32_t v = fx_add(ch->v, fx_add(l, ch->l1, status), status);
    v = fx_sub(v, fx_mul_f(ch->v, c->gamma.f, status), status);
    int32_t x = fx_add(ch->x, fx_mul_f(fx_add(v, ch->v, status), c->beta.f, status), status);
    ch->x = fx_sub(x, fx_mul_f(ch->x, c->gamma.f, status), status);
    ch->x2 = ch->x1, ch->x1 = a;
    ch->l2 = ch->l1, ch->l1 = l;
    ch->h2 = ch->h1, ch->h1 = h21, ch->h1_lo = (uint16_t)h;
    ch->v = v;
    return ch->x;
}
