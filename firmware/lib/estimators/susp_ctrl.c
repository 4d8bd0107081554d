#include "estimators/susp_ctrl.h"

#include "fixmath/fixmath.h"

const ROM param_range_t susp_ctrl_ranges[SUSP_CTRL_N_PARAMS] = {
    {0.0f, 1.0f, 0},    {0.0f, 1e4f, 16},      {0.0f, 8e6f, 8},   {0.0f, 8e6f, 8},
    {0.0f, 8e6f, 8},    {1e-10f, 1e-3f, 40},   {1e-3f, 1.0f, 30}, {0.0f, 2e4f, 16},
};

enum { P_ACTIVE, P_RHO_A, P_RHO_SD, P_RHO_TD, P_RHO_V, P_R, P_H, P_UMAX };

void susp_ctrl_design_f32(susp_ctrl_f32_t *c, const uint8_t *params, uint8_t first,
                          uint8_t mode, const qcar_f32_t *m)
{
    float p[SUSP_CTRL_N_PARAMS];
    for (uint8_t i = 0; i < SUSP_CTRL_N_PARAMS; i++) {
        p[i] = param_value(params, (uint8_t)(first + i), mode, param_range_q(susp_ctrl_ranges, i));
    }
    float h = p[P_H], hh = 0.5f * h * h;
    /* b_i: how each predicted output moves with u (the predictions of susp_ctrl.h). */
    float b1 = 1.0f / m->m_s, b2 = hh * (1.0f / m->m_s + 1.0f / m->m_us);
    float b3 = -hh / m->m_us, b4 = h / m->m_s;
    float den = p[P_R] + p[P_RHO_A] * b1 * b1 + p[P_RHO_SD] * b2 * b2 +
                p[P_RHO_TD] * b3 * b3 + p[P_RHO_V] * b4 * b4;
    float w1 = p[P_RHO_A] * b1 / den, w2 = p[P_RHO_SD] * b2 / den;
    float w3 = p[P_RHO_TD] * b3 / den, w4 = p[P_RHO_V] * b4 / den;
    *c = (susp_ctrl_f32_t){
        .g_F1 = w1 + w2 * hh + w4 * h,
        .g_F2 = (w3 - w2) * hh,
        .g_dx = w2,
        .g_dv = w2 * h,
        .g_td = w3,
        .g_vus = w3 * h,
        .g_vs = w4,
        .u_max = p[P_UMAX],
        .active = p[P_ACTIVE] >= 0.5f,
    };
}

uint8_t susp_ctrl_q_from_f32(susp_ctrl_q_t *q, const susp_ctrl_f32_t *c)
{
    uint8_t st = 0, *status = &st;
    *q = (susp_ctrl_q_t){
        .g_F1 = fx_factor(c->g_F1, 8 - 20, status),
        .g_F2 = fx_factor(c->g_F2, 8 - 20, status),
        .g_dx = fx_factor(c->g_dx, 8 - 28, status),
        .g_dv = fx_factor(c->g_dv, 8 - 24, status),
        .g_td = fx_factor(c->g_td, 8 - 28, status),
        .g_vus = fx_factor(c->g_vus, 8 - 24, status),
        .g_vs = fx_factor(c->g_vs, 8 - 24, status),
        .u_max = fx_from_float(c->u_max, 16, status),
        .active = c->active,
    };
    return st != 0 ? P_R + 1u : 0u; /* a larger force weight lowers every gain */
}

float susp_ctrl_step_f32(const susp_ctrl_f32_t *c, const susp_est_f32_t *e, uint8_t *status)
{
    if (!c->active) {
        return 0.0f;
    }
    float u = -(c->g_F1 * e->F1 + c->g_F2 * e->F2 + c->g_dx * (e->x_s - e->x_us) +
                c->g_dv * (e->v_s - e->v_us) + c->g_td * (e->x_us - e->x_r) +
                c->g_vus * e->v_us + c->g_vs * e->v_s);
    if (u > c->u_max || u < -c->u_max) {
        *status |= STATUS_CLAMPED;
        u = u > 0.0f ? c->u_max : -c->u_max;
    }
    return u;
}

int32_t susp_ctrl_step_q(const susp_ctrl_q_t *c, const susp_est_q_t *e, uint8_t *status)
{
    if (!c->active) {
        return 0;
    }
    uint8_t *s = status;
    int32_t u = fx_mul_f(e->F1, c->g_F1, s); /* N Q8 */
    u = fx_add(u, fx_mul_f(e->F2, c->g_F2, s), s);
    u = fx_add(u, fx_mul_f(fx_sub(e->x_s, e->x_us, s), c->g_dx, s), s);
    u = fx_add(u, fx_mul_f(fx_sub(e->v_s, e->v_us, s), c->g_dv, s), s);
    u = fx_add(u, fx_mul_f(fx_sub(e->x_us, e->x_r, s), c->g_td, s), s);
    u = fx_add(u, fx_mul_f(e->v_us, c->g_vus, s), s);
    u = fx_sub(fx_neg(u, s), fx_mul_f(e->v_s, c->g_vs, s), s);
    u = fx_rescale(u, 8, 16, s);
    if (u > c->u_max || u < -c->u_max) {
        *status |= STATUS_CLAMPED;
        u = u > 0 ? c->u_max : -c->u_max;
    }
    return u;
}
