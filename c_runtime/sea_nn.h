/* sea_nn.h -- seagen's integer network and polynomial kernels (twins: seagen/quant/kernels.py).
 *
 * Contract (c_runtime/README.md): int16 activations; int16 or int8 weights; accumulators int32 where the
 * generator proved no overflow over the calibrated box, else int64; every shift rounds half to even
 * (sea_rshift_rne_*); results saturate to int16 before narrowing. Inputs are clamped to the calibrated box
 * first, which is what makes the overflow proof hold for every possible input.
 */
#ifndef SEA_NN_H
#define SEA_NN_H

#include <stdint.h>

#include "sea_fixed.h"

#ifdef __cplusplus
extern "C" {
#endif

/* out[i] = min(max(x[i], lo[i]), hi[i]) for i < n. */
/*@ requires n >= 0 && \valid_read(x + (0 .. n - 1)) && \valid(out + (0 .. n - 1));
    requires \valid_read(lo + (0 .. n - 1)) && \valid_read(hi + (0 .. n - 1));
    assigns out[0 .. n - 1]; */
void sea_clamp_s16(const int16_t *x, const int16_t *lo, const int16_t *hi, int n, int16_t *out);

/* y[j] = sat16(rshift_rne(b[j] + sum_i w[j*n_in + i] * x[i], shift)), j < n_out. Accumulator: int32
 * (caller guarantees every partial sum fits) or int64; weights int16 or int8. */
/*@ requires n_in >= 1 && n_out >= 1 && 0 <= shift <= 30;
    requires \valid_read(w + (0 .. (n_in * n_out) - 1)) && \valid_read(b + (0 .. n_out - 1));
    requires \valid_read(x + (0 .. n_in - 1)) && \valid(y + (0 .. n_out - 1));
    requires \separated(x + (0 .. n_in - 1), y + (0 .. n_out - 1));
    assigns y[0 .. n_out - 1]; */
void sea_dense_w16_a32(const int16_t *w, const int32_t *b, const int16_t *x, int n_in, int n_out, int shift,
                       int16_t *y);
/*@ requires n_in >= 1 && n_out >= 1 && 0 <= shift <= 62;
    requires \valid_read(w + (0 .. (n_in * n_out) - 1)) && \valid_read(b + (0 .. n_out - 1));
    requires \valid_read(x + (0 .. n_in - 1)) && \valid(y + (0 .. n_out - 1));
    requires \separated(x + (0 .. n_in - 1), y + (0 .. n_out - 1));
    assigns y[0 .. n_out - 1]; */
void sea_dense_w16_a64(const int16_t *w, const int64_t *b, const int16_t *x, int n_in, int n_out, int shift,
                       int16_t *y);
/*@ requires n_in >= 1 && n_out >= 1 && 0 <= shift <= 30;
    requires \valid_read(w + (0 .. (n_in * n_out) - 1)) && \valid_read(b + (0 .. n_out - 1));
    requires \valid_read(x + (0 .. n_in - 1)) && \valid(y + (0 .. n_out - 1));
    requires \separated(x + (0 .. n_in - 1), y + (0 .. n_out - 1));
    assigns y[0 .. n_out - 1]; */
void sea_dense_w8_a32(const int8_t *w, const int32_t *b, const int16_t *x, int n_in, int n_out, int shift,
                      int16_t *y);
/*@ requires n_in >= 1 && n_out >= 1 && 0 <= shift <= 62;
    requires \valid_read(w + (0 .. (n_in * n_out) - 1)) && \valid_read(b + (0 .. n_out - 1));
    requires \valid_read(x + (0 .. n_in - 1)) && \valid(y + (0 .. n_out - 1));
    requires \separated(x + (0 .. n_in - 1), y + (0 .. n_out - 1));
    assigns y[0 .. n_out - 1]; */
void sea_dense_w8_a64(const int8_t *w, const int64_t *b, const int16_t *x, int n_in, int n_out, int shift,
                      int16_t *y);

/* Activations in place on n int16 values. */
/*@ requires n >= 0 && \valid(y + (0 .. n - 1));
    assigns y[0 .. n - 1]; */
void sea_relu_s16(int16_t *y, int n);
/*@ requires n >= 0 && \valid(y + (0 .. n - 1));
    assigns y[0 .. n - 1]; */
void sea_leaky_s16(int16_t *y, int n, int32_t alpha_q15);          /* y < 0: rshift_rne(y * alpha, 15) */
/*@ requires n >= 0 && \valid(y + (0 .. n - 1));
    assigns y[0 .. n - 1]; */
void sea_hardtanh_s16(int16_t *y, int n, int16_t lo, int16_t hi);
/* y = table[clamp(rshift_rne(y, in_shift) + offset, 0, len - 1)] (tanh / sigmoid, Q14 outputs). */
/*@ requires n >= 0 && \valid(y + (0 .. n - 1)) && len >= 1 && \valid_read(table + (0 .. len - 1));
    assigns y[0 .. n - 1]; */
void sea_table_s16(int16_t *y, int n, const int16_t *table, int32_t len, int in_shift, int32_t offset);

/* The smooth and piecewise-linear activations (twins: seagen/runtime/activations.py; formats: the defines).
 * smooth (ELU, SELU, Softplus, GELU, Mish, SiLU): f = s relu(y) + g(y), g a nearest-sample table in y's format:
 *   sat16(rshift_rne(max(y, 0) * slope, SEA_ACT_SLOPE_FRAC) + g[clamp(rshift_rne(y, in_shift) + offset)]);
 * hardsigmoid: clamp(rshift_rne(y * alpha + beta, SEA_ACT_HSIG_FRAC - SEA_ACT_OUT_FRAC), 0, 1.0), Q14 out;
 * hardswish: sat16(rshift_rne(y * hardsigmoid(y), SEA_ACT_OUT_FRAC)), y's format;
 * prelu: y < 0 -> sat16(rshift_rne(y * alpha[j], SEA_ACT_PRELU_FRAC)), a slope per channel j. */
#define SEA_ACT_OUT_FRAC 14   /* table and hardsigmoid outputs: Q14 */
#define SEA_ACT_ONE 16384     /* 1.0 in Q14 */
#define SEA_ACT_SLOPE_FRAC 14 /* a smooth function's relu slope s (< 2): Q14 */
#define SEA_ACT_SLOPE_ONE 16384 /* s = 1 in Q14 */
#define SEA_ACT_HSIG_FRAC 30  /* hardsigmoid: alpha y + beta summed in Q30 (int64) */
#define SEA_ACT_PRELU_FRAC 15 /* PReLU slopes (|a| <= 1): Q15 */

/* One value each (static inline: the Cortex-M kernels apply them to each result as it is made). */
/*@ requires len >= 1 && \valid_read(table + (0 .. len - 1)) && in_shift <= 30;
    assigns \nothing; */
static inline int16_t sea_table1(int16_t y, const int16_t *table, int32_t len, int in_shift, int32_t offset)
{
    /* in_shift 0 (a sample per input LSB): no call (the kernels pass constants, so this folds) */
    int32_t k = ((in_shift > 0) ? sea_rshift_rne_s32((int32_t)y, in_shift) : (int32_t)y) + offset;
    if (k < 0) {
        k = 0;
    }
    if (k > (len - 1)) {
        k = len - 1;
    }
    return SEA_ROM_RD16(&table[k]); /* a SEA_ROM table: program memory on an AVR */
}

/*@ requires len >= 1 && \valid_read(g + (0 .. len - 1)) && in_shift <= 30;
    assigns \nothing; */
static inline int16_t sea_smooth1(int16_t y, const int16_t *g, int32_t len, int in_shift, int32_t offset,
                                  int32_t slope)
{
    /* 0 <= y * slope < 2^15 * 2^15: int32; s = 1 (all but SELU) is y itself */
    int32_t r = 0;
    if (y > 0) {
        r = (slope == SEA_ACT_SLOPE_ONE) ? (int32_t)y : sea_rshift_rne_s32((int32_t)y * slope, SEA_ACT_SLOPE_FRAC);
    }
    return sea_sat16((int64_t)r + sea_table1(y, g, len, in_shift, offset));
}

/*@ assigns \nothing;
    ensures 0 <= \result <= SEA_ACT_ONE; */
static inline int16_t sea_hsig1(int16_t y, int32_t alpha, int64_t beta)
{
    int64_t h = sea_rshift_rne_s64(((int64_t)y * alpha) + beta, SEA_ACT_HSIG_FRAC - SEA_ACT_OUT_FRAC);
    if (h < 0) {
        h = 0;
    }
    if (h > SEA_ACT_ONE) {
        h = SEA_ACT_ONE;
    }
    return (int16_t)h;
}

/*@ assigns \nothing; */
static inline int16_t sea_hswish1(int16_t y, int32_t alpha, int64_t beta)
{
    /* |y| <= 2^15, 0 <= h <= 2^14: int32 */
    return sea_sat16(sea_rshift_rne_s32((int32_t)y * sea_hsig1(y, alpha, beta), SEA_ACT_OUT_FRAC));
}

/*@ assigns \nothing; */
static inline int16_t sea_hardtanh1(int16_t y, int16_t lo, int16_t hi)
{
    int16_t r = y;
    if (r < lo) {
        r = lo;
    }
    if (r > hi) {
        r = hi;
    }
    return r;
}

/* PReLU's and LeakyReLU's negative side (sea_leaky_s16 is this with one slope). */
/*@ assigns \nothing; */
static inline int16_t sea_prelu1(int16_t y, int32_t alpha)
{
    /* |alpha| <= 2^15: int32 */
    return (y < 0) ? sea_sat16(sea_rshift_rne_s32((int32_t)y * alpha, SEA_ACT_PRELU_FRAC)) : y;
}

/*@ requires n >= 0 && \valid(y + (0 .. n - 1)) && len >= 1 && \valid_read(g + (0 .. len - 1));
    assigns y[0 .. n - 1]; */
void sea_smooth_s16(int16_t *y, int n, const int16_t *g, int32_t len, int in_shift, int32_t offset,
                    int32_t slope);
/*@ requires n >= 0 && \valid(y + (0 .. n - 1));
    assigns y[0 .. n - 1]; */
void sea_hsig_s16(int16_t *y, int n, int32_t alpha, int64_t beta);
/*@ requires n >= 0 && \valid(y + (0 .. n - 1));
    assigns y[0 .. n - 1]; */
void sea_hswish_s16(int16_t *y, int n, int32_t alpha, int64_t beta);
/*@ requires n >= 0 && \valid(y + (0 .. n - 1)) && \valid_read(alpha + (0 .. n - 1));
    assigns y[0 .. n - 1]; */
void sea_prelu_s16(int16_t *y, int n, const int32_t *alpha);

/* One Horner step: sat32(floor(x * t / 2^shift) + A), A = add * 2^align (align >= 0) or floor(add / 2^-align);
 * floor shifts (c_runtime/README.md, item 7). The generator proved |x * t| / 2^shift and the result < 2^30
 * over the box, so the saturation never acts and the Cortex-M kernels compute it in int32. */
/*@ requires 0 <= shift <= 62 && -62 <= align <= 31;
    assigns \nothing; */
int32_t sea_horner_s32(int16_t x, int32_t t, int32_t add, int align, int shift);

/* A value in Q(from_frac) converted to an int16 in Q(to_frac): exact scaling up or rounding shift down,
 * then saturation. Scaling up needs |v| * 2^(to_frac - from_frac) < 2^63. Inline: NAME_step calls it with
 * constant formats, so each call folds to its own few instructions (no 64-bit call on a Cortex-M0+). */
/*@ requires to_frac - from_frac <= 62 && from_frac - to_frac <= 62;
    assigns \nothing; */
static inline int16_t sea_to_s16(int64_t v, int from_frac, int to_frac)
{
    if (to_frac >= from_frac) { /* sat16(v * 2^k), decided before scaling: no 64-bit multiply */
        const int k = to_frac - from_frac;
        if (k > 15) {
            return (int16_t)((v > 0) ? INT16_MAX : ((v < 0) ? INT16_MIN : 0));

        }
        if (v > (INT16_MAX >> k)) {
            return INT16_MAX;
        }
        if (v < -(32768 >> k)) {
            return INT16_MIN;
        }
        return (int16_t)((int32_t)v * ((int32_t)1 << k)); /* k <= 15: 1 << 15 overflows a 16-bit int */
    }
    return sea_sat16(sea_rshift_rne_s64(v, from_frac - to_frac));
}

/* The same to an int32 (e.g. a model output scaled to the controller's Q16): saturated to int32. */
/*@ requires 0 <= to_frac - from_frac <= 62 || 0 < from_frac - to_frac <= 62;
    assigns \nothing; */
static inline int32_t sea_to_s32(int64_t v, int from_frac, int to_frac)
{
    if (to_frac >= from_frac) {
        return sea_sat32(v * ((int64_t)1 << (to_frac - from_frac)));
    }
    return sea_sat32(sea_rshift_rne_s64(v, from_frac - to_frac));
}

#ifdef __cplusplus
}
#endif

#endif
