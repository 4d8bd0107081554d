#include "estimators/eso.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#include "fixmath/fixmath.h"
#include "proto/wire.h"

enum { P_T, P_EPS, P_VARIANT, P_DESIGN, P_ROAD_FROM, N_OWN };
#define N_PARAMS (N_OWN + SUSP_ECU_N_PARAMS)

static const ROM param_range_t ranges[N_OWN] = {
    {1e-4f, 0.05f, 30}, {0.001f, 2.0f, 24}, {0.0f, 1.0f, 0}, {0.0f, 1.0f, 0}, {0.0f, 1.0f, 0}};

/* -- float32 ------------------------------------------------------------- */

__attribute__((noinline)) static uint8_t step_f32(eso_state_t *st, const uint8_t *in, uint8_t *out)
{
    eso_f32_t *s = &st->u.f32;
    const qcar_f32_t *m = &s->ecu.model;
    float *z = s->z;
    float a_s = get_f32(in), a_us = get_f32(in + 4);
    uint8_t status = 0;
    if (!isfinite(a_s) || !isfinite(a_us)) {
        status = STATUS_NOT_FINITE; /* keep the state, report it again */
    } else {
        float y_s = accel_cond_step_f32(&s->ecu.cond, &s->ecu.ch[0], a_s);
        float y_us = accel_cond_step_f32(&s->ecu.cond, &s->ecu.ch[1], a_us);
        float e1 = y_s - z[0], e2 = y_us - z[3], u = s->ecu.u;
        float acc_s = z[2] + (u - s->fnl) / m->m_s; /* eq. 12, B-vectors 1/m_s, -1/m_us */
        float acc_us = z[5] + (s->fnl - u) / m->m_us;
        z[0] += s->T * z[1] + s->g[0] * e1;
        z[1] += s->T * acc_s + s->g[1] * e1;
        z[2] += s->g[2] * e1;
        z[3] += s->T * z[4] + s->g[0] * e2;
        z[4] += s->T * acc_us + s->g[1] * e2;
        z[5] += s->g[2] * e2;
    }
    float dx = z[0] - z[3], dv = z[1] - z[4];
    float fnl = qcar_strut_f32(m, dx, dv, 1);
    s->fnl = st->variant ? fnl : 0.0f;
    susp_est_f32_t est = {z[0], z[1], z[3], z[4], z[2] - s->fnl / m->m_s, z[5] + s->fnl / m->m_us,
                          0.0f};
    /* the strut force: the nominal strut at x̂, or the body's m_s ẍ_s = u - f (road_from) */
    float strut = st->road_from ? -m->m_s * est.F1 : fnl + m->k1 * dx + m->c1 * dv;
    est.x_r = est.x_us + (m->m_us * est.F2 - strut) / m->k_us;
    if (status == 0) {
        s->ecu.u = susp_ctrl_step_f32(&s->ecu.ctrl, &est, &status);
    }
    susp_ecu_put_f32(out, &est, s->ecu.u);
    return status;
}

/* -- fixed point --------------------------------------------------------- */

/* One observer, Euler (eq. 12): z Q28/Q24/Q20, y Q28, acceleration input acc Q20. */
static void observer_q(const fx_xfactor_t *k, int32_t *z, int32_t y, uint8_t *st, int32_t acc)
{
    int32_t e = fx_sub(y, z[0], st);
    int32_t z0 = fx_add(z[0], fx_mul_f(z[1], k[ESO_K_T].f, st), st);
    int32_t z1 = fx_add(z[1], fx_mul_f(acc, k[ESO_K_T].f, st), st);
    z[0] = fx_add(z0, fx_mul_f(e, k[ESO_K_G1].f, st), st);
    z[1] = fx_add(z1, fx_mul_f(e, k[ESO_K_G2].f, st), st);
    z[2] = fx_add(z[2], fx_mul_f(e, k[ESO_K_G3].f, st), st);
}

void eso_front_q_c(eso_q_t *s, const uint8_t *in, uint8_t *status)
{
    int32_t y_s = accel_cond_step_q_c(&s->ecu.cond, &s->ecu.ch[0], get_i32(in), status);
    int32_t y_us = accel_cond_step_q_c(&s->ecu.cond, &s->ecu.ch[1], get_i32(in + 4), status);
    observer_q(s->k, s->z + 3, y_us, status, s->model_in ? s->acc[1] : s->z[5]);
    observer_q(s->k, s->z, y_s, status, s->model_in ? s->acc[0] : s->z[2]);
}

#if defined(__AVR__)
#define eso_front_q(s, in, status) eso_front_q_avr(s, in, status, NULL, 0)
/* eso_avr.S reads eso_q_t at these offsets */
FX_ASM_LAYOUT(eso_model, offsetof(eso_q_t, ecu.model) == 33);
FX_ASM_LAYOUT(eso_r_m, offsetof(qcar_q_t, r_m_us) == 16 && offsetof(qcar_q_t, r_m_s) == 19);
FX_ASM_LAYOUT(eso_ctrl, offsetof(eso_q_t, ecu.ctrl) == 75 && offsetof(susp_ctrl_q_t, active) == 25);
FX_ASM_LAYOUT(eso_ch0, offsetof(eso_q_t, ecu.ch[0]) == 101);
FX_ASM_LAYOUT(eso_ch1, offsetof(eso_q_t, ecu.ch[1]) == 101 + 40);
FX_ASM_LAYOUT(eso_u, offsetof(eso_q_t, ecu.u) == 181);
FX_ASM_LAYOUT(eso_cond, offsetof(eso_q_t, ecu.cond) == 0);
FX_ASM_LAYOUT(eso_k, offsetof(eso_q_t, k) == 185 && sizeof(fx_xfactor_t) == 5);
FX_ASM_LAYOUT(eso_z, offsetof(eso_q_t, z) == 205);
FX_ASM_LAYOUT(eso_acc, offsetof(eso_q_t, acc) == 205 + 24);
FX_ASM_LAYOUT(eso_fnl, offsetof(eso_q_t, fnl) == 205 + 32);
FX_ASM_LAYOUT(eso_model_in, offsetof(eso_q_t, model_in) == 205 + 36);
#else
#define eso_front_q eso_front_q_c
#endif

/* The step after the front: the road, the controller, the outputs. */
static void back_q(eso_state_t *st, uint8_t *out, uint8_t *status)
{
    eso_q_t *s = &st->u.q;
    const qcar_q_t *m = &s->ecu.model;
    int32_t *z = s->z;
    int32_t dx = fx_sub(z[0], z[3], status), dv = fx_sub(z[1], z[4], status);
    susp_est_q_t est = {z[0], z[1], z[3], z[4], z[2], z[5], 0};
    s->fnl = st->variant ? qcar_strut_nl_q(m, dx, dv, status) : 0;
    if (st->variant) { /* variant B: the model's share leaves the lumped disturbances */
        est.F1 = fx_sub(z[2], fx_mul_f(s->fnl, m->inv_m_s, status), status);
        est.F2 = fx_add(z[5], fx_mul_f(s->fnl, m->inv_m_us, status), status);
    }
    /* x̂_r = x̂_us + (m_us F̂2 - strut)/k_us, each term over k_us in metres Q28 */
    int32_t x_r = fx_add(est.x_us, fx_mul_f(est.F2, m->r_m_us, status), status);
    if (st->road_from) { /* the strut from the body: -m_s F̂1 */
        x_r = fx_add(x_r, fx_mul_f(est.F1, m->r_m_s, status), status);
    } else { /* the nominal strut at x̂ */
        x_r = fx_sub(x_r, qcar_strut_over_kus_q(m, dx, dv, status), status);
    }
    est.x_r = x_r;
    s->ecu.u = susp_ctrl_step_q(&s->ecu.ctrl, &est, status);
    susp_ecu_put_q(out, &est, s->ecu.u);
}

__attribute__((flatten, noinline)) static uint8_t step_q(eso_state_t *st, const uint8_t *in, uint8_t *out)
{
    eso_q_t *s = &st->u.q;
    const qcar_q_t *m = &s->ecu.model;
    int32_t *z = s->z;
    uint8_t status = 0;
    if (s->model_in) { /* else u - f_nl stays 0: the front takes z3, z6 as they are */
        int32_t du = fx_sub(s->ecu.u, s->fnl, &status); /* N Q16 */
        s->acc[0] = fx_add(z[2], fx_mul_f(du, m->inv_m_s, &status), &status);
        s->acc[1] = fx_sub(z[5], fx_mul_f(du, m->inv_m_us, &status), &status);
    }
#if defined(__AVR__)
    if (!st->variant) { /* variant A: back_q's work in eso_avr.S too, in the front's frame */
        eso_front_q_avr(s, in, &status, out, st->road_from);
        return status;
    }
#endif
    eso_front_q(s, in, &status);
    back_q(st, out, &status);
    return status;
}

/* -- the estimator interface --------------------------------------------- */

static void eso_reset(void *state)
{
    eso_state_t *st = state;
    if (st->mode == MODE_F32) {
        susp_ecu_reset_f32(&st->u.f32.ecu);
        memset(st->u.f32.z, 0, sizeof st->u.f32.z);
        st->u.f32.fnl = 0.0f;
    } else {
        susp_ecu_reset_q(&st->u.q.ecu);
        memset(st->u.q.z, 0, sizeof st->u.q.z);
        st->u.q.fnl = 0;
    }
}

static uint8_t eso_configure(void *state, uint8_t mode, const uint8_t *params)
{
    eso_state_t *st = state;
    uint8_t bad = susp_ecu_check(params, mode, ranges, N_OWN);
    if (bad != 0) {
        return bad;
    }
    float T = param_value(params, P_T, mode, 30);
    float eps = param_value(params, P_EPS, mode, 24);
    /* design 1 puts the Euler loop's error poles at e^(-T/ε) (docs/estimators/eso.md) */
    float w = param_value(params, P_DESIGN, mode, 0) >= 0.5f ? (1.0f - expf(-T / eps)) / T
                                                            : 1.0f / eps;
    eso_f32_t f = {.T = T, .g = {T * 3.0f * w, T * 3.0f * w * w, T * w * w * w}};
    if (mode != MODE_F32 && (f.g[1] >= 2048.0f || f.g[2] >= 32768.0f)) {
        return P_EPS + 1u; /* T β2, T β3 past their Q20, Q16: a larger ε or T */
    }
    susp_ecu_configure_f32(&f.ecu, params, N_OWN, mode, T);
    st->mode = mode;
    st->variant = param_value(params, P_VARIANT, mode, 0) >= 0.5f;
    st->road_from = param_value(params, P_ROAD_FROM, mode, 0) >= 0.5f;
    if (mode == MODE_F32) {
        st->u.f32 = f;
    } else {
        uint8_t status = 0; /* the rule above keeps the gains' factors below 128 */
        eso_q_t *q = &st->u.q;
        bad = susp_ecu_q_from_f32(&q->ecu, &f.ecu);
        if (bad != 0) {
            return (uint8_t)(N_OWN + bad);
        }
        q->k[ESO_K_T] = fx_xfactor(T, 4, &status);
        q->k[ESO_K_G1] = fx_xfactor(f.g[0], 0, &status);
        q->k[ESO_K_G2] = fx_xfactor(f.g[1], -4, &status);
        q->k[ESO_K_G3] = fx_xfactor(f.g[2], -8, &status);
        q->model_in = q->ecu.ctrl.active || st->variant;
    }
    eso_reset(st);
    return 0;
}

static uint8_t eso_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                        uint8_t *out_len)
{
    eso_state_t *st = state;
    (void)in_len;
    *out_len = 4u * SUSP_ECU_N_OUTPUTS;
    return st->mode == MODE_F32 ? step_f32(st, in, out) : step_q(st, in, out);
}

const ROM estimator_t eso_estimator = {
    .id = ESO_ID,
    .name = "eso",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = 2,
    .n_outputs = SUSP_ECU_N_OUTPUTS,
    .n_params = N_PARAMS,
    .configure = eso_configure,
    .reset = eso_reset,
    .step = eso_step,
};
