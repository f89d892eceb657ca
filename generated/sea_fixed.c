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
    r = (int32_t)((uint32_t)v & (((uint32_t)1 << s) - 1u)); /* v - q 2^s, 0 <= r < 2^s: the low s bits */
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

/* -2^k <= x < 2^k (0 <= k <= 30): two signed comparisons, which a static analyser (Frama-C Eva, docs/prove.md)
 * uses to narrow x in the guarded branch; no overflow for any int32 x. */
#define SEA_ABS_BELOW(x, k) (((x) >= -((int32_t)1 << (k))) && ((x) < ((int32_t)1 << (k))))

int32_t sea_linkage_q16(const sea_act *a, int32_t pot)
{
    const int s = (int)a->link_shift; /* 0..8: an int shift count (16 bits on an AVR) */
    const int32_t *t = a->link_q16;
    int32_t p = (pot < 0) ? 0 : ((pot > a->pot_max) ? a->pot_max : pot);
    int32_t i = p >> s;
    int32_t f = (int32_t)((uint32_t)p & (((uint32_t)1 << s) - 1u)); /* p - (i << s): 0 <= f < 2^s (p >= 0) */
    const int32_t lo32 = SEA_ROM_RD32(&t[i]); /* read once: the guard below narrows these locals */
    const int32_t hi32 = SEA_ROM_RD32(&t[i + 1]); /* (a SEA_ROM table: program memory on an AVR) */
    int32_t r;
    if (SEA_ABS_BELOW(lo32, a->link_i32_bits) && SEA_ABS_BELOW(hi32, a->link_i32_bits)) {
        /* the same integers in int32: |lo (2^s - f) + hi f| < 2^s 2^(30 - s) */
        r = sea_rshift_rne_s32((lo32 * ((1 << s) - f)) + (hi32 * f), s);
    } else {
        const int64_t lo = lo32;
        const int64_t hi = hi32;
        const int64_t v = (lo * ((int64_t)1 << s)) + ((hi - lo) * f); /* |entry| < 2^30: fits int64 */
        r = (int32_t)sea_rshift_rne_s64(v, s);
    }
    return r;
}

int32_t sea_compression_q16(const sea_act *a, int32_t enc, int32_t pot)
{
    int64_t travel;
    if (SEA_ABS_BELOW(enc, a->enc_i32_bits)) { /* the same integers in int32 (no 64-bit multiply) */
        travel = sea_rshift_rne_s32(enc * a->travel_q, (int)a->travel_shift);
    } else {
        travel = sea_rshift_rne_s64((int64_t)enc * a->travel_q, (int)a->travel_shift); /* < 2^62 */
    }
    return sea_sat32((int64_t)sea_linkage_q16(a, pot) + travel);
}
