#include "estimators/accel_cond.h"

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
    } else {
        c->alpha = 1.0f;
    }
}

static biquad_q_t biquad_to_q(const biquad_f32_t *b, uint8_t *status)
{
    return (biquad_q_t){fx_from_float(b->b0, 29, status), fx_from_float(b->a1, 29, status),
                        fx_from_float(b->a2, 29, status)};
}

void accel_cond_q_from_f32(accel_cond_q_t *q, const accel_cond_f32_t *c, uint8_t *status)
{
    q->hp = (hp_delta_q_t){fx_from_float(c->hp.g, 30, status), fx_from_float(c->hp.c2, 30, status),
                           fx_from_float(c->hp.c12, 30, status)};
    q->lp = biquad_to_q(&c->lp, status);
    q->half_T = fx_from_float(c->half_T, 30, status);
    q->alpha = fx_from_float(c->alpha, 30, status);
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

/* Direct form I, input ACCEL_QH, output Q20, each product rounded into Q20. x + 2 x1 + x2
 * reaches 4 times the input's range: it is summed two bits coarser (Q19, ±4,096 m/s²), in
 * int32 without overflow; b0 < 1 scales that rounding down. */
static int32_t biquad_q(const biquad_q_t *b, int32_t x, int32_t x1, int32_t x2, int32_t y1,
                        int32_t y2, uint8_t *s)
{
    int32_t sum = (x >> 2) + (x1 >> 1) + (x2 >> 2);
    int32_t y = fx_mul(b->b0, 29, sum, ACCEL_QH - 2, 20, s);
    y = fx_sub(y, fx_mul(b->a1, 29, y1, 20, 20, s), s);
    return fx_sub(y, fx_mul(b->a2, 29, y2, 20, 20, s), s);
}

int32_t accel_cond_step_q(const accel_cond_q_t *c, accel_chan_q_t *ch, int32_t a,
                          uint8_t *status)
{
    const hp_delta_q_t *hp = &c->hp;
    int32_t a20 = fx_rescale(a, 16, 20, status);
    int32_t d2 = fx_sub(fx_sub(a20, ch->x1, status), fx_sub(ch->x1, ch->x2, status), status);
    int32_t dh = fx_sub(ch->dh, fx_mul(hp->c2, 30, ch->dh, ACCEL_QH, ACCEL_QH, status), status);
    dh = fx_add(dh, fx_mul(hp->g, 30, d2, 20, ACCEL_QH, status), status);
    ch->dh = fx_sub(dh, fx_mul(hp->c12, 30, ch->h1, ACCEL_QH, ACCEL_QH, status), status);
    int32_t h = fx_add(ch->h1, ch->dh, status);
    int32_t l = biquad_q(&c->lp, h, ch->h1, ch->h2, ch->l1, ch->l2, status);
    int32_t dv = fx_mul(c->half_T, 30, fx_add(l, ch->l1, status), 20, 24, status);
    int32_t v = fx_mul(c->alpha, 30, fx_add(ch->v, dv, status), 24, 24, status);
    int32_t dx = fx_mul(c->half_T, 30, fx_add(v, ch->v, status), 24, 28, status);
    ch->x = fx_mul(c->alpha, 30, fx_add(ch->x, dx, status), 28, 28, status);
    ch->x2 = ch->x1, ch->x1 = a20;
    ch->l2 = ch->l1, ch->l1 = l;
    ch->h2 = ch->h1, ch->h1 = h;
    ch->v = v;
    return ch->x;
}
