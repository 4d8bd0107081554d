#include "estimators/manf.h"

#include <math.h>
#include <string.h>

#include "estimators/params.h"
#include "estimators/wheel_choice.h"
#include "fixmath/fixmath.h"
#include "proto/wire.h"

enum { P_T, P_RW, P_WHEEL, P_GAMMA, P_XI, P_RG0, P_A, P_SIGN, P_READING, P_TREF, P_EDB, N_PARAMS };

#define ONE_Q30 (INT32_C(1) << 30)
#define ONE_Q24 (INT32_C(1) << 24)

static const ROM param_range_t ranges[N_PARAMS] = {
    {1e-4f, 0.1f, 30},  {0.1f, 1.0f, 24}, {0.0f, 2.0f, 0}, {1.0f, 1.9f, 30}, {0.0f, 1.0f, 30},
    {0.0f, 100.0f, 24}, {0.1f, 100.0f, 24}, {0.0f, 1.0f, 0}, {0.0f, 1.0f, 0}, {0.0f, 1.0f, 30},
    {0.0f, 10.0f, 24},
};

#define GAMMA_MAX 1.9f /* R_g γ below 2^32 in FIXED's unsigned Q24 */
/* γ and ξ per sample: as given (t_ref = 0, the paper: eqs. 39-40 act per sample, or t_ref =
 * T, exactly), or rates per t_ref of time raised to T / t_ref, so the filter is the same at
 * any sample time (docs/estimators/manf.md). Returns whether they were raised. */
static uint8_t per_sample(const uint8_t *params, uint8_t mode, float *gamma, float *xi)
{
    *gamma = param_value(params, P_GAMMA, mode, 30);
    *xi = param_value(params, P_XI, mode, 30);
    float t_ref = param_value(params, P_TREF, mode, 30);
    float T = param_value(params, P_T, mode, 30);
    if (t_ref <= 0.0f || T == t_ref) {
        return 0;
    }
    *gamma = param_pow(*gamma, T / t_ref);
    *xi = param_pow(*xi, T / t_ref);
    return 1;
}

/* Eqs. 39-42: the gain follows the error's sign pattern. Returns the new sign memory. */
static int8_t adapt_sign(int8_t s_prev, int8_t s, uint8_t *grow)
{
    *grow = (s_prev != 0 && s != 0) ? (s == s_prev ? 2u : 1u) : 0u; /* 2 grow, 1 shrink, 0 keep */
    return s != 0 ? s : s_prev;
}

/* A float's bits: the comparisons below are integer ones (a float comparison is a ~60-cycle
 * library call on the AVR); for finite floats of the same sign they order as the values. */
static uint32_t bits_of(float x)
{
    uint32_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

static int8_t sign_f32(float x)
{
    uint32_t b = bits_of(x);
    return (b & 0x7fffffffu) == 0u ? 0 : (b & 0x80000000u) ? -1 : 1;
}

static uint8_t step_f32(manf_state_t *st, const uint8_t *in, uint8_t *out)
{
    const manf_params_f32_t *p = &st->u.f32.p;
    manf_f32_t *s = &st->u.f32.s;
    float w = wheel_choice_f32(st->wheel, get_f32(in), get_f32(in + 4));
    uint8_t status = 0;
    if (!isfinite(w)) {
        status = STATUS_NOT_FINITE;
    } else if (!st->started) {
        st->started = 1;
        s->v = p->r_w * w; /* v̂(0) = R ω(0) */
    } else {
        float e = s->v - p->r_w * w;
        uint8_t grow; /* an error within ±e_db carries no sign */
        int8_t sign = (bits_of(e) & 0x7fffffffu) > bits_of(p->e_db) ? sign_f32(e) : 0;
        st->s_prev = adapt_sign(st->s_prev, sign, &grow);
        if (grow == 2u) {
            s->rg *= p->gamma;
        } else if (grow == 1u) {
            s->rg *= p->xi;
        }
        uint32_t rg = bits_of(s->rg); /* R_g in [0, a] */
        s->rg = (rg & 0x80000000u) ? 0.0f : (rg > bits_of(p->a) ? p->a : s->rg);
        float step = s->rg * tanh_f32(e);
        if (!st->reading) {
            step *= p->T; /* reading B: R_g is an acceleration */
        }
        float dv = st->printed_sign ? step : -step;
        if ((bits_of(dv) & 0x7fffffffu) > bits_of(p->limit)) { /* |dv| > a T, eq. 43 */
            dv = sign_f32(dv) > 0 ? p->limit : -p->limit;
            status |= STATUS_CLAMPED;
        }
        s->v += dv;
    }
    put_f32(out, s->v);
    put_f32(out + 4, s->rg);
    return status;
}

/* T tanh |e| in Q23 for |e| in Q24: the CONFIG-time table of T tanh on tanh's grid (fixmath's
 * nodes, so the same interpolation error), one 16 × 16 product between two nodes. */
static inline uint32_t t_tanh(const manf_params_q_t *p, uint32_t mag_e)
{
    if (mag_e >= UINT32_C(64) << 20) {
        return p->t_tanh[64];
    }
    uint8_t k;
    uint16_t frac = fx_grid16_cell(mag_e, 24, &k);
    uint32_t lo = p->t_tanh[k];
    uint16_t d = (uint16_t)(p->t_tanh[k + 1u] - lo); /* <= 0.1 tanh(1/16) 2^23 + 1 < 2^16 */
    return lo + fx_round_q15(fx_umul16x16(d, frac));
}

static uint8_t step_q(manf_state_t *st, const uint8_t *in, uint8_t *out)
{
    const manf_params_q_t *p = &st->u.q.p;
    manf_q_t *s = &st->u.q.s;
    int32_t w = wheel_choice_q(st->wheel, get_i32(in), get_i32(in + 4)); /* Q16 */
    uint8_t status = 0;
    /* R ω in Q24, exact: r_w < 1 is a 24-bit factor, r_w = 1 a shift */
    int32_t v_w = p->r_w < ONE_Q24 ? fx_mul_q24_rs16(w, (uint32_t)p->r_w, &status)
                                   : fx_rescale(w, 16, 24, &status);
    if (!st->started) {
        st->started = 1;
        s->v = v_w;
    } else {
        int32_t e = fx_sub(s->v, v_w, &status); /* Q24 */
        uint32_t mag_e = e < 0 ? (uint32_t)0 - (uint32_t)e : (uint32_t)e;
        uint8_t grow; /* an error within ±e_db carries no sign */
        int8_t sign = mag_e > (uint32_t)p->e_db ? (e < 0 ? -1 : 1) : 0;
        st->s_prev = adapt_sign(st->s_prev, sign, &grow);
        /* R_g γ = R_g + R_g (γ - 1), R_g ξ = R_g - R_g (1 - ξ): R_g >= 0 always (R_g(0), γ
         * and ξ are), below 2^31 and R_g γ below 2^32, clamped to a next */
        uint32_t rg = (uint32_t)s->rg;
        if (grow == 2u && rg < (uint32_t)p->a) { /* at a, R_g γ clamps back to a */
            rg += fx_umul_q24(rg, p->gamma_m1);
        } else if (grow == 1u) {
            rg = p->xi_zero ? 0u : rg - fx_umul_q24(rg, p->one_m_xi);
        }
        if (rg > (uint32_t)p->a) {
            rg = (uint32_t)p->a;
        }
        s->rg = (int32_t)rg;
        /* The step's magnitude R_g T |tanh e| (reading A: R_g |tanh e|), Q24, then its sign:
         * T |tanh e| in Q24 is below 1 and R_g below 2^31, so it cannot saturate, and one
         * compare clamps it. */
        uint32_t step = st->reading ? fx_umul16_q15(rg, fx_tanh_abs_q15(mag_e, 24))
                                    : fx_umul_q24(rg, t_tanh(p, mag_e) << 1);
        if (step > (uint32_t)p->limit) {
            step = (uint32_t)p->limit;
            status |= STATUS_CLAMPED;
        }
        /* v̂ moves against the error (with the printed sign: along it) */
        s->v = (e < 0) == (st->printed_sign != 0) ? fx_sub(s->v, (int32_t)step, &status)
                                                  : fx_add(s->v, (int32_t)step, &status);
    }
    put_i32(out, fx_rescale(s->v, 24, 16, &status));
    put_i32(out + 4, s->rg);
    return status;
}

static void manf_reset(void *state)
{
    manf_state_t *st = state;
    st->started = 0;
    st->s_prev = 0;
    if (st->mode == MODE_F32) {
        st->u.f32.s = (manf_f32_t){.rg = st->u.f32.p.rg0};
    } else {
        st->u.q.s = (manf_q_t){.rg = st->u.q.p.rg0};
    }
}

static uint8_t manf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    manf_state_t *st = state;
    uint8_t bad = params_check(params, mode, ranges, N_PARAMS);
    if (bad != 0) {
        return bad;
    }
    float gamma, xi;
    uint8_t raised = per_sample(params, mode, &gamma, &xi);
    if (gamma > GAMMA_MAX * 1.000001f) { /* param_pow's last bits: 1.9 itself passes */
        return (uint8_t)(P_TREF + 1u); /* a rate per t_ref past 1.9 per sample */
    }
    st->mode = mode;
    st->wheel = (uint8_t)param_value(params, P_WHEEL, mode, 0);
    st->printed_sign = param_value(params, P_SIGN, mode, 0) >= 0.5f;
    st->reading = param_value(params, P_READING, mode, 0) >= 0.5f;
    if (mode == MODE_F32) {
        st->u.f32.p = (manf_params_f32_t){
            .T = get_f32(params + 4u * P_T),
            .r_w = get_f32(params + 4u * P_RW),
            .gamma = gamma,
            .xi = xi,
            .rg0 = get_f32(params + 4u * P_RG0),
            .a = get_f32(params + 4u * P_A),
            .e_db = get_f32(params + 4u * P_EDB),
        };
        st->u.f32.p.limit = st->u.f32.p.a * st->u.f32.p.T;
    } else {
        manf_params_q_t *p = &st->u.q.p;
        int32_t gamma_q = param_q(params, P_GAMMA), xi_q = param_q(params, P_XI);
        uint8_t sat = 0; /* cannot: γ <= 1.9, ξ <= 1, T <= 0.1 */
        if (raised) { /* the rates per sample, to Q30 */
            gamma_q = fx_from_float(gamma, 30, &sat);
            xi_q = fx_from_float(xi, 30, &sat);
        }
        uint32_t T = (uint32_t)fx_rescale(param_q(params, P_T), 30, 24, &sat);
        for (uint8_t k = 0; k <= 64u; k++) { /* tanh's nodes, Q15 << 8, times T: Q23 */
            uint32_t node = (uint32_t)fx_tanh_abs_q15((uint32_t)k << 20, 24) << 8;
            p->t_tanh[k] = fx_umul_q24(T, node);
        }
        p->gamma_m1 = (uint32_t)fx_rescale(gamma_q - ONE_Q30, 30, 24, &sat);
        p->one_m_xi = (uint32_t)fx_rescale(ONE_Q30 - xi_q, 30, 24, &sat);
        p->xi_zero = p->one_m_xi >= (uint32_t)ONE_Q24; /* ξ below 2^-25 zeroes R_g as 0 does */
        p->r_w = param_q(params, P_RW);
        p->rg0 = param_q(params, P_RG0);
        p->a = param_q(params, P_A);
        p->e_db = param_q(params, P_EDB);
        p->limit = (int32_t)fx_umul_q24((uint32_t)p->a, T); /* eq. 43 */
    }
    manf_reset(st);
    return 0;
}

static uint8_t manf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                         uint8_t *out_len)
{
    manf_state_t *st = state;
    (void)in_len;
    *out_len = 8;
    return st->mode == MODE_F32 ? step_f32(st, in, out) : step_q(st, in, out);
}

const ROM estimator_t manf_estimator = {
    .id = MANF_ID,
    .name = "manf",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = 2,
    .n_outputs = 2,
    .n_params = N_PARAMS,
    .configure = manf_configure,
    .reset = manf_reset,
    .step = manf_step,
};
