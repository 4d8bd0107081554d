#include "estimators/anf.h"

#include <math.h>

#include "estimators/params.h"
#include "estimators/wheel_choice.h"
#include "fixmath/fixmath.h"
#include "proto/wire.h"

enum { P_T, P_RW, P_WHEEL, P_RG, N_PARAMS };

static const ROM param_range_t ranges[N_PARAMS] = {
    {1e-4f, 0.1f, 30}, {0.1f, 1.0f, 24}, {0.0f, 2.0f, 0}, {0.0f, 100.0f, 24},
};

static uint8_t step_f32(anf_state_t *st, const uint8_t *in, uint8_t *out)
{
    float w = wheel_choice_f32(st->wheel, get_f32(in), get_f32(in + 4));
    uint8_t status = 0;
    if (!isfinite(w)) {
        status = STATUS_NOT_FINITE; /* hold v̂ */
    } else {
        float v_w = st->u.f32.r_w * w;
        if (!st->started) {
            st->started = 1;
            st->u.f32.v = v_w;
        } else if (st->u.f32.v > v_w) {
            st->u.f32.v -= st->u.f32.step;
        } else if (st->u.f32.v < v_w) {
            st->u.f32.v += st->u.f32.step;
        }
    }
    put_f32(out, st->u.f32.v);
    return status;
}

static uint8_t step_q(anf_state_t *st, const uint8_t *in, uint8_t *out)
{
    int32_t w = wheel_choice_q(st->wheel, get_i32(in), get_i32(in + 4)); /* Q16 */
    uint8_t status = 0;
    int32_t v_w = fx_mul(st->u.q.r_w, 24, w, 16, 24, &status); /* Q24 */
    if (!st->started) {
        st->started = 1;
        st->u.q.v = v_w;
    } else if (st->u.q.v > v_w) {
        st->u.q.v = fx_sub(st->u.q.v, st->u.q.step, &status);
    } else if (st->u.q.v < v_w) {
        st->u.q.v = fx_add(st->u.q.v, st->u.q.step, &status);
    }
    put_i32(out, fx_rescale(st->u.q.v, 24, 16, &status));
    return status;
}

static void anf_reset(void *state)
{
    ((anf_state_t *)state)->started = 0;
}

static uint8_t anf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    anf_state_t *st = state;
    uint8_t bad = params_check(params, mode, ranges, N_PARAMS);
    if (bad != 0) {
        return bad;
    }
    st->mode = mode;
    st->wheel = (uint8_t)param_value(params, P_WHEEL, mode, 0);
    if (mode == MODE_F32) {
        st->u.f32.r_w = get_f32(params + 4u * P_RW);
        st->u.f32.step = get_f32(params + 4u * P_T) * get_f32(params + 4u * P_RG);
    } else {
        uint8_t sat = 0; /* never set: T <= 0.1 s and R_g <= 100 m/s², so T R_g <= 10 m/s */
        st->u.q.r_w = param_q(params, P_RW);
        st->u.q.step = fx_mul(param_q(params, P_T), 30, param_q(params, P_RG), 24, 24, &sat);
    }
    anf_reset(st);
    return 0;
}

static uint8_t anf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                        uint8_t *out_len)
{
    anf_state_t *st = state;
    (void)in_len;
    *out_len = 4;
    return st->mode == MODE_F32 ? step_f32(st, in, out) : step_q(st, in, out);
}

const ROM estimator_t anf_estimator = {
    .id = ANF_ID,
    .name = "anf",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = 2,
    .n_outputs = 1,
    .n_params = N_PARAMS,
    .configure = anf_configure,
    .reset = anf_reset,
    .step = anf_step,
};
