/* sea_fixed.c -- seagen's fixed-point primitives; twins in seagen/quant/primitives.py. */
#include "sea_fixed.h"

int64_t sea_rshift_rne_s64(int64_t v, int s)
{
    int64_t q, r, half;
    if (s <= 0) {
        return v;
    }
    q = v >> s;                        /* floor(v / 2^s): arithmetic shift (checked in the header) */
    r = v - q * ((int64_t)1 << s);     /* 0 <= r < 2^s; no left shift of a negative value */
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
    int64_t q, r;
    if (den <= 0) {
        return 0;
    }
    q = (int64_t)num / den;            /* C99: truncates toward zero */
    r = (int64_t)num - q * den;        /* same sign as num */
    if (r < 0) {                       /* make it floor division: 0 <= r < den */
        q -= 1;
        r += den;
    }
    if (2 * r > den || (2 * r == den && (q & 1) != 0)) {
        q += 1;
    }
    return (int32_t)q;
}
