#include "estimators/acc_kf.h"

#include <math.h>

#include "estimators/accel_cond.h"
#include "estimators/health.h"
#include "estimators/params.h"
#include "fixmath/fixmath.h"
#include "proto/wire.h"

enum {
    P_T, P_RW, P_NV, P_NB, P_R, P_P0V, P_P0B, P_RBAR, P_C1, P_C2, P_VG, P_LPF,
    P_Z2MAX, P_ZWIN, P_VMAX, P_SMAX, N_PARAMS
};

static const ROM param_range_t ranges[N_PARAMS] = {
    {1e-4f, 0.1f, 30},   {0.1f, 1.0f, 24}, {0.0f, 10.0f, 27}, {0.0f, 1.0f, 30},
    {1e-6f, 100.0f, 24}, {0.0f, 7.9f, 24}, {0.0f, 1.0f, 30},  {-1.0f, 1.0f, 30},
    {0.0f, 1.0f, 0},     {0.0f, 1.0f, 0},  {0.0f, 10.0f, 16}, {0.0f, 100.0f, 24},
    {0.1f, 1000.0f, 16}, {0.1f, 100.0f, 24}, {1.0f, 200.0f, 16}, {0.0f, 0.99f, 30},
};

/* The low-pass's cutoff times T, at most (0.8 of Nyquist). */
#define ACC_KF_LPF_MAX_FC_T 0.4f
#define ONE_Q30 (INT32_C(1) << 30)

/* -- float32 ------------------------------------------------------------- */

static void reset_f32(acc_kf_params_f32_t *p, acc_kf_f32_t *s)
{
    *s = (acc_kf_f32_t){.p11 = p->p0_v, .p22 = p->p0_b};
}

static float lpf_f32(const acc_kf_params_f32_t *p, acc_kf_f32_t *s, float a_m)
{
    /* Eq. 4b, 2nd order; the Butterworth's b are b0 (1, 2, 1): one product */
    float a_f = p->lpf_on ? p->b0 * ((a_m + s->am[1]) + (s->am[0] + s->am[0])) +
                                p->c[0] * s->af[0] + p->c[1] * s->af[1]
                          : a_m;
    s->am[1] = s->am[0];
    s->am[0] = a_m;
    s->af[1] = s->af[0];
    s->af[0] = a_f;
    return a_f;
}

static uint8_t step_f32(acc_kf_state_t *st, const uint8_t *in, uint8_t *out)
{
    const acc_kf_params_f32_t *p = &st->u.f32.p;
    acc_kf_f32_t *s = &st->u.f32.s;
    float a_m = get_f32(in), w_l = get_f32(in + 4), w_r = get_f32(in + 8);
    uint8_t braking = get_f32(in + 12) > 0.5f;
    uint8_t status = 0;
    if (!isfinite(a_m) || !isfinite(w_l) || !isfinite(w_r)) {
        status = STATUS_NOT_FINITE; /* the state is left as it was */
    } else {
        float v_m = p->r_w_half * (w_l + w_r); /* eq. 3 */
        if (!st->started) {
            /* x̂(0) = [v_m(0), 0]; the LPF starts in steady state at a_m(0). */
            st->started = 1;
            s->v = v_m;
            s->a0 = 0.0f;
            s->u_prev = a_m;
            s->am[0] = s->am[1] = s->af[0] = s->af[1] = a_m;
        } else {
            float T = p->T;
            float w2 = st->corr1 ? s->w2_prev : 0.0f;
            float v_pred = s->v + T * (s->u_prev - s->a0);
            float b_pred = s->a0 + w2;
            float m12 = s->p12 - T * s->p22;
            float m11 = s->p11 - T * (s->p12 + m12) + p->q_v; /* 2 P12 - T P22 = P12 + M12 */
            float m22 = s->p22 + p->q_b;
            /* c = 1 - slip (eq. 8); c = 1 multiplies exactly, so those steps skip c's
             * products */
            float cm11 = m11, cm12 = m12, c2m11 = m11, c_v_pred = v_pred;
            if (braking && st->corr2 && s->slip != 0.0f) {
                float c = 1.0f - s->slip;
                cm11 = c * m11;
                cm12 = c * m12;
                c2m11 = c * cm11;
                c_v_pred = c * v_pred;
            }
            float inv_s = 1.0f / (c2m11 + p->R);
            float k1 = cm11 * inv_s, k2 = cm12 * inv_s;
            float e = v_m - c_v_pred;
            s->v = v_pred + k1 * e;
            s->a0 = b_pred + k2 * e;
            float g = p->R * inv_s; /* 1 - c k1: P11 - k1 c M11 = M11 g, P12 alike */
            s->p11 = m11 * g;
            s->p12 = m12 * g;
            s->p22 = m22 - k2 * cm12;
            /* Health (docs/estimators/acc_kf.md): the innovation's windowed mean against its
             * white-noise spread, v̂ within 3σ of [-v_guard, v_max] (near standstill the
             * filter is not held to its speed). */
            s->e_mean = health_window_mean(s->e_mean, p->alpha, e);
            if (s->e_mean * s->e_mean * inv_s > p->z_lim ||
                health_outside_3sigma(s->v, -p->v_guard, p->v_max, s->p11)) {
                status |= STATUS_DIVERGED;
            }
            if (st->corr1) { /* a_f serves correction 1 alone */
                float a_f = lpf_f32(p, s, a_m);
                s->w2_prev = p->rbar * (a_f - s->af[1]); /* eq. 6 */
            }
            if (braking && s->v > p->v_guard) {
                float slip = 1.0f - v_m / s->v; /* eq. 7, for the next step */
                if (slip < 0.0f || slip > p->s_max) {
                    status |= STATUS_CLAMPED;
                    slip = slip < 0.0f ? 0.0f : p->s_max;
                }
                s->slip = slip;
            } else {
                s->slip = 0.0f;
            }
            s->u_prev = a_m;
            if (!isfinite(s->v) || !isfinite(s->p11)) {
                status |= STATUS_NOT_FINITE;
            }
        }
    }
    put_f32(out, s->v);
    put_f32(out + 4, s->a0);
    return status;
}

/* -- fixed point --------------------------------------------------------- */

static void reset_q(acc_kf_params_q_t *p, acc_kf_q_t *s)
{
    *s = (acc_kf_q_t){.p11 = p->p0_v, .p22 = p->p0_b};
}

static int32_t lpf_q(const acc_kf_params_q_t *p, acc_kf_q_t *s, int32_t a_m, uint8_t *st)
{
    /* Eq. 4b, the Butterworth's b0 (1, 2, 1) times the samples' quarter sum q = a_m / 4 +
     * a_m(k-1) / 2 + a_m(k-2) / 4, each quarter kept floored (an error below one Q24 unit,
     * 6e-8 m/s², far under any accelerometer's noise). With its unit DC gain,
     * 1 - c1 - c2 = 4 b0, the step is a_f(k-1) + 4 b0 (q - a_f(k-1)) - c2 (a_f(k-1) -
     * a_f(k-2)), the last difference a_f's last increment: two products by 16-bit factors, whose rounding moves the poles by 2^-17
     * and leaves the DC gain exactly 1 (docs/estimators/acc_kf.md). Returns a_f's
     * increment, eq. 6's difference. */
    int32_t af1 = s->af;
    int32_t a_f = a_m; /* lpf_hz = 0: a_f = a_m */
    int32_t inc;
    int32_t a4 = a_m >> 2;
    if (p->lpf_on) {
        int32_t quarter = a4 + s->am4[0] + s->am4[0] + s->am4[1]; /* no overflow: < 2^31 */
        inc = fx_add(fx_mul_f(fx_sub(quarter, af1, st), p->b4, st), fx_smul_f(s->daf, p->a2), st);
        a_f = fx_add(af1, inc, st);
    } else {
        inc = fx_sub(a_m, af1, st);
    }
    s->am4[1] = s->am4[0];
    s->am4[0] = a4;
    s->af = a_f;
    s->daf = inc;
    return inc;
}

/* x 2^d for a quotient's numerator (d < 0: rounded half up, x's last -d bits dropped);
 * past int32 it returns 0 and sets *over. */
static int32_t numerator(int32_t x, int8_t d, uint8_t *over)
{
    if (d >= 0) {
        uint8_t u = (uint8_t)d;
        int32_t lim = u > 30u ? 0 : (int32_t)fx_shr32((uint32_t)FX_MAX, u);
        if (x > lim || x < -lim - 1) {
            *over = 1;
            return 0;
        }
        return (int32_t)fx_shl32((uint32_t)x, u);
    }
    uint8_t k = (uint8_t)(-d - 1); /* (x + 2^k) >> (k + 1) as ((x >> k) + 1) >> 1 */
    return k > 30u ? 0 : (fx_sar32(x, k) + 1) >> 1;
}

/* x (qa) / b (qb) -> q_out from b's reciprocal r: x r.y 2^(r.n - 60 + qb - qa + q_out), as
 * x shifted by d = r.n - 34 + qb - qa + q_out and one product with the constant shift 26
 * (~300 cycles with the product, where fx_div_by, which first normalises x, costs ~480).
 * A shift that would leave int32 saturates (flagged); a right shift (d < 0: b large)
 * rounds half up and drops x's last -d bits (docs/estimators/acc_kf.md). */
static int32_t quotient(int32_t x, fx_recip_t r, int8_t d, uint8_t *status)
{
    uint8_t over = 0;
    int32_t xs = numerator(x, d, &over);
    if (over) {
        *status |= STATUS_SATURATED;
        return x < 0 ? FX_MIN : FX_MAX;
    }
    return fx_mul_rs(xs, r.y, 26, status);
}

/* A gain x / S (x in Q28, S in Q24 from its 16-bit reciprocal r 2^(n - 46)) to 16 bits:
 * x's leading 16 bits, rounded, times r, rounded to 16 bits again: x / S = ±m 2^-sh with
 * m in [2^15, 2^16), relative error < 1e-4 (r's 5e-5 and two roundings: a gain needs no
 * more than the 16 bits r gives it, docs/estimators/acc_kf.md). gain_factor checks sh
 * against the kernel's range. */
typedef struct {
    uint16_t m;
    int16_t sh;
    uint8_t neg;  /* 0x80 for a negative gain: fx_factor_t's sign bit */
    uint16_t top; /* |x| ~ top 2^e, top in [2^15, 2^16) (0 for x = 0) */
    int8_t e;
} gain_t;

static inline __attribute__((always_inline)) gain_t gain(int32_t x, fx_recip16_t r)
{
    uint8_t neg = x < 0 ? 0x80u : 0u;
    uint32_t a = neg ? 0u - (uint32_t)x : (uint32_t)x;
    if (a == 0u) {
        return (gain_t){0, 16, 0, 0, 0};
    }
    /* a's top bit to bit 31, by words and bytes first (the AVR shifts an int32 a bit at a
     * time): x = a 2^(e - 16) */
    int8_t e = 16;
    if (!(a >> 16)) {
        a <<= 16;
        e = 0;
    }
    if (!(a >> 24)) {
        a <<= 8;
        e = (int8_t)(e - 8);
    }
    while (!(a & 0x80000000u)) {
        a <<= 1;
        e--;
    }
    uint16_t top = (uint16_t)(a >> 16); /* x ~ top 2^e, rounded by a's bit 15 */
    if ((uint8_t)(a >> 8) & 0x80u) {
        top++;
        if (top == 0u) {
            top = 0x8000u;
            e++;
        }
    }
    /* x / S = top r 2^(e + n - 50), top r in [2^30, 2^32) */
    uint32_t prod = fx_umul16x16(top, r.r);
    int16_t sh = (int16_t)(34 - e - (int8_t)r.n);
    if (prod >= UINT32_C(0x7fffc000)) { /* (prod + 2^15) 2^-16 <= 0xfffe */
        return (gain_t){(uint16_t)((prod + 0x8000u) >> 16), sh, neg, top, e};
    }
    return (gain_t){fx_round_q15(prod), (int16_t)(sh + 1), neg, top, e}; /* prod < 2^31 - 2^14 */
}

/* k x in Q30 for the gain k = x / S that gain() made from x (Q28): one 16 x 16 product of
 * their mantissas (relative error < 1e-4, k's own), >= 0 as k and x have one sign;
 * saturated (flagged) past int32. */
static int32_t gain_times_x(gain_t k, uint8_t *status)
{
    uint32_t prod = fx_umul16x16(k.m, k.top);
    int16_t s = (int16_t)(k.sh - k.e - 2); /* k x = prod 2^(e - 28 - sh), Q30 */
    if (s > 32) {
        return 0;
    }
    if (s >= 1) {
        uint32_t x = (fx_shr32(prod, (uint8_t)(s - 1)) + 1u) >> 1; /* rounded half up */
        if (x <= (uint32_t)FX_MAX) {
            return (int32_t)x;
        }
    }
    if (prod == 0u) {
        return 0;
    }
    *status |= STATUS_SATURATED;
    return FX_MAX;
}

/* The gain times 2^up as a factor for fx_mul_f: below 2^-32 it is 0; at 2^16 / 2^9 = 128
 * or past it the largest factor, flagged SATURATED (a gain that large is outside the
 * parameters' physics: k1 <= 1 / c). */
static fx_factor_t gain_factor(gain_t k, uint8_t up, uint8_t *status)
{
    int16_t sh = (int16_t)(k.sh - up);
    if (k.m == 0u || sh > 47) {
        return (fx_factor_t){0, 16};
    }
    if (sh < 9) {
        *status |= STATUS_SATURATED;
        return (fx_factor_t){0xffffu, (uint8_t)(9u | k.neg)};
    }
    return (fx_factor_t){k.m, (uint8_t)((uint8_t)sh | k.neg)};
}

/* R / S as a 16-bit factor (in (0, 1)): R's mantissa at CONFIG (R 2^-7 = m 2^-sh) times
 * 1/S's, one 16 x 16 hardware product normalised to 16 bits. */
static fx_ufactor_t recip_times_r(const acc_kf_params_q_t *p, fx_recip16_t inv_s)
{
    /* R = m 2^(7 - sh), 1 / S = r 2^(n - 46 + 24): R / S = prod 2^-(sh + 15 - n) */
    uint32_t prod = fx_umul16x16(inv_s.r, p->R_f.m); /* in [2^30, 2^32) */
    int16_t sh = (int16_t)(p->R_f.sh + 15 - inv_s.n);
    uint16_t g;
    if (prod & 0x80000000u) {
        g = (uint16_t)(prod >> 16);
        sh = (int16_t)(sh - 16);
    } else {
        g = (uint16_t)((prod << 1) >> 16);
        sh = (int16_t)(sh - 15);
    }
    if (sh < 16) { /* R / S within 2^-15 of 1 */
        return (fx_ufactor_t){0xffffu, 16};
    }
    return sh > 48 ? (fx_ufactor_t){0, 16} : (fx_ufactor_t){g, (uint8_t)sh};
}

/* The gains and the covariance update (eq. 8's C = [c, 0]), their flags kept in p_status.
 * With c = 1 the recursion depends on P alone: once an update leaves P's bits unchanged
 * (p_steady), every later step with c = 1 would compute the same gains and the same P,
 * so step_q reuses them; the bits are those of the full recursion (the steady state of
 * a time-invariant filter, reached in fixed point; docs/estimators/acc_kf.md). */
static __attribute__((noinline)) void covariance_q(const acc_kf_params_q_t *p, acc_kf_q_t *s, int32_t c, uint8_t unit_c)
{
    uint8_t status = 0;
    /* M = A P Aᵀ + Q (P11, P12 Q28; P22 Q30): M11 = P11 - T (2 P12 - T P22) + Q11, two
     * products by T to 16 bits (relative error <= 2^-16: a covariance's rounding) */
    int32_t m12 = fx_sub(s->p12, fx_smul_f(s->p22, p->T_q28), &status); /* Q28 */
    /* 2 P12 - T P22 = P12 + M12 */
    int32_t m11 = fx_add(fx_sub(s->p11, fx_smul_f(fx_add(s->p12, m12, &status), p->T_f), &status),
                         p->q_v, &status);
    int32_t m22 = fx_add(s->p22, p->q_b, &status);
    int32_t cm11 = m11, cm12 = m12;
    int32_t c2m11 = ((m11 >> 3) + 1) >> 1; /* Q24, rounded half up (no overflow) */
    if (!unit_c) {
        cm11 = fx_mul(c, 30, m11, 28, 28, &status);
        cm12 = fx_mul(c, 30, m12, 28, 28, &status);
        c2m11 = fx_mul(c, 30, cm11, 28, 24, &status);
    }
    int32_t S = fx_add(c2m11, p->R, &status); /* Q24 */
    int32_t p11 = m11, p12 = m12, p22 = m22;
    fx_factor_t kv = {0, 16}, ka = {0, 16};
    uint16_t g16 = 0x8000u; /* no update if S is not positive (it is R > 0 or more) */
    if (S > 0) {
        /* the gains and P to 16 bits of 1/S (relative error < 5e-5: a covariance's
         * rounding, docs/estimators/acc_kf.md): P11 - k1 c M11 = M11 g and P12 - k1 c M12
         * = M12 g with g = 1 - c k1 = R / S; k2 c M12 from 16-bit mantissas */
        fx_recip16_t inv_s = fx_recip16(S);
        gain_t k2 = gain(cm12, inv_s);
        kv = gain_factor(gain(cm11, inv_s), 0, &status); /* k1: Q20 e -> Q20 v */
        ka = gain_factor(k2, 4, &status);                /* k2 (1/s): Q20 e -> Q24 a0 */
        fx_ufactor_t g = recip_times_r(p, inv_s);
        p11 = fx_smul_f(m11, g);
        p12 = fx_smul_f(m12, g);
        p22 = fx_sub(m22, gain_times_x(k2, &status), &status);
        g16 = (uint16_t)fx_shr32(g.m, (uint8_t)(g.sh - 15u)); /* Q15 */
    } else {
        status |= STATUS_SINGULAR;
    }
    s->p_steady = unit_c && p11 == s->p11 && p12 == s->p12 && p22 == s->p22;
    s->p11 = p11;
    s->p12 = p12;
    s->p22 = p22;
    s->kv = kv;
    s->ka = ka;
    s->g16 = g16;
    s->p_status = status;
}

/* The health check: ē, the innovation's average over z_window (e clipped to ±8 m/s, in Q28),
 * and R ē²/S = ē² (1 - c k1) (so no division) against R z2_max α / (2 - α), in Q(2 q_e)
 * with ē to 16 bits in Q q_e (q_e from that limit at CONFIG: ē's range 32 times the
 * limit's root, its unit 1/1024 of it). Its own saturation (ē past that range) says "far
 * off", not a saturated estimate. */
#define E_CLIP ((INT32_C(8) << 20) - 1) /* 8 m/s in Q20, so e 2^8 fits Q28 */
static uint8_t health_q(const acc_kf_params_q_t *p, acc_kf_q_t *s, int32_t e)
{
    uint8_t hs = 0;
    int32_t e28 = (int32_t)((uint32_t)(e > E_CLIP ? E_CLIP : (e < -E_CLIP ? -E_CLIP : e)) << 8);
    /* the average's step alpha (e - ē), on its magnitude (a 32 x 24 product inline): both
     * within ±8 m/s, so their difference's magnitude fits 32 bits unsigned */
    uint8_t up = e28 >= s->e_mean;
    uint32_t step = fx_umul_q24(up ? (uint32_t)e28 - (uint32_t)s->e_mean
                                   : (uint32_t)s->e_mean - (uint32_t)e28,
                                p->alpha);
    s->e_mean = up ? (int32_t)((uint32_t)s->e_mean + step) : (int32_t)((uint32_t)s->e_mean - step);
    int32_t e_r = p->e_shift ? (fx_sar32(s->e_mean, (uint8_t)(p->e_shift - 1u)) + 1) >> 1
                             : s->e_mean;
    uint16_t e16 = (uint16_t)(e_r < 0 ? -e_r : e_r); /* |ē|, 16 bits */
    if (e_r > INT16_MAX || e_r < -INT16_MAX) {
        e16 = INT16_MAX;
    }
    uint32_t e2g = fx_umul16_q15(fx_umul16x16(e16, e16), s->g16); /* < 2^30 */
    int32_t out_v = s->v < -p->v_guard ? fx_add(s->v, p->v_guard, &hs)
                                       : (s->v > p->v_max ? fx_sub(s->v, p->v_max, &hs) : 0);
    uint8_t bad = e2g > p->z_lim;
    if (out_v != 0) { /* 9 P11 (Q20), needed only off the plausible range */
        int32_t var9 = fx_mul(s->p11, 28, INT32_C(9) << 24, 24, 20, &hs);
        bad |= fx_mul(out_v, 20, out_v, 20, 20, &hs) > var9;
    }
    return bad ? STATUS_DIVERGED : 0u;
}

static uint8_t step_q(acc_kf_state_t *st, const uint8_t *in, uint8_t *out)
{
    const acc_kf_params_q_t *p = &st->u.q.p;
    acc_kf_q_t *s = &st->u.q.s;
    int32_t a_m = get_i32(in);                         /* Q24 */
    uint8_t status = 0;
    int32_t w_sum = fx_add(get_i32(in + 4), get_i32(in + 8), &status); /* Q16 */
    uint8_t braking = get_i32(in + 12) != 0;
    int32_t v_m = fx_mul(w_sum, 16, p->r_w_half, 28, 20, &status); /* Q20, eq. 3 */
    if (!st->started) {
        st->started = 1;
        s->v = v_m;
        s->a0 = 0;
        s->u_prev = a_m;
        s->am4[0] = s->am4[1] = a_m >> 2;
        s->af = a_m;
        s->daf = 0;
    } else {
        int32_t w2 = 0;
        if (st->corr1) { /* a_f serves correction 1 alone; eq. 6 with r̄ to 16 bits */
            w2 = s->w2_prev;
            s->w2_prev = fx_mul_f(lpf_q(p, s, a_m, &status), p->rbar, &status); /* the next */
        }
        /* c = 1 - slip (eq. 8); c = 1, every step without the correction, multiplies
         * exactly, so those steps skip c's products and keep the same bits. */
        uint8_t unit_c = !(braking && st->corr2 && s->slip != 0);
        int32_t c = unit_c ? ONE_Q30 : fx_sub(ONE_Q30, s->slip, &status); /* slip in (0, s_max] */
        if (!unit_c || !s->p_steady) {
            covariance_q(p, s, c, unit_c);
        }
        status |= s->p_status;
        /* v⁻ = v + T (u - a0): Q30 · Q24 -> Q20 */
        int32_t v_pred =
            fx_add(s->v, fx_mul(p->T, 30, fx_sub(s->u_prev, s->a0, &status), 24, 20, &status), &status);
        int32_t b_pred = fx_add(s->a0, w2, &status);
        int32_t c_v_pred = unit_c ? v_pred : fx_mul(c, 30, v_pred, 20, 20, &status);
        int32_t e = fx_sub(v_m, c_v_pred, &status); /* Q20 */
        s->v = fx_add(v_pred, fx_mul_f(e, s->kv, &status), &status);
        s->a0 = fx_add(b_pred, fx_mul_f(e, s->ka, &status), &status);
        status |= health_q(p, s, e);
        if (braking && s->v > p->v_guard) {
            fx_recip_t inv_v = fx_recip(s->v); /* s->v > v_guard > 0 */
            int32_t slip = /* Q20 / Q20 -> Q30 */
                fx_sub(ONE_Q30, quotient(v_m, inv_v, (int8_t)(inv_v.n - 4), &status), &status);
            if (slip < 0 || slip > p->s_max) {
                status |= STATUS_CLAMPED;
                slip = slip < 0 ? 0 : p->s_max;
            }
            s->slip = slip;
        } else {
            s->slip = 0;
        }
        s->u_prev = a_m;
    }
    put_i32(out, ((s->v >> 3) + 1) >> 1); /* Q20 -> Q16, rounded half up */
    put_i32(out + 4, s->a0);
    return status;
}

/* -- the estimator interface --------------------------------------------- */

static void acc_kf_reset(void *state)
{
    acc_kf_state_t *st = state;
    st->started = 0;
    if (st->mode == MODE_F32) {
        reset_f32(&st->u.f32.p, &st->u.f32.s);
    } else {
        reset_q(&st->u.q.p, &st->u.q.s);
    }
}

/* The step's numbers from the physical parameters and T, in float32 for either mode
 * (only IEEE operations, so the AVR and the host derive the same bits). */
typedef struct {
    float q_v, q_b, b0, c[2]; /* eq. 4b: b = b0 (1, 2, 1) */
    uint8_t lpf_on;           /* lpf_hz > 0 (else a_f = a_m) */
} per_step_t;

static uint8_t derive(const uint8_t *params, uint8_t mode, per_step_t *d)
{
    float T = param_value(params, P_T, mode, 30);
    float fc = param_value(params, P_LPF, mode, 24);
    if (fc * T > ACC_KF_LPF_MAX_FC_T) {
        return (uint8_t)(P_LPF + 1u);
    }
    float q_v = param_value(params, P_NV, mode, 27) * T;
    float q_b = param_value(params, P_NB, mode, 30) * T;
    if (fc > 0.0f) {
        biquad_f32_t lp = butter2_lp(fc, T);
        *d = (per_step_t){q_v, q_b, lp.b0, {-lp.a1, -lp.a2}, 1};
    } else {
        *d = (per_step_t){q_v, q_b, 0.0f, {0.0f, 0.0f}, 0};
    }
    return 0;
}

static uint8_t acc_kf_configure(void *state, uint8_t mode, const uint8_t *params)
{
    acc_kf_state_t *st = state;
    per_step_t d;
    uint8_t bad = params_check(params, mode, ranges, N_PARAMS);
    if (bad == 0) {
        bad = derive(params, mode, &d);
    }
    if (bad != 0) {
        return bad;
    }
    st->mode = mode;
    st->corr1 = param_value(params, P_C1, mode, 0) >= 0.5f;
    st->corr2 = param_value(params, P_C2, mode, 0) >= 0.5f;
    if (mode == MODE_F32) {
        acc_kf_params_f32_t *p = &st->u.f32.p;
        p->T = get_f32(params + 4u * P_T);
        p->r_w_half = 0.5f * get_f32(params + 4u * P_RW);
        p->q_v = d.q_v;
        p->q_b = d.q_b;
        p->R = get_f32(params + 4u * P_R);
        p->p0_v = get_f32(params + 4u * P_P0V);
        p->p0_b = get_f32(params + 4u * P_P0B);
        p->rbar = get_f32(params + 4u * P_RBAR);
        p->v_guard = get_f32(params + 4u * P_VG);
        p->s_max = get_f32(params + 4u * P_SMAX);
        p->alpha = p->T / get_f32(params + 4u * P_ZWIN);
        p->z_lim = get_f32(params + 4u * P_Z2MAX) * p->alpha / (2.0f - p->alpha);
        p->v_max = get_f32(params + 4u * P_VMAX);
        p->lpf_on = d.lpf_on;
        p->b0 = d.b0;
        for (uint8_t i = 0; i < 2u; i++) {
            p->c[i] = d.c[i];
        }
    } else {
        acc_kf_params_q_t *p = &st->u.q.p;
        uint8_t sat = 0;
        p->T = param_q(params, P_T);
        p->T_f = fx_ufactor((uint32_t)p->T, 30);
        p->T_q28 = (fx_ufactor_t){p->T_f.m, (uint8_t)(p->T_f.sh + 2u)}; /* T P22 to Q28 */
        p->r_w_half = (int32_t)((uint32_t)param_q(params, P_RW) << 3); /* Q24 -> r_w / 2 in Q28 */
        p->q_v = fx_from_float(d.q_v, 28, &sat);
        p->q_b = fx_from_float(d.q_b, 30, &sat);
        p->R = param_q(params, P_R);
        p->R_f = fx_ufactor((uint32_t)p->R, 31); /* R 2^-7 < 1 */
        p->p0_v = fx_rescale(param_q(params, P_P0V), 24, 28, &sat);
        p->p0_b = param_q(params, P_P0B);
        p->rbar = fx_factor(param_value(params, P_RBAR, mode, 30), 0, &sat);
        p->v_guard = fx_rescale(param_q(params, P_VG), 16, 20, &sat);
        p->s_max = param_q(params, P_SMAX);
        float T = param_value(params, P_T, mode, 30);
        float alpha = T / param_value(params, P_ZWIN, mode, 24); /* in [1e-6, 1] */
        p->alpha = (uint32_t)fx_from_float(alpha < 1.0f ? alpha : 0.99999994f, 24, &sat);
        /* the health check's ē in Q q_e: 2^15 units reach 32 times the limit's root */
        float lim = param_value(params, P_R, mode, 24) * param_value(params, P_Z2MAX, mode, 16) *
                    alpha / (2.0f - alpha);
        uint8_t q_e = 0; /* the largest q_e <= 28 with 1024 lim 2^(2 q_e) <= 2^30 */
        for (float x = 4096.0f * lim; q_e < 28u && x <= 1073741824.0f; x *= 4.0f) {
            q_e++;
        }
        p->e_shift = (uint8_t)(28u - q_e);
        p->z_lim = (uint32_t)fx_from_float(lim, (uint8_t)(2u * q_e), &sat);
        p->v_max = fx_rescale(param_q(params, P_VMAX), 16, 20, &sat);
        p->lpf_on = d.lpf_on;
        p->b4 = fx_factor(4.0f * d.b0, 0, &sat);
        p->a2 = fx_ufactor((uint32_t)fx_from_float(-d.c[1], 31, &sat), 31); /* in [0, 1) */
    }
    acc_kf_reset(st);
    return 0;
}

static uint8_t acc_kf_step(void *state, const uint8_t *in, uint8_t in_len, uint8_t *out,
                           uint8_t *out_len)
{
    acc_kf_state_t *st = state;
    (void)in_len; /* the dispatcher checked it against n_inputs */
    *out_len = 8;
    return st->mode == MODE_F32 ? step_f32(st, in, out) : step_q(st, in, out);
}

const ROM estimator_t acc_kf_estimator = {
    .id = ACC_KF_ID,
    .name = "acc_kf",
    .modes = (1u << MODE_F32) | (1u << MODE_FIXED),
    .n_inputs = 4,
    .n_outputs = 2,
    .n_params = N_PARAMS,
    .configure = acc_kf_configure,
    .reset = acc_kf_reset,
    .step = acc_kf_step,
};
