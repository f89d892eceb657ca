/* sea_control_extra.h -- the controller API for hand-written firmware (sea_control.h): an outside desired
 * compression and the kinematic predictor. Not part of an export (its generated controller does not use it). */
#ifndef SEA_CONTROL_EXTRA_H
#define SEA_CONTROL_EXTRA_H

#include <stdint.h>

#include "sea_control.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Desired compression (Q16 mm) from outside (the "cloud" predictor); kept until the next call.
 * With a predictor configured, the predictor overwrites it at its next call. */
/*@ requires \valid(s);
    assigns s->desired;
    ensures s->desired == desired_q16; */
void sea_control_set_desired(sea_control_state *s, int32_t desired_q16);

/* The kinematic inverse as a predictor: compression = (F + friction) * inv_k, rounded half to even. */
typedef struct {
    int32_t friction_q16; /* actuator friction, Q16 N (2.7 N = 176947) */
    int32_t inv_k_q16;    /* 1 / spring rate, Q16 mm per N (1 / 4.2 = 15604) */
} sea_kin_params;

/*@ requires \valid_read((const sea_kin_params *)ctx);
    assigns \nothing; */
int32_t sea_predict_kinematic(void *ctx, int32_t enc, int32_t pot, int32_t force_q16);

#ifdef __cplusplus
}
#endif

#endif
