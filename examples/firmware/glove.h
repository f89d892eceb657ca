/* glove.h -- example firmware for the exoskeleton glove: seven SEAs served in one 100 Hz tick.
 *
 * Each actuator gets its calibrated force estimate (the calibration MLP on raw counts) and its force loop
 * (ctl_mlp_controller_tick: the control MLP as the predictor of the tuned two-level controller). Both models
 * read one feature pipeline per actuator (sea_features_step once per tick: cal_mlp_step_features, and the
 * controller set up by ctl_mlp_controller_init_shared), the same integers as each running its own.
 * Everything it includes comes from two seagen exports into one folder (see README.md):
 *     seagen export generated/models/mlp_calibration.pt --prefix cal_mlp [--target CORE] --out build
 *     seagen export generated/models/mlp_control.pt --prefix ctl_mlp --controller [--target CORE] --out build
 * Integers only, no malloc: the caller owns the glove_t (e.g. one static instance).
 */
#ifndef GLOVE_H
#define GLOVE_H

#include <stdint.h>

#include "cal_mlp.h"
#include "ctl_mlp_controller.h"

#define GLOVE_N_SEA 7

#if CAL_MLP_ACT_KEY != CTL_MLP_ACT_KEY
#error "cal_mlp and ctl_mlp were exported for different actuators: they cannot share a feature pipeline"
#endif

typedef struct {
    sea_features_state feat[GLOVE_N_SEA];  /* feature pipeline of each actuator, shared by its two models */
    sea_features_out f[GLOVE_N_SEA];       /* its output of the current tick */
    ctl_mlp_controller_t ctl[GLOVE_N_SEA]; /* force loop of each actuator */
} glove_t;

/* Start every actuator at its current raw readings (enc, pot: GLOVE_N_SEA counts each). */
void glove_init(glove_t *g, const int32_t *enc, const int32_t *pot);

/* One 10 ms tick for all actuators: raw counts and desired forces (Q16 N at the shaft) in; motor commands
 * (mV) and calibrated force estimates (int16, Q CAL_MLP_OUT_Q newtons) out. */
void glove_tick(glove_t *g, const int32_t *enc, const int32_t *pot, const int32_t *force_q16, int32_t *motor_mv,
                int16_t *force_est);

#endif /* GLOVE_H */
