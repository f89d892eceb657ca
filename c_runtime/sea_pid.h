/* sea_pid.h -- fixed-point PID for spring-compression control (hand-written C; contract: c_runtime/README.md).
 *
 * Parallel form, one call per control tick:
 *   e     = setpoint - meas                          (Q16 mm, saturated to int32)
 *   e     = 0 if |e| <= margin                       (control margin: no P action, integrator held)
 *   d     = d + alpha (meas - meas_prev - d)         (first-order filter of the measurement's rate)
 *   P     = kp e,  I += ki e (anti-windup),  D = -kd d   (all Q16 mV)
 *   out   = clamp(round(P + I + D), out_min, out_max) (int32 millivolts: any supply, a 48 V motor included)
 * Every shift rounds half to even (sea_rshift_rne_s64); every narrowing saturates first. The Python twin
 * seagen/control/pid.py computes the same integers. Integers only; no float, no malloc; C99.
 */
#ifndef SEA_PID_H
#define SEA_PID_H

#include <stdint.h>

#include "sea_fixed.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SEA_PID_GAIN_FRAC 12   /* kp, ki, kd: signed Q19.12 in int32 (gains >= 1 up to ~524,287) */
#define SEA_PID_ALPHA_FRAC 16  /* derivative filter coefficient: Q16 in [0, 65536]; 65536 = no filter */
#define SEA_PID_OUT_FRAC 16    /* integrator and term sums: Q16 millivolts */

typedef struct {
    int32_t kp;      /* mV per mm of compression error, Q12 */
    int32_t ki;      /* mV per mm per tick, Q12 (integral gain times the tick) */
    int32_t kd;      /* mV per (mm per tick), Q12 (derivative gain over the tick), on -d(meas)/dt */
    int32_t d_alpha; /* derivative filter: d += alpha (x - d), Q16, clamped to [0, 65536] */
    int32_t margin;  /* control margin, Q16 mm (0.1 mm = 6554); negative means none */
    int32_t out_min; /* command range, mV (out_min <= out_max; within +-act->motor_max_mv, sea_fixed.h) */
    int32_t out_max; /* mV; |out_min|, |out_max| < 2^31 */
} sea_pid_params;

typedef struct {
    int64_t integ;     /* integrator, Q16 mV, always inside [out_min, out_max] (|integ| < 2^47) */
    int32_t d_filt;    /* filtered measurement rate, Q16 mm per tick */
    int32_t meas_prev; /* the previous measurement, Q16 mm */
    int32_t out;       /* the last command, mV */
} sea_pid_state;

/* Bumpless (re)start: the integrator takes `out` (clamped to the range, Q16), the derivative filter is
 * cleared and the previous measurement set to `meas`, so a following step with |e| <= margin and an
 * unchanged measurement returns exactly `out`. sea_pid_reset(p, s, meas, 0) clears the integrator. */
/*@ requires \valid_read(p) && \valid(s) && p->out_min <= p->out_max;
    assigns *s;
    ensures s->d_filt == 0; */
void sea_pid_reset(const sea_pid_params *p, sea_pid_state *s, int32_t meas, int32_t out);

/* One tick: setpoint and measurement in Q16 mm (any int32); returns the command in mV (also s->out). */
/*@ requires \valid_read(p) && \valid(s) && p->out_min <= p->out_max;
    assigns *s;
    ensures p->out_min <= \result <= p->out_max; */
int32_t sea_pid_step(const sea_pid_params *p, sea_pid_state *s, int32_t setpoint, int32_t meas);

#ifdef __cplusplus
}
#endif

#endif
