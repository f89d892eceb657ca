/* sea_features.c -- the feature pipeline (contract in sea_features.h); twin: seagen/quant/features.py. */
#include "sea_features.h"

void sea_features_reset(sea_features_state *s)
{
    int k;
    for (k = 0; k < SEA_FEAT_N_BASE; ++k) {
        s->p1[k] = 0;
        s->p2[k] = 0;
    }
    s->primed = 0;
}

void sea_features_step(sea_features_state *s, const sea_act *act, int32_t enc, int32_t pot, sea_features_out *f)
{
    int k;
    f->act = act;
    f->b[SEA_FEAT_POT] = pot;
    f->b[SEA_FEAT_ENC] = enc;
    f->b[SEA_FEAT_COMP] = sea_compression_q16(act, enc, pot);
    if (!s->primed) {
        for (k = 0; k < SEA_FEAT_N_BASE; ++k) {
            s->p1[k] = f->b[k];
            s->p2[k] = f->b[k];
        }
        s->primed = 1;
    }
    for (k = 0; k < SEA_FEAT_N_BASE; ++k) {
        f->p1[k] = s->p1[k];
        f->p2[k] = s->p2[k];
        s->p2[k] = s->p1[k];
        s->p1[k] = f->b[k];
    }
}
