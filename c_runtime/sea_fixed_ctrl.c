/* sea_fixed_ctrl.c -- the fixed-point primitives only the controller uses (declared in sea_fixed.h); twins in
 * seagen/quant/primitives.py. Shipped with `seagen export --controller`, so other exports carry no unused code. */
#include "sea_fixed.h"

int64_t sea_clamp_s64(int64_t v, int64_t lo, int64_t hi)
{
    int64_t r = v;
    if (r > hi) {
        r = hi;
    }
    if (r < lo) {
        r = lo;
    }
    return r;
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
