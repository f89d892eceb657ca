/* sea_features.c -- the feature pipeline (contract in sea_features.h); twin: seagen/quant/features.py. */
#include "sea_features.h"
#include "sea_nn.h"

void sea_features_reset(sea_features_state *s)
{
    int k;
    for (k = 0; k < SEA_FEAT_N_BASE; ++k) {
        s->p1[k] = 0;
        s->p2[k] = 0;
    }
    s->primed = 0;
}

void sea_features_step(sea_features_state *s, const int32_t table[SEA_LINK_TABLE_LEN], int32_t enc, int32_t pot,
                       sea_features_out *f)
{
    int k;
    f->b[SEA_FEAT_POT] = pot;
    f->b[SEA_FEAT_ENC] = enc;
    f->b[SEA_FEAT_COMP] = sea_compression_q16(table, enc, pot);
    f->angle_q24 = (int64_t)pot * SEA_POT_DEG_Q24 + SEA_POT_OFFSET_Q24;
    if (!s->primed) {
        for (k = 0; k < SEA_FEAT_N_BASE; ++k) {
            s->p1[k] = f->b[k];
            s->p2[k] = f->b[k];
        }
        s->primed = 1;
    }
    for (k = 0; k < SEA_FEAT_N_BASE; ++k) {
        f->d[k] = (int64_t)f->b[k] - s->p1[k];
        f->dd[k] = (int64_t)f->b[k] - 2 * (int64_t)s->p1[k] + s->p2[k];
        s->p2[k] = s->p1[k];
        s->p1[k] = f->b[k];
    }
}

/* The value a plan entry names, in its own format (externals are handled by the caller). */
static int64_t sea_features_value(const sea_features_out *f, const sea_feature_src *src)
{
    switch (src->kind) {
    case SEA_FEAT_D:
        return f->d[src->index];
    case SEA_FEAT_DD:
        return f->dd[src->index];
    case SEA_FEAT_ANGLE:
        return f->angle_q24;
    default:
        return f->b[src->index];
    }
}

void sea_features_inputs(const sea_features_out *f, const sea_feature_src *plan, int n, const int16_t *ext,
                         int16_t *in)
{
    int i;
    for (i = 0; i < n; ++i) {
        if (plan[i].kind == SEA_FEAT_EXTERNAL) {
            in[i] = ext[plan[i].index];
        } else {
            in[i] = sea_to_s16(sea_features_value(f, &plan[i]), plan[i].from_frac, plan[i].to_frac);
        }
    }
}
