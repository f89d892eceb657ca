/* sea_control.h -- the paper's two-level SEA force controller (Figs. 11-12), one call per control tick.
 *
 *   tick:  pot summed over act->pot_avg_ticks ticks (the loop rate / 10 Hz: 10 at 100 Hz); when a block is
 *          full the average is refreshed (10 Hz, rounded half to even); compression =
 *          sea_compression_q16(act, enc, pot average) (Q16 mm, every tick);
 *          every `predict_every` ticks the predictor maps (enc, pot, desired force) to a prediction;
 *          the desired compression is the mean of the last `pred_avg` predictions; the PID (sea_pid.h)
 *          drives the compression there; returns the motor command, mV.
 *   faults: pot stuck at a rail, impossible encoder jump, desired force outside the calibrated range ->
 *          safe state: motor 0 mV, integrator cleared, fault bits latched until sea_control_reset().
 * Integers only, no malloc, C99. Twin: seagen/control/controller.py. Contract: c_runtime/README.md.
 */
#ifndef SEA_CONTROL_H
#define SEA_CONTROL_H

#include <stddef.h>
#include <stdint.h>

#include "sea_fixed.h"
#include "sea_pid.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SEA_CTRL_PRED_AVG_MAX 10    /* the desired compression is the mean of the last pred_avg predictions */
/* The pot-average length, the default encoder-jump bound (twice the no-load counts per tick) and the default
 * stuck-pot ticks (100 ms) are the actuator's: act->pot_avg_ticks, act->enc_jump_max, act->pot_stuck_ticks. */

#define SEA_FAULT_NONE 0
#define SEA_FAULT_POT_STUCK_LOW 1  /* pot read 0 for pot_stuck_ticks consecutive ticks */
#define SEA_FAULT_POT_STUCK_HIGH 2 /* pot read act->pot_max for pot_stuck_ticks consecutive ticks */
#define SEA_FAULT_ENC_JUMP 4       /* |enc - previous enc| > enc_jump_max in one tick */
#define SEA_FAULT_FORCE_RANGE 8    /* desired force outside [force_min, force_max] */

/* A high-level predictor: raw encoder counts, raw pot counts, desired force (Q16 N) -> desired spring
 * compression (Q16 mm). Generated models provide functions of this type; ctx is theirs. */
typedef int32_t (*sea_predictor_fn)(void *ctx, int32_t enc, int32_t pot, int32_t force_q16);

typedef struct {
    sea_pid_params pid;
    const sea_act *act;         /* the actuator's constants (sea_fixed.h; generated sea_act_<id>.c) */
    sea_predictor_fn predictor; /* NULL: desired compression supplied by sea_control_set_desired() */
    void *predictor_ctx;
    int32_t predict_every;      /* ticks between predictor calls: 1 = every tick (< 1 means 1) */
    int32_t pred_avg;           /* predictions averaged into the desired compression, 1..10 (clamped) */
    int32_t force_min;          /* calibrated range of the desired force, Q16 N */
    int32_t force_max;
    int32_t enc_jump_max;       /* counts per tick (default act->enc_jump_max) */
    int32_t pot_stuck_ticks;    /* consecutive rail readings that make a fault (< 1 means 1; act's default) */
} sea_control_config;

typedef struct {
    sea_pid_state pid;
    int64_t pot_sum;   /* raw pot readings of the current block, summed */
    int32_t pot_idx;   /* readings in pot_sum; the average refreshes when it reaches act->pot_avg_ticks */
    int32_t pot_avg;   /* the averaged pot, counts */
    int32_t pred_count; /* ticks since the last predictor call, 0..predict_every-1 */
    int32_t pred_buf[SEA_CTRL_PRED_AVG_MAX]; /* the last predictions (Q16 mm), ring of pred_avg */
    int32_t pred_idx;  /* next slot in pred_buf */
    int32_t enc_prev;  /* encoder at the previous tick */
    int32_t stuck_lo;  /* consecutive ticks with pot <= 0 */
    int32_t stuck_hi;  /* consecutive ticks with pot >= act->pot_max */
    int32_t desired;   /* desired compression, Q16 mm */
    int32_t comp;      /* measured compression, Q16 mm */
    int32_t fault;     /* latched SEA_FAULT_* bits; nonzero = safe state */
    int32_t out;       /* last motor command, mV */
} sea_control_state;

/* Start (or restart after a fault): clears faults, starts a pot block with average `pot`, measures the
 * compression, holds it as the desired compression, resets the PID bumplessly to 0 mV. */
/*@ requires \valid_read(c) && \valid(s) && \valid_read(c->act) && c->pid.out_min <= c->pid.out_max;
    assigns *s;
    ensures s->fault == 0; */
void sea_control_reset(const sea_control_config *c, sea_control_state *s, int32_t enc, int32_t pot);

/* One tick with raw encoder counts, raw pot counts and the desired force (Q16 N at the shaft).
 * Returns the motor command in mV (0 in the safe state); s->fault holds the latched fault bits. */
/* Contract: the predictor writes at most the object its ctx points to (a generated NAME_predict_q16: its
 * NAME_state_t; NAME_predict_features_q16 and sea_predict_kinematic write nothing). */
/*@ requires \valid_read(c) && \valid(s) && \valid_read(c->act) && c->pid.out_min <= c->pid.out_max;
    assigns *s, ((char *)c->predictor_ctx)[0 .. \block_length(c->predictor_ctx) - 1];
    ensures \result == 0 || (c->pid.out_min <= \result <= c->pid.out_max); */
int32_t sea_control_step(const sea_control_config *c, sea_control_state *s, int32_t enc, int32_t pot,
                         int32_t force_q16);

#ifdef __cplusplus
}
#endif

#endif
