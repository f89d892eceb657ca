/* sea_features.h -- the feature pipeline of every generated model (twin: seagen/quant/features.py).
 *
 * One call per 100 Hz sample with the raw encoder and pot counts:
 *   base signals  b[SEA_FEAT_POT] = pot (counts, Q0), b[SEA_FEAT_ENC] = enc (counts, Q0),
 *                 b[SEA_FEAT_COMP] = sea_compression_q16(table, enc, pot) (Q16 mm, Eq. 2);
 *   angle         angle_q24 = pot * SEA_POT_DEG_Q24 + SEA_POT_OFFSET_Q24 (Q24 deg, Eq. 5; exact in int64);
 *   differences   d = b - b[-1], dd = b - 2 b[-1] + b[-2] per base signal (exact in int64);
 *   warm-up       the first step after sea_features_reset takes b[-1] = b[-2] = b (d = dd = 0); the
 *                 second takes b[-2] = b[-1] (the previous sample).
 * A model's plan (one sea_feature_src per model input) picks one of these values per input and converts
 * it to an int16 in the input's Q format with sea_to_s16 (rounding half to even, then saturation).
 */
#ifndef SEA_FEATURES_H
#define SEA_FEATURES_H

#include <stddef.h>
#include <stdint.h>

#include "sea_fixed.h"

#define SEA_FEAT_N_BASE 3 /* base signals carried in the state */
#define SEA_FEAT_POT 0
#define SEA_FEAT_ENC 1
#define SEA_FEAT_COMP 2

/* What a model input is (sea_feature_src.kind). */
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

/* The values one step computes. */
typedef struct {
    int32_t b[SEA_FEAT_N_BASE];
    int64_t d[SEA_FEAT_N_BASE];
    int64_t dd[SEA_FEAT_N_BASE];
    int64_t angle_q24;
} sea_features_out;

/* Model input i = sea_to_s16(value(kind, index), from_frac, to_frac); external inputs are copied. */
typedef struct {
    uint8_t kind;
    uint8_t index;
    int8_t from_frac;
    int8_t to_frac;
} sea_feature_src;

/* Start a new run of samples: the next step has no history. */
void sea_features_reset(sea_features_state *s);

/* One sample from raw counts (any int32 enc, pot): base signals, angle, differences; updates the state. */
void sea_features_step(sea_features_state *s, const int32_t table[SEA_LINK_TABLE_LEN], int32_t enc, int32_t pot,
                       sea_features_out *f);

/* The n model inputs of a plan from one step's values and the external inputs (NULL when none). */
void sea_features_inputs(const sea_features_out *f, const sea_feature_src *plan, int n, const int16_t *ext,
                         int16_t *in);

#endif
