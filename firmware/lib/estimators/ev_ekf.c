#include "estimators/ev_ekf.h"

#include "linalg/mat_f32.h"
#include "proto/wire.h"

static const ROM param_range_t own_ranges[EV_N_FORCE_PARAMS] = {EV_FORCE_RANGES};

static void ev_ekf_reset(void *state)
{
    ev_ekf_state_t *s = state;
    ev_model_reset(&s->model);
    ev_prior(&s->model, EV_NX, s->p0_f, s->x, s->P);
    s->started = 0;
}

static uint8_t ev_ekf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    ev_ekf_state_t *s = state;
    uint8_t bad = ev_model_configure(&s->model, mode, params, own_ranges, EV_N_FORCE_PARAMS);
    if (bad != 0u) {
        return bad;
    }
    s->p0_f = get_f32(params + 4u * (EV_N_PARAMS + EV_PF_P0F));
    s->q_f = get_f32(params + 4u * (EV_N_PARAMS + EV_PF_QF));
    ev_ekf_reset(s);
    return 0;
}

static void predict(ev_ekf_state_t *s)
{
    const float *p = s->model.p;
    ev_wheels_t w;
    ev_slopes_t d;
    ev_wheels(s->x, &s->u_prev, &s->model, &w);
    ev_slopes(&s->u_prev, &s->model, &w, &d);
    ev_jacobians(&s->model, s->x, &s->u_prev, &w, &d, s->F, NULL);
    ev_step(&s->model, s->x, &s->u_prev, &w);
    mat_mul_f32(s->F, s->P, EV_NX, EV_NX, EV_NX, s->tmp);
    mat_mul_bt_f32(s->tmp, s->F, EV_NX, EV_NX, EV_NX, s->P);
    const float q[3] = {p[EV_P_QV], p[EV_P_QVY], p[EV_P_QR]};
    for (uint8_t i = 0; i < EV_NX; i++) {
        s->P[i * EV_NX + i] += i < 3u ? q[i] : s->q_f;
    }
}

static void update(ev_ekf_state_t *s, const ev_inputs_t *u)
{
    float r[EV_NY], e[EV_NY];
    float *H = s->F;
    ev_wheels_t w;
    ev_slopes_t d;
    ev_wheels(s->x, u, &s->model, &w);
    ev_slopes(u, &s->model, &w, &d);
    ev_noise(&s->model, u, &w, r);
    ev_jacobians(&s->model, s->x, u, &w, &d, NULL, H);
    ev_h(&s->model, s->x, s->x + 3, u, &w, e);
    for (uint8_t j = 0; j < EV_NY; j++) {
        e[j] = u->y[j] - e[j];
    }
    ev_ekf_correct(s->x, s->P, EV_NX, H, e, r);
}

static uint8_t ev_ekf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                           uint8_t *out_len)
{
    (void)in_len;
    ev_ekf_state_t *s = state;
    ev_inputs_t u;
    *out_len = 4u * EV_N_OUTPUTS;
    uint8_t status = ev_model_inputs(&s->model, in, &u);
    if (status == 0u) {
        if (s->started) {
            predict(s);
        }
        update(s, &u);
        ev_symmetrize(s->P, EV_NX);
        s->u_prev = u;
        s->started = 1;
    }
    return (uint8_t)(status | ev_outputs(s->x, s->x + 3, out));
}

const ROM estimator_t ev_ekf_estimator = {
    .id = EV_EKF_ID,
    .name = "ev_ekf",
    .modes = 1u << MODE_F32,
    .n_inputs = EV_N_INPUTS,
    .n_outputs = EV_N_OUTPUTS,
    .n_params = EV_N_PARAMS + EV_N_FORCE_PARAMS,
    .configure = ev_ekf_configure,
    .reset = ev_ekf_reset,
    .step = ev_ekf_step,
};
