#include "estimators/ev_model.h"

#include <math.h>
#include <string.h>

#include "proto/messages.h"
#include "proto/wire.h"

/* Note §5.2's vehicle, as in host/vehil/models/ev4wd.py. */
#define M_VEH 1400.0f
#define I_Z 1900.0f
#define L_F 1.10f
#define L_R 1.45f
#define TRACK 1.50f
#define H_CG 0.50f
#define R_W 0.30f
#define I_W 1.2f
#define DRAG (0.5f * 1.206f * 0.30f * 2.2f)
#define ROLL (M_VEH * 9.81f * 0.015f)
#define WB (L_F + L_R)
#define BX 10.0f
#define CX 1.9f
#define BY 10.0f
#define CY 1.3f
/* B_xα = B_y (note §5.2), so G_xα and F_y0's slope share 1 + (B_y α)² */
#define BXA BY
#define BYK 10.0f
/* C_xα = C_yκ = 1 (host CXA, CYK), so cos(C atan z) = 1/√(1+z²) and sin(C atan z) =
 * z/√(1+z²): a square root instead of an atan and a cos, on a core without an FPU. */
#define SIGMA (60000.0f / 150000.0f)
#define TAU_WDOT 0.02f

static const float lx[4] = {L_F, L_F, -L_R, -L_R};
static const float byw[4] = {0.5f * TRACK, -0.5f * TRACK, 0.5f * TRACK, -0.5f * TRACK};

static const ROM param_range_t ranges[EV_N_PARAMS] = {
    {1e-3f, 0.05f, 16},  {0.05f, 1.2f, 16},  {0.5f, 60.0f, 16},   {1e-6f, 100.0f, 16},
    {1e-8f, 10.0f, 16},  {1e-10f, 1.0f, 16}, {1e-10f, 1.0f, 16},
    {1e-12f, 1.0f, 16},  {1e-8f, 100.0f, 16}, {1e-8f, 100.0f, 16},
    {1e-10f, 1.0f, 16},  {1e-8f, 100.0f, 16}, {0.0f, 1.0f, 16},   {0.0f, 1e3f, 16},
    {0.0f, 1e3f, 16},    {0.0f, 1.0f, 16},   {0.0f, 1e3f, 16},    {0.0f, 1e3f, 16},
    {0.0f, 1e3f, 16},    {0.0f, 1e4f, 16},   {0.0f, 1e3f, 16},    {0.0f, 1e4f, 16},
    {0.0f, 1e4f, 16},    {0.0f, 1e3f, 16},   {0.0f, 1e3f, 16},    {0.0f, 1e2f, 16},
    {0.0f, 1e2f, 16},    {1.0f, 1e6f, 16},
};

uint8_t ev_model_configure(ev_model_t *m, uint8_t mode, const uint8_t *params,
                           const param_range_t *own, uint8_t n_own)
{
    uint8_t bad = params_check(params, mode, ranges, EV_N_PARAMS);
    if (bad != 0u) {
        return bad;
    }
    bad = params_check(params + 4u * EV_N_PARAMS, mode, own, n_own);
    if (bad != 0u) {
        return (uint8_t)(bad + EV_N_PARAMS);
    }
    for (uint8_t i = 0; i < EV_N_PARAMS; i++) {
        m->p[i] = get_f32(params + 4u * i);
    }
    const float *p = m->p;
    m->T = p[EV_P_T];
    m->inv_T = 1.0f / m->T;
    m->mu = p[EV_P_MU];
    m->linear = 0;
    const float fixed[4] = {p[EV_P_RAX], p[EV_P_RAY], p[EV_P_RGZ], p[EV_P_RW]};
    const float c[4] = {p[EV_P_CAX] / 3.0f, p[EV_P_CAY] / 2.0f, p[EV_P_CGZ] / 2.0f,
                        p[EV_P_CW] / 3.0f};
    for (uint8_t i = 0; i < 4u; i++) {
        m->r_scale[i] = c[i] * fixed[i];
        m->r_lo[i] = fixed[i] / p[EV_P_RCLIP];
        m->r_hi[i] = fixed[i] * p[EV_P_RCLIP];
    }
    m->lp = m->T / (TAU_WDOT + m->T);
    m->adaptive = m->p[EV_P_ADAPTIVE] >= 0.5f;
    ev_model_reset(m);
    return 0;
}

void ev_model_reset(ev_model_t *m)
{
    memset(m->w_dot, 0, sizeof m->w_dot);
    m->have_w = 0;
}

uint8_t ev_model_inputs(ev_model_t *m, const uint8_t *in, ev_inputs_t *u)
{
    float z[EV_N_INPUTS];
    for (uint8_t i = 0; i < EV_N_INPUTS; i++) {
        z[i] = get_f32(in + 4u * i);
        if (!isfinite(z[i])) {
            return STATUS_NOT_FINITE;
        }
    }
    const float *w = z + 3, *tq = z + 8;
    float ax = z[0], ay = z[1];
    for (uint8_t i = 0; i < 4u; i++) {
        if (m->have_w) {
            m->w_dot[i] += m->lp * ((w[i] - m->w_prev[i]) * m->inv_T - m->w_dot[i]);
        }
        m->w_prev[i] = w[i];
        u->fx[i] = (tq[i] - I_W * m->w_dot[i]) * (1.0f / R_W);
    }
    m->have_w = 1;
    /* Static loads and quasi-static transfer (note §5.2). */
    /* the constant factors first, so the compiler folds them */
    float lon = ax * (M_VEH * H_CG / (2.0f * WB));
    float front = M_VEH * 9.81f * L_R / (2.0f * WB) - lon;
    float rear = M_VEH * 9.81f * L_F / (2.0f * WB) + lon;
    float lat_f = ay * (M_VEH * H_CG * L_R / (TRACK * WB));
    float lat_r = ay * (M_VEH * H_CG * L_F / (TRACK * WB));
    const float fz[4] = {front - lat_f, front + lat_f, rear - lat_r, rear + lat_r};
    for (uint8_t i = 0; i < 4u; i++) {
        u->fz[i] = fz[i] > 0.0f ? fz[i] : 0.0f;
    }
    u->delta = z[7];
    u->sd = sinf(z[7]);
    /* a road-wheel angle is within ±90°, where the cosine is this square root */
    u->cd = fabsf(z[7]) < 1.5707963f ? sqrtf(1.0f - u->sd * u->sd) : cosf(z[7]);
    for (uint8_t i = 0; i < 4u; i++) {
        float cd = i < 2u ? u->cd : 1.0f, sd = i < 2u ? u->sd : 0.0f;
        u->L[i][0] = cd;
        u->L[i][1] = sd;
        u->L[i][2] = -byw[i] * cd + lx[i] * sd;
        u->dviy[i][0] = -sd;
        u->dviy[i][1] = cd;
        u->dviy[i][2] = sd * byw[i] + cd * lx[i];
    }
    memcpy(u->y, z, 3u * sizeof(float));
    memcpy(u->y + 3, w, 4u * sizeof(float));
    return 0;
}

static float cd_of(const ev_inputs_t *u, uint8_t i) { return i < 2u ? u->cd : 1.0f; }
static float sd_of(const ev_inputs_t *u, uint8_t i) { return i < 2u ? u->sd : 0.0f; }
static float fmaxf_(float a, float b) { return a > b ? a : b; }

/* tanh(v_x / 0.5) of the rolling resistance: past |v_x| = 5 m/s it is 1 in float32 (and
 * within 4e-9 of it), so the 3.2 k-cycle tanhf is skipped at speed; the host's
 * roll_tanh does the same. */
static float roll_tanh(float vx)
{
    return vx > 5.0f ? 1.0f : (vx < -5.0f ? -1.0f : tanhf(vx / 0.5f));
}

void ev_wheels(const float *x, const ev_inputs_t *u, const ev_model_t *m, ev_wheels_t *w)
{
    float mu = m->mu;
    for (uint8_t i = 0; i < 4u; i++) {
        float vX = x[0] - byw[i] * x[2], vY = x[1] + lx[i] * x[2];
        float vix = vX, viy = vY;
        if (i < 2u) { /* the front wheels turn with δ */
            vix = u->cd * vX + u->sd * vY;
            viy = -u->sd * vX + u->cd * vY;
        }
        float den = fmaxf_(fabsf(vix), 0.5f), zz = viy / den;
        float dmax = mu * u->fz[i];
        float alpha, kappa, ba, ty = 0.0f, sty = 0.0f, g_yk = 1.0f;
        if (m->linear) {
            alpha = -zz;
            ba = BY * alpha;
            kappa = u->fx[i] / (BX * CX * fmaxf_(dmax, 1.0f));
            w->fy_qs[i] = dmax * CY * ba;
        } else {
            alpha = -atanf(zz);
            ba = BY * alpha;
            /* (27)-(28): κ̂ = F_x / (G_xα B_x C_x D_x), G_xα = 1/√(1+(B_xα α)²) */
            kappa = u->fx[i] * sqrtf(1.0f + ba * ba) / (BX * CX * fmaxf_(dmax, 1.0f));
            ty = CY * atanf(ba);
            sty = sinf(ty);
            float bk = BYK * kappa;
            g_yk = 1.0f / sqrtf(1.0f + bk * bk);
            /* (15), (17), (19) with E_y = 0 and S_H = 0 */
            w->fy_qs[i] = dmax * sty * g_yk;
        }
        w->vix[i] = vix;
        w->alpha[i] = alpha;
        w->kappa[i] = kappa;
        w->den[i] = den;
        w->zz[i] = zz;
        w->ba[i] = ba;
        w->ty[i] = ty;
        w->sty[i] = sty;
        w->g_yk[i] = g_yk;
    }
}

void ev_slopes(const ev_inputs_t *u, const ev_model_t *m, const ev_wheels_t *w, ev_slopes_t *d)
{
    float mu = m->mu;
    for (uint8_t i = 0; i < 4u; i++) {
        const float *L = u->L[i], *dviy = u->dviy[i];
        /* α = -atan(v_iy / max(|v_ix|, 0.5)) */
        float vix = w->vix[i], avix = fabsf(vix);
        float sgn = vix > 0.0f ? 1.0f : (vix < 0.0f ? -1.0f : 0.0f);
        float zz = w->zz[i];
        /* linear tires: α = -zz, so no 1 / (1 + zz²) */
        float g = 1.0f / (m->linear ? w->den[i] : w->den[i] * (1.0f + zz * zz));
        for (uint8_t j = 0; j < 3u; j++) {
            float dden = avix > 0.5f ? sgn * L[j] : 0.0f;
            d->dalpha[i][j] = -(dviy[j] - zz * dden) * g;
        }
        if (m->linear) { /* κ̂ does not depend on α, F_y = B_y C_y μF_z α */
            d->dk[i] = 0.0f;
            d->dqs[i] = mu * u->fz[i] * (BY * CY);
            continue;
        }
        /* κ̂ = F_x / (G_xα(α) k): dκ̂/dα = -κ̂ G_xα' / G_xα = κ̂ B_xα² α / (1 + (B_xα α)²) */
        float k = w->kappa[i], ba = w->ba[i], bk = BYK * k;
        float inv_q = 1.0f / (1.0f + ba * ba);
        float dk = k * BXA * ba * inv_q;
        float dmax = mu * u->fz[i], sty = w->sty[i];
        /* cos C_y atan(B_y α) from its sine: negative past |C_y atan| = π/2 */
        float cty = sqrtf(fmaxf_(1.0f - sty * sty, 0.0f));
        if (fabsf(w->ty[i]) > 1.5707963f) {
            cty = -cty;
        }
        float f0 = dmax * sty, df0 = dmax * (CY * BY) * cty * inv_q;
        float g_yk = w->g_yk[i]; /* G_yκ = 1/√(1+(B_yκ κ̂)²) */
        float dg_yk = (-BYK) * bk * g_yk * g_yk * g_yk;
        d->dk[i] = dk;
        d->dqs[i] = g_yk * df0 + f0 * dg_yk * dk; /* d(G_yκ F_y0)/dα */
    }
}

/* (ΣF_X - resistances) / m, ΣF_Y / m, M_z / I_z (eqs. 1-4, 3), by axle: the front pair
 * shares δ and l_f and the rear is not steered, which saves a third of the operations. */
static void accels(const float *x, const float *fy, const ev_inputs_t *u, float *acc)
{
    const float *fx = u->fx;
    float cd = u->cd, sd = u->sd;
    float fx_f = fx[0] + fx[1], fy_f = fy[0] + fy[1], fx_r = fx[2] + fx[3];
    float fy_r = fy[2] + fy[3];
    float dX_f = cd * (fx[0] - fx[1]) - sd * (fy[0] - fy[1]); /* F_1X - F_2X */
    float fY_f = sd * fx_f + cd * fy_f;
    float sx = cd * fx_f - sd * fy_f + fx_r, sy = fY_f + fy_r;
    float mz = L_F * fY_f - L_R * fy_r - (0.5f * TRACK) * (dX_f + fx[2] - fx[3]);
    float vx = x[0];
    acc[0] = (sx - (DRAG * vx * fabsf(vx) + ROLL * roll_tanh(vx))) * (1.0f / M_VEH);
    acc[1] = sy * (1.0f / M_VEH);
    acc[2] = mz * (1.0f / I_Z);
}

void ev_body_rates(const float *x, const float *fy, const ev_inputs_t *u, float *rates)
{
    accels(x, fy, u, rates);
    rates[0] += x[2] * x[1];
    rates[1] -= x[2] * x[0];
}

void ev_step(const ev_model_t *m, float *x, const ev_inputs_t *u, const ev_wheels_t *w)
{
    float d[3];
    ev_body_rates(x, x + 3, u, d);
    for (uint8_t i = 0; i < 4u; i++) { /* (20) */
        x[3u + i] += m->T * fabsf(w->vix[i]) / SIGMA * (w->fy_qs[i] - x[3u + i]);
    }
    for (uint8_t i = 0; i < 3u; i++) {
        x[i] += m->T * d[i];
    }
}

void ev_h(const float *x, const float *fy, const ev_inputs_t *u, const ev_wheels_t *w, float *y)
{
    float acc[3];
    accels(x, fy, u, acc);
    y[0] = acc[0];
    y[1] = acc[1];
    y[2] = x[2];
    for (uint8_t i = 0; i < 4u; i++) { /* (29) */
        y[3u + i] = w->vix[i] * (1.0f + w->kappa[i]) * (1.0f / R_W);
    }
}

static float resist_slope(float vx)
{
    float t = roll_tanh(vx);
    return 2.0f * DRAG * fabsf(vx) + ROLL * (1.0f - t * t) / 0.5f;
}

/* Row i of ∂ω/∂(v_x, v_y, γ) (29) into h (stride 1). */
static void omega_row(const ev_inputs_t *u, const ev_wheels_t *w, const ev_slopes_t *d,
                      uint8_t i, float *h)
{
    const float *L = u->L[i];
    float a = (1.0f + w->kappa[i]) * (1.0f / R_W), b = w->vix[i] * d->dk[i] * (1.0f / R_W);
    for (uint8_t j = 0; j < 3u; j++) {
        h[j] = L[j] * a + b * d->dalpha[i][j];
    }
}

void ev_jacobians(const ev_model_t *m, const float *x, const ev_inputs_t *u,
                  const ev_wheels_t *w, const ev_slopes_t *d, float *F, float *H)
{
    float rs = resist_slope(x[0]) / M_VEH;
    if (H != NULL) {
        memset(H, 0, EV_NY * EV_NX * sizeof(float));
        H[0] = -rs;
        H[2 * EV_NX + 2] = 1.0f;
    }
    if (F != NULL) {
        memset(F, 0, EV_NX * EV_NX * sizeof(float));
        F[0] = -rs;
        F[1] = x[2];
        F[2] = x[1];
        F[EV_NX + 0] = -x[2];
        F[EV_NX + 2] = -x[0];
    }
    for (uint8_t i = 0; i < 4u; i++) {
        float cd = cd_of(u, i), sd = sd_of(u, i);
        uint8_t c = (uint8_t)(3u + i);
        if (H != NULL) {
            H[c] = -sd / M_VEH;
            H[EV_NX + c] = cd / M_VEH;
            float row[3];
            omega_row(u, w, d, i, row);
            memcpy(H + c * EV_NX, row, sizeof row);
        }
        if (F == NULL) {
            continue;
        }
        F[c] = -sd / M_VEH;
        F[EV_NX + c] = cd / M_VEH;
        F[2 * EV_NX + c] = (lx[i] * cd + byw[i] * sd) / I_Z;
        /* Row of F̃_iy: ∂/∂V of |v_ix|/σ (G_yκ(κ̂) F_y0(α) - F̃). */
        const float *L = u->L[i];
        float vix = w->vix[i], avix = fabsf(vix);
        float sgn = vix > 0.0f ? 1.0f : (vix < 0.0f ? -1.0f : 0.0f);
        float q = w->fy_qs[i] - x[c];
        for (uint8_t j = 0; j < 3u; j++) {
            F[c * EV_NX + j] = (sgn * L[j] * q + avix * d->dqs[i] * d->dalpha[i][j]) / SIGMA;
        }
        F[c * EV_NX + c] = -avix / SIGMA;
    }
    if (F != NULL) { /* I + T J */
        for (uint8_t k = 0; k < EV_NX * EV_NX; k++) {
            F[k] *= m->T;
        }
        for (uint8_t k = 0; k < EV_NX; k++) {
            F[k * EV_NX + k] += 1.0f;
        }
    }
}

void ev_force_slopes3(const ev_inputs_t *u, const ev_slopes_t *d, float *J)
{
    /* ∂(ΣF_X / m, ΣF_Y / m, M_z / I_z)/∂V through the quasi-static forces' dF_y/dα ∂α/∂V,
     * by axle as in accels */
    const float a0 = -u->sd * (1.0f / M_VEH), a1 = u->cd * (1.0f / M_VEH);
    const float a2 = L_F * u->cd * (1.0f / I_Z), a2d = 0.5f * TRACK * u->sd * (1.0f / I_Z);
    for (uint8_t j = 0; j < 3u; j++) {
        float g1 = d->dqs[0] * d->dalpha[0][j], g2 = d->dqs[1] * d->dalpha[1][j];
        float s_f = g1 + g2;
        float s_r = d->dqs[2] * d->dalpha[2][j] + d->dqs[3] * d->dalpha[3][j];
        J[j] = a0 * s_f;
        J[3u + j] = a1 * s_f + s_r * (1.0f / M_VEH);
        J[6u + j] = a2 * s_f + a2d * (g1 - g2) - (L_R / I_Z) * s_r;
    }
}

void ev_f3(const ev_model_t *m, const float *x, const float *J, float *F)
{
    float rs = resist_slope(x[0]) * (1.0f / M_VEH);
    const float coupling[9] = {-rs, x[2], x[1], -x[2], 0.0f, -x[0], 0.0f, 0.0f, 0.0f};
    for (uint8_t k = 0; k < 9u; k++) {
        F[k] = m->T * (J[k] + coupling[k]);
    }
    F[0] += 1.0f;
    F[4] += 1.0f;
    F[8] += 1.0f;
}

void ev_h3(const float *x, const ev_inputs_t *u, const ev_wheels_t *w, const ev_slopes_t *d,
           const float *J, float *H)
{
    memcpy(H, J, 6u * sizeof(float)); /* a_x, a_y: the accelerations' rows */
    H[0] -= resist_slope(x[0]) * (1.0f / M_VEH);
    H[6] = 0.0f;
    H[7] = 0.0f;
    H[8] = 1.0f;
    for (uint8_t i = 0; i < 4u; i++) {
        omega_row(u, w, d, i, H + (3u + i) * 3u);
    }
}

static float clip(float r, float lo, float hi)
{
    return r < lo ? lo : (r > hi ? hi : r);
}

void ev_noise(const ev_model_t *m, const ev_inputs_t *u, const ev_wheels_t *w, float *r)
{
    const float *p = m->p;
    r[0] = p[EV_P_RAX];
    r[1] = p[EV_P_RAY];
    r[2] = p[EV_P_RGZ];
    for (uint8_t i = 3; i < EV_NY; i++) {
        r[i] = p[EV_P_RW];
    }
    if (!m->adaptive) {
        return;
    }
    float ax = fabsf(u->y[0]), ay = fabsf(u->y[1]), gz = fabsf(u->y[2]), dl = fabsf(u->delta);
    float sfx = 0.0f, sk = 0.0f;
    for (uint8_t i = 0; i < 4u; i++) {
        sfx += fabsf(u->fx[i]);
        sk += fabsf(w->kappa[i]);
    }
    /* (66)-(69); the |δ| term is computed once when the rules of a_y and γ share d_2 */
    float e_dl_ay = expf(-p[EV_P_DAY2] * dl);
    float e_dl_gz = p[EV_P_DGZ2] == p[EV_P_DAY2] ? e_dl_ay : expf(-p[EV_P_DGZ2] * dl);
    float r_ax = m->r_scale[0] *
                 (expf(-p[EV_P_DAX1] * ax) + expf(-p[EV_P_DAX2] * sfx) + expf(-p[EV_P_DAX3] * sk));
    float r_ay = m->r_scale[1] * (expf(-p[EV_P_DAY1] * ay) + e_dl_ay);
    float r_gz = m->r_scale[2] * (expf(-p[EV_P_DGZ1] * gz) + e_dl_gz);
    float common = expf(p[EV_P_DW2] * ax) + expf(p[EV_P_DW3] * ay);
    for (uint8_t i = 0; i < 4u; i++) {
        float k = fabsf(w->kappa[i]);
        float r_w = m->r_scale[3] * (expf(p[EV_P_DW1] * (k < 1.0f ? k : 1.0f)) + common);
        r[3u + i] = clip(r_w, m->r_lo[3], m->r_hi[3]);
    }
    r[0] = clip(r_ax, m->r_lo[0], m->r_hi[0]);
    r[1] = clip(r_ay, m->r_lo[1], m->r_hi[1]);
    r[2] = clip(r_gz, m->r_lo[2], m->r_hi[2]);
}

void ev_prior(const ev_model_t *m, uint8_t n, float p0_f, float *x, float *P)
{
    memset(x, 0, n * sizeof(float));
    memset(P, 0, n * n * sizeof(float));
    x[0] = m->p[EV_P_VX0];
    P[0] = m->p[EV_P_P0V];
    P[n + 1u] = m->p[EV_P_P0LAT];
    P[2u * n + 2u] = 0.01f * m->p[EV_P_P0LAT];
    for (uint8_t i = 3; i < n; i++) {
        P[i * n + i] = p0_f;
    }
}

void ev_ekf_correct(float *x, float *P, uint8_t n, const float *H, const float *e,
                    const float *r)
{
    float dx[EV_NX], ph[EV_NX];
    memset(dx, 0, n * sizeof(float));
    for (uint8_t j = 0; j < EV_NY; j++) {
        const float *hj = H + j * n;
        float ej = e[j], sum = r[j];
        for (uint8_t i = 0; i < n; i++) {
            float acc = 0.0f;
            for (uint8_t k = 0; k < n; k++) {
                acc += P[i * n + k] * hj[k];
            }
            ph[i] = acc;
            ej -= hj[i] * dx[i]; /* y_j's innovation at the state corrected so far */
        }
        for (uint8_t i = 0; i < n; i++) {
            sum += hj[i] * ph[i];
        }
        float inv = 1.0f / sum;
        for (uint8_t i = 0; i < n; i++) {
            float k = ph[i] * inv;
            dx[i] += k * ej;
            /* P - k phᵀ is symmetric: the upper triangle, mirrored */
            for (uint8_t c = i; c < n; c++) {
                P[i * n + c] = P[c * n + i] = P[i * n + c] - k * ph[c];
            }
        }
    }
    for (uint8_t i = 0; i < n; i++) {
        x[i] += dx[i];
    }
}

void ev_symmetrize(float *P, uint8_t n)
{
    for (uint8_t i = 0; i < n; i++) {
        for (uint8_t j = 0; j < i; j++) {
            float m = 0.5f * (P[i * n + j] + P[j * n + i]);
            P[i * n + j] = P[j * n + i] = m;
        }
    }
}

uint8_t ev_outputs(const float *x, const float *fy, uint8_t *out)
{
    uint8_t status = 0;
    for (uint8_t i = 0; i < EV_NX; i++) {
        float v = i < 3u ? x[i] : fy[i - 3u];
        put_f32(out + 4u * i, v);
        if (!isfinite(v)) {
            status = STATUS_NOT_FINITE;
        }
    }
    put_f32(out + 4u * EV_NX, atan2f(x[1], fmaxf_(x[0], 0.1f)) * (180.0f / 3.14159265f));
    return status;
}
