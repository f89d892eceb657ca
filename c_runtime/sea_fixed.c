/* sea_fixed.c -- seagen's fixed-point primitives; twins in seagen/quant/primitives.py. */
#include "sea_fixed.h"

int64_t sea_rshift_rne_s64(int64_t v, int s)
{
    int64_t q, r, half;
    if (s <= 0) {
        return v;
    }
    if (s <= 30 && v >= INT32_MIN && v <= INT32_MAX) {
        return sea_rshift_rne_s32((int32_t)v, s); /* same integers in 32-bit arithmetic (cheap on a Cortex-M) */
    }
    q = v >> s;                        /* floor(v / 2^s): arithmetic shift (checked in the header) */
    r = (int64_t)((uint64_t)v & (((uint64_t)1 << s) - 1u)); /* v - q 2^s, 0 <= r < 2^s: the low s bits */
    half = (int64_t)1 << (s - 1);
    if (r > half || (r == half && (q & 1) != 0)) {
        q += 1;
    }
    return q;
}

int32_t sea_rshift_rne_s32(int32_t v, int s)
{
    int32_t q, r, half;
    if (s <= 0) {
        return v;
    }
    q = v >> s;
    r = (int32_t)(v - q * ((int32_t)1 << s));
    half = (int32_t)1 << (s - 1);
    if (r > half || (r == half && (q & 1) != 0)) {
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

int32_t sea_linkage_q16(const int32_t table[SEA_LINK_TABLE_LEN], int32_t pot)
{
    int32_t p = pot < 0 ? 0 : (pot > SEA_POT_MAX ? SEA_POT_MAX : pot);
    int32_t i = p >> SEA_LINK_TABLE_SHIFT;
    int32_t f = p - (i << SEA_LINK_TABLE_SHIFT);       /* p >= 0: no negative shifts */
    int64_t a = table[i];
    int64_t b = table[i + 1];
    int64_t v = a * ((int64_t)1 << SEA_LINK_TABLE_SHIFT) + (b - a) * f;
    return (int32_t)sea_rshift_rne_s64(v, SEA_LINK_TABLE_SHIFT);
}

int32_t sea_compression_q16(const int32_t table[SEA_LINK_TABLE_LEN], int32_t enc, int32_t pot)
{
    int64_t travel = sea_rshift_rne_s64((int64_t)enc * SEA_MM_PER_COUNT_Q24, 24 - SEA_COMP_FRAC_BITS);
    return sea_sat32((int64_t)sea_linkage_q16(table, pot) + travel);
}

int64_t sea_clamp_s64(int64_t v, int64_t lo, int64_t hi)
{
    if (v > hi) {
        v = hi;
    }
    if (v < lo) {
        v = lo;
    }
    return v;
}

int32_t sea_div_rne_s32(int32_t num, int32_t den)
{
    /* Floor quotient and remainder from unsigned 32-bit division of |num| (no 64-bit division: a Cortex-M0+
     * would call __aeabi_ldivmod), then round half to even. |num| of INT32_MIN is 2^31 as uint32. */
    uint32_t d, a, qa, ra, r;
    int64_t q;
    if (den <= 0) {
        return 0;
    }
    d = (uint32_t)den;
    a = num < 0 ? 0u - (uint32_t)num : (uint32_t)num;
    qa = a / d;
    ra = a - qa * d;
    if (num >= 0) {
        q = (int64_t)qa;
        r = ra;
    } else {
        q = -(int64_t)qa - (ra != 0u); /* floor: 0 <= r < den */
        r = ra != 0u ? d - ra : 0u;
    }
    if (r > d - r || (r == d - r && (q & 1) != 0)) {
        q += 1;
    }
    return (int32_t)q;
}
