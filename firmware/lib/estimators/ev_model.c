#include "estimators/ev_model.h"

#include <math.h>
#include <string.h>

#include "proto/messages.h"
#include "proto/wire.h"

/* The smoothing speed of the rolling resistance's sign, tanh(v_x / V_ROLL): numerical,
 * not the car's. */
#define V_ROLL 0.5f

static const ROM param_range_t ranges[EV_N_PARAMS] = {
    {1e-3f, 0.05f, 16},  {0.05f, 1.2f, 16},  {0.5f, 60.0f, 16},   {1e-6f, 100.0f, 16},
    {1e-8f, 10.0f, 16},  {1e-10f, 1.0f, 16}, {1e-10f, 1.0f, 16},
    {1e-12f, 1.0f, 16},  {1e-8f, 100.0f, 16}, {1e-8f, 100.0f, 16},
    {1e-10f, 1.0f, 16},  {1e-8f, 100.0f, 16}, {0.0f, 1.0f, 16},   {0.0f, 1e3f, 16},
    {0.0f, 1e3f, 16},    {0.0f, 1.0f, 16},   {0.0f, 1e3f, 16},    {0.0f, 1e3f, 16},
    {0.0f, 1e3f, 16},    {0.0f, 1e4f, 16},   {0.0f, 1e3f, 16},    {0.0f, 1e4f, 16},
    {0.0f, 1e4f, 16},    {0.0f, 1e3f, 16},   {0.0f, 1e3f, 16},    {0.0f, 1e2f, 16},
    {0.0f, 1e2f, 16},    {1.0f, 1e6f, 16},
    /* the car, as ev.CAR_PARAMS: m, I_z, l_f, l_r, track, h, R, I_w, ρ, C_d, A, f, g */
    {200.0f, 5000.0f, 16}, {50.0f, 20000.0f, 16}, {0.3f, 3.0f, 16}, {0.3f, 3.0f, 16},
    {0.8f, 2.5f, 16},      {0.1f, 2.0f, 16},      {0.1f, 1.0f, 16}, {0.05f, 50.0f, 16},
    {0.5f, 1.5f, 16},      {0.0f, 2.0f, 16},      {0.5f, 10.0f, 16}, {0.0f, 0.1f, 16},
    {9.0f, 10.5f, 16},
    /* B_x, C_x, B_y, C_y, E_y, B_xα, C_xα, B_yκ, C_yκ, σ, τ of ω̇'s low-pass; C_xα, C_yκ
     * at most 1 keep cos(C atan z) > 0 */
    {1.0f, 50.0f, 16}, {0.5f, 3.0f, 16}, {1.0f, 50.0f, 16}, {0.5f, 2.0f, 16},
    {-3.0f, 1.0f, 16}, {0.0f, 50.0f, 16}, {0.5f, 1.0f, 16}, {0.0f, 50.0f, 16},
    {0.5f, 1.0f, 16},  {0.05f, 3.0f, 16}, {1e-3f, 1.0f, 16},
};

/* The car's terms from its parameters p (EV_P_M on), each in the order its constant was
 * folded when it was one, so the default car gives the bits it gave then. */
static void car_configure(ev_car_t *c, const float *p)
{
    float m = p[EV_P_M], g = p[EV_P_G], h = p[EV_P_HCG];
    float lf = p[EV_P_LF], lr = p[EV_P_LR], track = p[EV_P_TRACK], wb = lf + lr;
    c->m = m;
    c->inv_m = 1.0f / m;
    c->i_z = p[EV_P_IZ];
    c->inv_iz = 1.0f / c->i_z;
    c->lr_iz = lr / c->i_z;
    for (uint8_t i = 0; i < 4u; i++) {
        c->lx[i] = i < 2u ? lf : -lr;
        c->byw[i] = (i & 1u) ? -(0.5f * track) : 0.5f * track;
    }
    c->i_w = p[EV_P_IW];
    c->inv_r = 1.0f / p[EV_P_RWHEEL];
    c->drag = 0.5f * p[EV_P_RHO] * p[EV_P_CD] * p[EV_P_AF];
    c->drag2 = 2.0f * c->drag;
    c->roll = m * g * p[EV_P_FROLL];
    c->fz_front = m * g * lr / (2.0f * wb);
    c->fz_rear = m * g * lf / (2.0f * wb);
    c->fz_lon = m * h / (2.0f * wb);
    c->fz_lat_f = m * h * lr / (track * wb);
    c->fz_lat_r = m * h * lf / (track * wb);
    c->bx_cx = p[EV_P_BX] * p[EV_P_CX];
    c->by = p[EV_P_BY];
    c->cy = p[EV_P_CY];
    c->by_cy = c->by * c->cy;
    c->ey = p[EV_P_EY];
    c->bxa = p[EV_P_BXA];
    c->cxa = p[EV_P_CXA];
    c->byk = p[EV_P_BYK];
    c->cyk = p[EV_P_CYK];
    c->sigma = p[EV_P_SIGMA];
    c->shape = (uint8_t)((c->bxa != c->by ? EV_TIRE_BXA : 0u) |
                         (c->cxa != 1.0f ? EV_TIRE_CXA : 0u) |
                         (c->ey != 0.0f ? EV_TIRE_EY : 0u) | (c->cyk != 1.0f ? EV_TIRE_CYK : 0u));
}

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
    float p[EV_N_PARAMS];
    for (uint8_t i = 0; i < EV_N_PARAMS; i++) {
        p[i] = get_f32(params + 4u * i);
    }
    memcpy(m->p, p, sizeof m->p);
    car_configure(&m->car, p);
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
    m->lp = m->T / (p[EV_P_TAU_WDOT] + m->T);
    m->adaptive = p[EV_P_ADAPTIVE] >= 0.5f;
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
    const ev_car_t *c = &m->car;
    float ax = z[0], ay = z[1];
    for (uint8_t i = 0; i < 4u; i++) {
        if (m->have_w) {
            m->w_dot[i] += m->lp * ((w[i] - m->w_prev[i]) * m->inv_T - m->w_dot[i]);
        }
        m->w_prev[i] = w[i];
        u->dr.fx[i] = (tq[i] - c->i_w * m->w_dot[i]) * c->inv_r;
    }
    m->have_w = 1;
    /* Static loads and quasi-static transfer (ours: the paper gives no load model). */
    float lon = ax * c->fz_lon;
    float front = c->fz_front - lon;
    float rear = c->fz_rear + lon;
    float lat_f = ay * c->fz_lat_f;
    float lat_r = ay * c->fz_lat_r;
    const float fz[4] = {front - lat_f, front + lat_f, rear - lat_r, rear + lat_r};
    for (uint8_t i = 0; i < 4u; i++) {
        u->fz[i] = fz[i] > 0.0f ? fz[i] : 0.0f;
    }
    u->delta = z[7];
    float sd = sinf(z[7]);
    /* a road-wheel angle is within ±90°, where the cosine is this square root */
    u->dr.sd = sd;
    u->dr.cd = fabsf(z[7]) < 1.5707963f ? sqrtf(1.0f - sd * sd) : cosf(z[7]);
    for (uint8_t i = 0; i < 4u; i++) {
        const float lx = c->lx[i], byw = c->byw[i];
        if (i < 2u) {
            float cd = u->dr.cd;
            u->L[i][0] = cd;
            u->L[i][1] = sd;
            u->L[i][2] = -byw * cd + lx * sd;
            u->dviy[i][0] = -sd;
            u->dviy[i][1] = cd;
            u->dviy[i][2] = sd * byw + cd * lx;
        } else { /* the rear wheels are not steered: δ = 0 in the same expressions */
            u->L[i][0] = 1.0f;
            u->L[i][1] = 0.0f;
            u->L[i][2] = -byw;
            u->dviy[i][0] = -0.0f;
            u->dviy[i][1] = 1.0f;
            u->dviy[i][2] = lx;
        }
    }
    memcpy(u->y, z, 3u * sizeof(float));
    memcpy(u->y + 3, w, 4u * sizeof(float));
    return 0;
}

static float cd_of(const ev_inputs_t *u, uint8_t i) { return i < 2u ? u->dr.cd : 1.0f; }
static float sd_of(const ev_inputs_t *u, uint8_t i) { return i < 2u ? u->dr.sd : 0.0f; }
static float fmaxf_(float a, float b) { return a > b ? a : b; }

/* tanh(v_x / V_ROLL) of the rolling resistance: past |v_x| = 5 m/s it is 1 in float32
 * (and within 4e-9 of it), so the 3.2 k-cycle tanhf is skipped at speed; the host's
 * roll_tanh does the same. */
static float roll_tanh(float vx)
{
    return vx > 5.0f ? 1.0f : (vx < -5.0f ? -1.0f : tanhf(vx / V_ROLL));
}

void ev_wheels(const float *x, const ev_inputs_t *u, const ev_model_t *m, ev_wheels_t *w)
{
    const ev_car_t *c = &m->car;
    float mu = m->mu, cd = u->dr.cd, sd = u->dr.sd;
    for (uint8_t i = 0; i < 4u; i++) {
        float vX = x[0] - c->byw[i] * x[2], vY = x[1] + c->lx[i] * x[2];
        float vix = vX, viy = vY;
        if (i < 2u) { /* the front wheels turn with δ */
            vix = cd * vX + sd * vY;
            viy = -sd * vX + cd * vY;
        }
        float den = fmaxf_(fabsf(vix), 0.5f), zz = viy / den;
        float dmax = mu * u->fz[i];
        float alpha, kappa, ba, ty = 0.0f, sty = 0.0f, g_yk = 1.0f;
        if (m->linear) {
            alpha = -zz;
            ba = c->by * alpha;
            kappa = u->dr.fx[i] / (c->bx_cx * fmaxf_(dmax, 1.0f));
            w->fy_qs[i] = dmax * c->cy * ba;
        } else {
            alpha = -atanf(zz);
            ba = c->by * alpha;
            /* (27)-(28): κ̂ = F_x / (G_xα B_x C_x D_x), G_xα = cos(C_xα atan(B_xα α)):
             * 1/√(1+(B_xα α)²) at C_xα = 1 (the default), a square root where an atan and
             * a cos would cost ~4 k cycles; B_xα = B_y (the default) shares B_y α */
            float bxa = (c->shape & EV_TIRE_BXA) ? c->bxa * alpha : ba;
            float inv_gxa = (c->shape & EV_TIRE_CXA) ? 1.0f / cosf(c->cxa * atanf(bxa))
                                                     : sqrtf(1.0f + bxa * bxa);
            kappa = u->dr.fx[i] * inv_gxa / (c->bx_cx * fmaxf_(dmax, 1.0f));
            /* (15) with S_H = 0: sin(C_y atan(B_y α - E_y (B_y α - atan(B_y α)))) */
            float zy = (c->shape & EV_TIRE_EY) ? ba - c->ey * (ba - atanf(ba)) : ba;
            ty = c->cy * atanf(zy);
            sty = sinf(ty);
            float bk = c->byk * kappa;
            g_yk = (c->shape & EV_TIRE_CYK) ? cosf(c->cyk * atanf(bk)) : 1.0f / sqrtf(1.0f + bk * bk);
            /* (17), (19) */
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
    const ev_car_t *c = &m->car;
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
            d->dqs[i] = mu * u->fz[i] * c->by_cy;
            continue;
        }
        /* κ̂ = F_x / (G_xα(α) k): dκ̂/dα = -κ̂ G_xα' / G_xα
         * = κ̂ C_xα B_xα tan(C_xα atan(B_xα α)) / (1 + (B_xα α)²), κ̂ B_xα² α / (1 + (B_xα α)²)
         * at the defaults */
        float k = w->kappa[i], ba = w->ba[i], bk = c->byk * k;
        float inv_q = 1.0f / (1.0f + ba * ba);
        float dk;
        if (!(c->shape & (EV_TIRE_BXA | EV_TIRE_CXA))) {
            dk = k * c->bxa * ba * inv_q;
        } else {
            float bxa = c->bxa * w->alpha[i], t = c->cxa * atanf(bxa);
            dk = k * c->cxa * c->bxa * (sinf(t) / cosf(t)) / (1.0f + bxa * bxa);
        }
        float dmax = mu * u->fz[i], sty = w->sty[i];
        /* cos C_y atan(z) from its sine: negative past |C_y atan| = π/2 */
        float cty = sqrtf(fmaxf_(1.0f - sty * sty, 0.0f));
        if (fabsf(w->ty[i]) > 1.5707963f) {
            cty = -cty;
        }
        /* dF_y0/dα = D C_y cos(C_y atan z) dz/dα / (1 + z²), z = B_y α at E_y = 0, else
         * dz/dα = B_y (1 - E_y + E_y / (1 + (B_y α)²)) */
        float f0 = dmax * sty, df0 = dmax * c->by_cy * cty * inv_q;
        if (c->shape & EV_TIRE_EY) {
            float e = c->ey, zy = ba - e * (ba - atanf(ba));
            df0 = dmax * c->by_cy * cty * ((1.0f - e + e * inv_q) / (1.0f + zy * zy));
        }
        float g_yk = w->g_yk[i], dg_yk; /* G_yκ = cos(C_yκ atan(B_yκ κ̂)) */
        if (c->shape & EV_TIRE_CYK) {
            dg_yk = -sinf(c->cyk * atanf(bk)) * c->cyk * c->byk / (1.0f + bk * bk);
        } else {
            dg_yk = (-c->byk) * bk * g_yk * g_yk * g_yk;
        }
        d->dk[i] = dk;
        d->dqs[i] = g_yk * df0 + f0 * dg_yk * dk; /* d(G_yκ F_y0)/dα */
    }
}

/* (ΣF_X - resistances) / m, ΣF_Y / m, M_z / I_z (eqs. 1-4, 3), by axle: the front pair
 * shares δ and l_f and the rear is not steered, which saves a third of the operations. */
static void accels(const ev_car_t *c, const float *x, const float *fy, const ev_drive_t *dr,
                   float *acc)
{
    const float *fx = dr->fx;
    float cd = dr->cd, sd = dr->sd;
    float fx_f = fx[0] + fx[1], fy_f = fy[0] + fy[1], fx_r = fx[2] + fx[3];
    float fy_r = fy[2] + fy[3];
    float dX_f = cd * (fx[0] - fx[1]) - sd * (fy[0] - fy[1]); /* F_1X - F_2X */
    float fY_f = sd * fx_f + cd * fy_f;
    float sx = cd * fx_f - sd * fy_f + fx_r, sy = fY_f + fy_r;
    /* l_r = -lx[2], d/2 = byw[0] */
    float mz = c->lx[0] * fY_f + c->lx[2] * fy_r - c->byw[0] * (dX_f + fx[2] - fx[3]);
    float vx = x[0];
    acc[0] = (sx - (c->drag * vx * fabsf(vx) + c->roll * roll_tanh(vx))) * c->inv_m;
    acc[1] = sy * c->inv_m;
    acc[2] = mz * c->inv_iz;
}

void ev_body_rates(const ev_model_t *m, const float *x, const float *fy, const ev_drive_t *dr,
                   float *rates)
{
    accels(&m->car, x, fy, dr, rates);
    rates[0] += x[2] * x[1];
    rates[1] -= x[2] * x[0];
}

void ev_step(const ev_model_t *m, float *x, const ev_inputs_t *u, const ev_wheels_t *w)
{
    float d[3];
    ev_body_rates(m, x, x + 3, &u->dr, d);
    for (uint8_t i = 0; i < 4u; i++) { /* (20) */
        x[3u + i] += m->T * fabsf(w->vix[i]) / m->car.sigma * (w->fy_qs[i] - x[3u + i]);
    }
    for (uint8_t i = 0; i < 3u; i++) {
        x[i] += m->T * d[i];
    }
}

void ev_h(const ev_model_t *m, const float *x, const float *fy, const ev_inputs_t *u,
          const ev_wheels_t *w, float *y)
{
    float acc[3];
    accels(&m->car, x, fy, &u->dr, acc);
    y[0] = acc[0];
    y[1] = acc[1];
    y[2] = x[2];
    for (uint8_t i = 0; i < 4u; i++) { /* (29) */
        y[3u + i] = w->vix[i] * (1.0f + w->kappa[i]) * m->car.inv_r;
    }
}

static float resist_slope(const ev_car_t *c, float vx)
{
    float t = roll_tanh(vx);
    return c->drag2 * fabsf(vx) + c->roll * (1.0f - t * t) / V_ROLL;
}

/* Row i of ∂ω/∂(v_x, v_y, γ) (29) into h (stride 1). */
static void omega_row(const ev_car_t *c, const ev_inputs_t *u, const ev_wheels_t *w,
                      const ev_slopes_t *d, uint8_t i, float *h)
{
    const float *L = u->L[i];
    float a = (1.0f + w->kappa[i]) * c->inv_r, b = w->vix[i] * d->dk[i] * c->inv_r;
    for (uint8_t j = 0; j < 3u; j++) {
        h[j] = L[j] * a + b * d->dalpha[i][j];
    }
}

void ev_jacobians(const ev_model_t *m, const float *x, const ev_inputs_t *u,
                  const ev_wheels_t *w, const ev_slopes_t *d, float *F, float *H)
{
    const ev_car_t *c = &m->car;
    float rs = resist_slope(c, x[0]) / c->m;
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
        uint8_t k = (uint8_t)(3u + i);
        if (H != NULL) {
            H[k] = -sd / c->m;
            H[EV_NX + k] = cd / c->m;
            float row[3];
            omega_row(c, u, w, d, i, row);
            memcpy(H + k * EV_NX, row, sizeof row);
        }
        if (F == NULL) {
            continue;
        }
        F[k] = -sd / c->m;
        F[EV_NX + k] = cd / c->m;
        F[2 * EV_NX + k] = (c->lx[i] * cd + c->byw[i] * sd) / c->i_z;
        /* Row of F̃_iy: ∂/∂V of |v_ix|/σ (G_yκ(κ̂) F_y0(α) - F̃). */
        const float *L = u->L[i];
        float vix = w->vix[i], avix = fabsf(vix);
        float sgn = vix > 0.0f ? 1.0f : (vix < 0.0f ? -1.0f : 0.0f);
        float q = w->fy_qs[i] - x[k];
        for (uint8_t j = 0; j < 3u; j++) {
            F[k * EV_NX + j] = (sgn * L[j] * q + avix * d->dqs[i] * d->dalpha[i][j]) / c->sigma;
        }
        F[k * EV_NX + k] = -avix / c->sigma;
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

void ev_force_slopes3(const ev_model_t *m, const ev_inputs_t *u, const ev_slopes_t *d, float *J)
{
    /* ∂(ΣF_X / m, ΣF_Y / m, M_z / I_z)/∂V through the quasi-static forces' dF_y/dα ∂α/∂V,
     * by axle as in accels */
    const ev_car_t *c = &m->car;
    const float a0 = -u->dr.sd * c->inv_m, a1 = u->dr.cd * c->inv_m;
    const float a2 = c->lx[0] * u->dr.cd * c->inv_iz, a2d = c->byw[0] * u->dr.sd * c->inv_iz;
    for (uint8_t j = 0; j < 3u; j++) {
        float g1 = d->dqs[0] * d->dalpha[0][j], g2 = d->dqs[1] * d->dalpha[1][j];
        float s_f = g1 + g2;
        float s_r = d->dqs[2] * d->dalpha[2][j] + d->dqs[3] * d->dalpha[3][j];
        J[j] = a0 * s_f;
        J[3u + j] = a1 * s_f + s_r * c->inv_m;
        J[6u + j] = a2 * s_f + a2d * (g1 - g2) - c->lr_iz * s_r;
    }
}

void ev_f3(const ev_model_t *m, const float *x, const float *J, float *F)
{
    float rs = resist_slope(&m->car, x[0]) * m->car.inv_m;
    const float coupling[9] = {-rs, x[2], x[1], -x[2], 0.0f, -x[0], 0.0f, 0.0f, 0.0f};
    for (uint8_t k = 0; k < 9u; k++) {
        F[k] = m->T * (J[k] + coupling[k]);
    }
    F[0] += 1.0f;
    F[4] += 1.0f;
    F[8] += 1.0f;
}

void ev_h3(const ev_model_t *m, const float *x, const ev_inputs_t *u, const ev_wheels_t *w,
           const ev_slopes_t *d, const float *J, float *H)
{
    memcpy(H, J, 6u * sizeof(float)); /* a_x, a_y: the accelerations' rows */
    H[0] -= resist_slope(&m->car, x[0]) * m->car.inv_m;
    H[6] = 0.0f;
    H[7] = 0.0f;
    H[8] = 1.0f;
    for (uint8_t i = 0; i < 4u; i++) {
        omega_row(&m->car, u, w, d, i, H + (3u + i) * 3u);
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
        sfx += fabsf(u->dr.fx[i]);
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
