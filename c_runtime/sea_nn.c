/* sea_nn.c -- seagen's integer network and polynomial kernels; twins in seagen/quant/kernels.py. */
#include "sea_nn.h"
#include "sea_fixed.h"

void sea_clamp_s16(const int16_t *x, const int16_t *lo, const int16_t *hi, int n, int16_t *out)
{
    int i;
    for (i = 0; i < n; ++i) {
        out[i] = (x[i] < lo[i]) ? lo[i] : ((x[i] > hi[i]) ? hi[i] : x[i]);
    }
}

/* The four dense kernels share one body: W (int8/int16) times x (int16) accumulated from the bias in ACC
 * (int32 where the generator proved every partial sum fits, else int64), then shifted and saturated. W and b
 * are SEA_ROM tables (program memory on an AVR), read with the SEA_ROM_RD macro of their width (sea_fixed.h). */
#define SEA_DENSE_BODY(ACC, SHIFT_FN, RD_W, RD_B)                            \
    int i;                                                                   \
    int j;                                                                   \
    for (j = 0; j < n_out; ++j) {                                            \
        ACC acc = RD_B(&b[j]);                                               \
        for (i = 0; i < n_in; ++i) {                                         \
            acc += (ACC)((int32_t)RD_W(&w[(j * n_in) + i]) * (int32_t)x[i]); \
        }                                                                    \
        y[j] = sea_sat16(SHIFT_FN(acc, shift));                              \
    }

void sea_dense_w16_a32(const int16_t *w, const int32_t *b, const int16_t *x, int n_in, int n_out, int shift,
                       int16_t *y)
{
    SEA_DENSE_BODY(int32_t, sea_rshift_rne_s32, SEA_ROM_RD16, SEA_ROM_RD32)
}

void sea_dense_w16_a64(const int16_t *w, const int64_t *b, const int16_t *x, int n_in, int n_out, int shift,
                       int16_t *y)
{
    SEA_DENSE_BODY(int64_t, sea_rshift_rne_s64, SEA_ROM_RD16, SEA_ROM_RD64)
}

void sea_dense_w8_a32(const int8_t *w, const int32_t *b, const int16_t *x, int n_in, int n_out, int shift,
                      int16_t *y)
{
    SEA_DENSE_BODY(int32_t, sea_rshift_rne_s32, SEA_ROM_RD8, SEA_ROM_RD32)
}

void sea_dense_w8_a64(const int8_t *w, const int64_t *b, const int16_t *x, int n_in, int n_out, int shift,
                      int16_t *y)
{
    SEA_DENSE_BODY(int64_t, sea_rshift_rne_s64, SEA_ROM_RD8, SEA_ROM_RD64)
}

void sea_relu_s16(int16_t *y, int n)
{
    int i;
    for (i = 0; i < n; ++i) {
        if (y[i] < 0) {
            y[i] = 0;
        }
    }
}

void sea_leaky_s16(int16_t *y, int n, int32_t alpha_q15)
{
    int i;
    for (i = 0; i < n; ++i) {
        y[i] = sea_prelu1(y[i], alpha_q15);
    }
}

void sea_hardtanh_s16(int16_t *y, int n, int16_t lo, int16_t hi)
{
    int i;
    for (i = 0; i < n; ++i) {
        y[i] = sea_hardtanh1(y[i], lo, hi);
    }
}

void sea_table_s16(int16_t *y, int n, const int16_t *table, int32_t len, int in_shift, int32_t offset)
{
    int i;
    for (i = 0; i < n; ++i) {
        y[i] = sea_table1(y[i], table, len, in_shift, offset);
    }
}

void sea_smooth_s16(int16_t *y, int n, const int16_t *g, int32_t len, int in_shift, int32_t offset,
                    int32_t slope)
{
    int i;
    for (i = 0; i < n; ++i) {
        y[i] = sea_smooth1(y[i], g, len, in_shift, offset, slope);
    }
}

void sea_hsig_s16(int16_t *y, int n, int32_t alpha, int64_t beta)
{
    int i;
    for (i = 0; i < n; ++i) {
        y[i] = sea_hsig1(y[i], alpha, beta);
    }
}

void sea_hswish_s16(int16_t *y, int n, int32_t alpha, int64_t beta)
{
    int i;
    for (i = 0; i < n; ++i) {
        y[i] = sea_hswish1(y[i], alpha, beta);
    }
}

void sea_prelu_s16(int16_t *y, int n, const int32_t *alpha)
{
    int i;
    for (i = 0; i < n; ++i) {
        y[i] = sea_prelu1(y[i], SEA_ROM_RD32(&alpha[i]));
    }
}

int32_t sea_horner_s32(int16_t x, int32_t t, int32_t add, int align, int shift)
{
    int64_t p = ((int64_t)x * t) >> shift; /* floor: arithmetic shift (c_runtime/README.md, item 7) */
    int64_t a = (align >= 0) ? ((int64_t)add * ((int64_t)1 << align)) : ((int64_t)add >> -align);

    return sea_sat32(p + a);
}
