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

#if !defined(__ARM_FEATURE_IDIV)
/* floor(a / d) for 1 <= d <= 16 without a division helper (a Cortex-M0+ has no divide instruction): the
 * high word of a * floor((2^32 - 1) / d) is at most the quotient and at most 2 below it; the remainder loop
 * corrects it, so the result is exact for every uint32 a. Four 16 x 16 multiplies (Hacker's Delight's
 * mulhu). */
static uint32_t sea_udiv_small(uint32_t a, uint32_t d)
{
    static const uint32_t recip[17] = {
        0u, 0xFFFFFFFFu / 1u, 0xFFFFFFFFu / 2u, 0xFFFFFFFFu / 3u, 0xFFFFFFFFu / 4u, 0xFFFFFFFFu / 5u,
        0xFFFFFFFFu / 6u, 0xFFFFFFFFu / 7u, 0xFFFFFFFFu / 8u, 0xFFFFFFFFu / 9u, 0xFFFFFFFFu / 10u,
        0xFFFFFFFFu / 11u, 0xFFFFFFFFu / 12u, 0xFFFFFFFFu / 13u, 0xFFFFFFFFu / 14u, 0xFFFFFFFFu / 15u,
        0xFFFFFFFFu / 16u};
    const uint32_t m = recip[d];
    const uint32_t al = a & 0xFFFFu;
    const uint32_t ah = a >> 16;
    const uint32_t ml = m & 0xFFFFu;
    const uint32_t mh = m >> 16;
    const uint32_t t = (ah * ml) + ((al * ml) >> 16);
    const uint32_t w = (al * mh) + (t & 0xFFFFu);
    uint32_t q = (ah * mh) + (t >> 16) + (w >> 16); /* floor(a m / 2^32) */
    uint32_t r = a - (q * d);
    while (r >= d) {
        q += 1u;
        r -= d;
    }
    return q;
}
#endif

int32_t sea_div_rne_s32(int32_t num, int32_t den)
{
    /* Floor quotient and remainder from unsigned 32-bit division of |num| (no 64-bit division: a Cortex-M0+
     * would call __aeabi_ldivmod; on a core without a divide instruction, divisors 1..16, e.g. the
     * controller's averages, need no division helper), then round half to even. |num| of INT32_MIN is 2^31
     * as uint32. */
    uint32_t d;
    uint32_t a;
    uint32_t qa;
    uint32_t ra;
    uint32_t r;
    int64_t q;
    if (den <= 0) {
        return 0;
    }
    d = (uint32_t)den;
    a = (num < 0) ? (0u - (uint32_t)num) : (uint32_t)num;
#if defined(__ARM_FEATURE_IDIV) /* a divide instruction (ACLE): faster than the reciprocal */
    qa = a / d;
#else
    qa = (d <= 16u) ? sea_udiv_small(a, d) : (a / d);
#endif
    ra = a - (qa * d);
    if (num >= 0) {
        q = (int64_t)qa;
        r = ra;
    } else {
        q = -(int64_t)qa - ((ra != 0u) ? 1 : 0); /* floor: 0 <= r < den */
        r = (ra != 0u) ? (d - ra) : 0u;
    }
    if ((r > (d - r)) || ((r == (d - r)) && ((q & 1) != 0))) {

        q += 1;
    }
    return (int32_t)q;
}
