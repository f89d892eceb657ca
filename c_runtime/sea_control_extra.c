/* sea_control_extra.c -- the controller API for hand-written firmware (sea_control_extra.h): an outside
 * desired compression and the kinematic predictor. Not part of an export (its generated controller does not
 * call them); twin: seagen/control/controller.py. */
#include "sea_control_extra.h"

void sea_control_set_desired(sea_control_state *s, int32_t desired_q16)
{
    s->desired = desired_q16;
}

int32_t sea_predict_kinematic(void *ctx, int32_t enc, int32_t pot, int32_t force_q16)
{
    const sea_kin_params *k = (const sea_kin_params *)ctx;
    int64_t f = sea_sat32((int64_t)force_q16 + k->friction_q16); /* |f| < 2^31: product < 2^62 */
    (void)enc;
    (void)pot;
    return sea_sat32(sea_rshift_rne_s64(f * k->inv_k_q16, SEA_FORCE_FRAC_BITS));
}
