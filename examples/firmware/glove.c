/* glove.c -- example firmware: seven SEAs in one 100 Hz tick (see glove.h). */
#include "glove.h"

void glove_init(glove_t *g, const int32_t *enc, const int32_t *pot)
{
    int i;
    for (i = 0; i < GLOVE_N_SEA; ++i) {
        sea_features_reset(&g->feat[i]);
        ctl_mlp_controller_init_shared(&g->ctl[i], enc[i], pot[i], &g->f[i]);
    }
}

void glove_tick(glove_t *g, const int32_t *enc, const int32_t *pot, const int32_t *force_q16, int32_t *motor_mv,
                int16_t *force_est)
{
    int i;
    for (i = 0; i < GLOVE_N_SEA; ++i) {
        sea_features_step(&g->feat[i], CAL_MLP_ACT, enc[i], pot[i], &g->f[i]);
        force_est[i] = cal_mlp_step_features(&g->f[i]);
        motor_mv[i] = ctl_mlp_controller_tick(&g->ctl[i], enc[i], pot[i], force_q16[i]);
    }
}
