/* sea_fixed.c -- seagen's fixed-point primitives; twins in seagen/quant/primitives.py. */
#include "sea_fixed.h"

int64_t sea_rshift_rne_s64(int64_t v, int s)
{
    int64_t q;
    int64_t r;
    int64_t half;
    if (s <= 0) {
        return v;
    }
    if ((s <= 30) && (v >= INT32_MIN) && (v <= INT32_MAX)) {
        return sea_rshift_rne_s32((int32_t)v, s); /* same integers in 32-bit arithmetic (cheap on a Cortex-M) */
    }
    q = v >> s;                        /* floor(v / 2^s): arithmetic shift (checked in the header) */
    r = (int64_t)((uint64_t)v & (((uint64_t)1 << s) - 1u)); /* v - q 2^s, 0 <= r < 2^s: the low s bits */
    half = (int64_t)1 << (s - 1);
    if ((r > half) || ((r == half) && ((q & 1) != 0))) {
        q += 1;
    }
    return q;
}

int32_t sea_rshift_rne_s32(int32_t v, int s)
{
    int32_t q;
    int32_t r;
    int32_t half;
    if (s <= 0) {
        return v;
    }
    q = v >> s;
    r = (int32_t)(v - (q * ((int32_t)1 << s)));
    half = (int32_t)1 << (s - 1);
    if ((r > half) || ((r == half) && ((q & 1) != 0))) {
        q += 1;
    }
    return q;
}

int16_t sea_sat16(int64_t v)
{
    if (v > INT16_MAX) {
        return INT16_MAX;
    }
    if (v < INT16_MIN) {
        return INT16_MIN;
    }
    return (int16_t)v;
}

int32_t sea_sat32(int64_t v)
{
    if (v > INT32_MAX) {
        return INT32_MAX;
    }
    if (v < INT32_MIN) {
        return INT32_MIN;
    }
    return (int32_t)v;
}

/* -2^k <= x < 2^k (0 <= k <= 30), in unsigned 32-bit arithmetic: no overflow for any int32 x. */
#define SEA_ABS_BELOW(x, k) ((uint32_t)(x) + ((uint32_t)1 << (k)) < ((uint32_t)1 << ((k) + 1)))

int32_t sea_linkage_q16(const int32_t table[SEA_LINK_TABLE_LEN], int32_t pot)
{
    int32_t p = (pot < 0) ? 0 : ((pot > SEA_POT_MAX) ? SEA_POT_MAX : pot);
    int32_t i = p >> SEA_LINK_TABLE_SHIFT;
    int32_t f = p - (i << SEA_LINK_TABLE_SHIFT);       /* p >= 0: no negative shifts */
    int64_t a = table[i];
    int64_t b = table[i + 1];
    int64_t v;
    if (SEA_ABS_BELOW(table[i], 26) && SEA_ABS_BELOW(table[i + 1], 26)) {
        /* the same integers in int32: |a 2^4 + (b - a) f| = |a (16 - f) + b f| < 2^4 2^26 */
        const int32_t a32 = table[i];
        const int32_t b32 = table[i + 1];
        return sea_rshift_rne_s32((a32 * ((1 << SEA_LINK_TABLE_SHIFT) - f)) + (b32 * f), SEA_LINK_TABLE_SHIFT);
    }
    v = (a * ((int64_t)1 << SEA_LINK_TABLE_SHIFT)) + ((b - a) * f);
    return (int32_t)sea_rshift_rne_s64(v, SEA_LINK_TABLE_SHIFT);
}

/* Encoder counts with enc * SEA_MM_PER_COUNT_Q24 inside int32: -2^14 <= enc < 2^14, 2^14 < 2^31 / 73584. */
#define SEA_ENC_INT32_BITS 14

int32_t sea_compression_q16(const int32_t table[SEA_LINK_TABLE_LEN], int32_t enc, int32_t pot)
{
    int64_t travel;
    if (SEA_ABS_BELOW(enc, SEA_ENC_INT32_BITS)) { /* the same integers in int32 (no 64-bit multiply) */
        travel = sea_rshift_rne_s32(enc * SEA_MM_PER_COUNT_Q24, 24 - SEA_COMP_FRAC_BITS);
    } else {
        travel = sea_rshift_rne_s64((int64_t)enc * SEA_MM_PER_COUNT_Q24, 24 - SEA_COMP_FRAC_BITS);
    }
    return sea_sat32((int64_t)sea_linkage_q16(table, pot) + travel);
}
