/* sea_features.h -- the feature pipeline of every generated model (twin: seagen/quant/features.py).
 *
 * One call per control-loop sample with the raw encoder and pot counts and the actuator's constants
 * (a `const sea_act *`, sea_fixed.h; the generated sea_act_<id>.c):
 *   base signals  b[SEA_FEAT_POT] = pot (counts, Q0), b[SEA_FEAT_ENC] = enc (counts, Q0),
 *                 b[SEA_FEAT_COMP] = sea_compression_q16(act, enc, pot) (Q16 mm, Eq. 2);
 *   angle         pot * act->pot_deg_q24 + act->pot_offset_q24 (Q24 deg, Eq. 5; exact in int64);
 *   differences   d = b - b[-1], dd = b - 2 b[-1] + b[-2] per base signal (exact in int64);
 *   warm-up       the first step after sea_features_reset takes b[-1] = b[-2] = b (d = dd = 0); the
 *                 second takes b[-2] = b[-1] (the previous sample).
 * A step records b, b[-1] and b[-2]; sea_features_value forms the one value a model input uses (a base
 * signal, a difference or the angle), and NAME_step converts it to the input's Q format with sea_to_s16
 * (rounding half to even, then saturation). Called with constant kind and index, it folds to that value.
 */
#ifndef SEA_FEATURES_H
#define SEA_FEATURES_H

#include <stdint.h>

#include "sea_fixed.h"

#ifdef __cplusplus
extern "C" {
#endif

#define SEA_FEAT_N_BASE 3 /* base signals carried in the state */
#define SEA_FEAT_POT 0
#define SEA_FEAT_ENC 1
#define SEA_FEAT_COMP 2

/* What a model input is (the kind argument of sea_features_value). */
#define SEA_FEAT_BASE 0     /* b[index] */
#define SEA_FEAT_D 1        /* d[index] */
#define SEA_FEAT_DD 2       /* dd[index] */
#define SEA_FEAT_ANGLE 3    /* angle_q24 */
#define SEA_FEAT_EXTERNAL 4 /* ext[index]: an already quantized argument (the desired force) */
#define SEA_FEAT_ANGLE_FRAC_BITS 24

/* The previous two samples of each base signal. */
typedef struct {
    int32_t p1[SEA_FEAT_N_BASE];
    int32_t p2[SEA_FEAT_N_BASE];
    uint8_t primed; /* 0 after sea_features_reset */
} sea_features_state;

/* One step's samples: the base signals and the two before them (warm-up applied), and the actuator. */
typedef struct {
    const sea_act *act;
    int32_t b[SEA_FEAT_N_BASE];
    int32_t p1[SEA_FEAT_N_BASE];
    int32_t p2[SEA_FEAT_N_BASE];
} sea_features_out;

/* Start a new run of samples: the next step has no history. */
/*@ requires \valid(s);
    assigns *s;
    ensures s->primed == 0; */
void sea_features_reset(sea_features_state *s);

/* One sample from raw counts (any int32 enc, pot): base signals and their history; updates the state. */
/*@ requires \valid(s) && \valid(f) && \valid_read(act) && \separated(s, f);
    assigns *s, *f;
    ensures s->primed == 1 && f->act == act; */
void sea_features_step(sea_features_state *s, const sea_act *act, int32_t enc, int32_t pot, sea_features_out *f);

/* The value of `kind` for base signal `index` (exact): SEA_FEAT_BASE b (pot, enc Q0; compression Q16 mm),
 * SEA_FEAT_D b - b[-1], SEA_FEAT_DD b - 2 b[-1] + b[-2], SEA_FEAT_ANGLE the angle (Q24 deg; index unused).
 * SEA_FEAT_EXTERNAL inputs are arguments of NAME_step, not values of the pipeline. */
/*@ requires \valid_read(f) && 0 <= index < SEA_FEAT_N_BASE;
    requires kind == SEA_FEAT_ANGLE ==> \valid_read(f->act);
    assigns \nothing; */
static inline int64_t sea_features_value(const sea_features_out *f, int kind, int index)
{
    switch (kind) {
    case SEA_FEAT_D:
        return (int64_t)f->b[index] - f->p1[index];
    case SEA_FEAT_DD:
        return ((int64_t)f->b[index] - (2 * (int64_t)f->p1[index])) + f->p2[index];
    case SEA_FEAT_ANGLE:
        return ((int64_t)f->b[SEA_FEAT_POT] * f->act->pot_deg_q24) + f->act->pot_offset_q24;

    default:
        return f->b[index];
    }
}

#ifdef __cplusplus
}
#endif

#endif
