/* sea_pid.c -- fixed-point PID (contract: sea_pid.h, c_runtime/README.md); twin: seagen/control/pid.py. */
#include "sea_pid.h"

#define SEA_PID_TERM_SHIFT (SEA_PID_GAIN_FRAC + SEA_COMP_FRAC_BITS - SEA_PID_OUT_FRAC)
#define SEA_PID_ONE_MV ((int64_t)1 << SEA_PID_OUT_FRAC)

/* round(a b / 2^s), half to even, for any int32 a, b and 1 <= s <= 31: the same integer as
 * sea_rshift_rne_s64((int64_t)a * b, s), with a b formed from four 16 x 16 -> 32-bit products
 * (a = ah 2^16 + al, ah signed, al unsigned), so that a core without a long multiply (ARMv6-M: __aeabi_lmul)
 * calls no helper. Inline: s is a constant at every call. */
static inline int64_t sea_pid_mul_rne(int32_t a, int32_t b, int s)
{
    const int32_t ah = a >> 16; /* arithmetic shift: checked in sea_fixed.h */
    const int32_t bh = b >> 16;
    const uint32_t al = (uint32_t)a & 0xFFFFu;
    const uint32_t bl = (uint32_t)b & 0xFFFFu;
    /* |ah bl|, |al bh| < 2^31; |ah bh| <= 2^30; al bl < 2^32 */
    const int64_t mid = (int64_t)(ah * (int32_t)bl) + ((int32_t)al * bh);

    const int64_t p = ((int64_t)(ah * bh) * 4294967296) + (mid * 65536) + (int64_t)(al * bl);
    const int64_t q = p >> s; /* floor */
    const uint32_t r = (uint32_t)p & (((uint32_t)1 << s) - 1u);
    const uint32_t half = (uint32_t)1 << (s - 1);
    return ((r > half) || ((r == half) && ((q & 1) != 0))) ? (q + 1) : q;
}

void sea_pid_reset(const sea_pid_params *p, sea_pid_state *s, int32_t meas, int32_t out)
{
    int64_t o = sea_clamp_s64(out, p->out_min, p->out_max);
    s->integ = o * SEA_PID_ONE_MV; /* |o| <= 2^31: o * 2^16 fits int64 */
    s->d_filt = 0;
    s->meas_prev = meas;
    s->out = sea_sat32(o);
}

/* Filtered rate of the measurement, Q16 mm per tick; |alpha * (x - d)| < 2^17 * 2^33: fits int64. */
static int32_t sea_pid_rate(const sea_pid_params *p, const sea_pid_state *s, int32_t meas)
{
    int64_t alpha = sea_clamp_s64(p->d_alpha, 0, (int64_t)1 << SEA_PID_ALPHA_FRAC);
    int64_t x = sea_sat32((int64_t)meas - s->meas_prev);
    int64_t diff = x - s->d_filt;
    int64_t step = ((diff >= INT32_MIN) && (diff <= INT32_MAX))
                       ? sea_pid_mul_rne((int32_t)alpha, (int32_t)diff, SEA_PID_ALPHA_FRAC)
                       : sea_rshift_rne_s64(alpha * diff, SEA_PID_ALPHA_FRAC);
    return sea_sat32(s->d_filt + step);
}

int32_t sea_pid_step(const sea_pid_params *p, sea_pid_state *s, int32_t setpoint, int32_t meas)
{
    const int64_t lo = (int64_t)p->out_min * SEA_PID_ONE_MV; /* Q16 mV */
    const int64_t hi = (int64_t)p->out_max * SEA_PID_ONE_MV;
    int32_t margin = (p->margin < 0) ? 0 : p->margin;
    int32_t e = sea_sat32((int64_t)setpoint - meas);
    int64_t pterm;
    int64_t dterm;
    int64_t inc;
    int64_t integ;
    int64_t u;

    s->d_filt = sea_pid_rate(p, s, meas);
    s->meas_prev = meas;
    if ((e >= -margin) && (e <= margin)) {
        e = 0; /* inside the control margin: no P action and the integrator is held */
    }
    /* |gain| < 2^31 and |e|, |d_filt| < 2^31: products < 2^62; terms < 2^50 after the shift. */
    pterm = sea_pid_mul_rne(p->kp, e, SEA_PID_TERM_SHIFT);
    dterm = -sea_pid_mul_rne(p->kd, s->d_filt, SEA_PID_TERM_SHIFT);
    inc = sea_pid_mul_rne(p->ki, e, SEA_PID_TERM_SHIFT);
    integ = sea_clamp_s64(s->integ + inc, lo, hi); /* |integ| <= 2^47, |inc| < 2^50 */
    u = pterm + integ + dterm;
    if (((u > hi) && (inc > 0)) || ((u < lo) && (inc < 0))) {

        integ = s->integ; /* anti-windup: no integration deeper into saturation */
        u = pterm + integ + dterm;
    }
    s->integ = integ; /* within [lo, hi] */
    s->out = sea_sat32(sea_clamp_s64(sea_rshift_rne_s64(u, SEA_PID_OUT_FRAC), p->out_min, p->out_max));
    return s->out;
}
