/* sea_dsp.h -- helpers of the Cortex-M target kernels (`seagen export --target cortex-m4|cortex-m0plus`).
 *
 * Header-only (static inline). Each helper is an exact re-expression of a primitive of the numeric contract
 * (c_runtime/README.md): the dual multiply-accumulate is the exact integer sum of two products, the folded
 * rounding shift equals sea_rshift_rne (Python twin seagen.quant.primitives.rshift_rne) once 2^(s-1) has
 * been added to the accumulator, and the saturations equal sea_sat16 / max(0, sea_sat16). Tested bit for
 * bit against those twins by tests/test_target_kernels.py (the portable fallbacks, through cffi).
 *
 * With __ARM_FEATURE_SIMD32 (Cortex-M4/M7/M33) the ACLE intrinsics of <arm_acle.h> are used (SMLAD,
 * SMLALD, USAT, SSAT); elsewhere portable C gives identical results. Packed words hold two int16 values,
 * the first in the low half (int16x2_t of the ACLE is int32_t).
 */
#ifndef SEA_DSP_H
#define SEA_DSP_H

#include <stdint.h>

#if defined(__ARM_FEATURE_SIMD32)
#include <arm_acle.h>
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* sea_int16x2: two int16 values packed in one word, the first in the low half: int32_t (the ACLE's int16x2_t)
 * for every compiler. For Frama-C analysing the Cortex-M4 code only (__FRAMAC__ with __ARM_FEATURE_SIMD32,
 * `seagen verify --prove`, docs/prove.md) it is the struct of the two halves: Eva's interval
 * over a word loses the range of a low half that spans 0, over the struct it keeps each half's range. The pack,
 * the pair clamp and SMLAD/SMLALD are then analysed as their half-by-half integer functions (below, and the
 * ACLE model Eva reads as arm_acle.h), the integers the word gives (tests/test_target_kernels.py bit for bit,
 * tests/test_cortexm.py on emulated cores). The compiled C is unchanged: the type is int32_t there. */
#if defined(__FRAMAC__) && defined(__ARM_FEATURE_SIMD32)
typedef struct {
    int16_t lo;
    int16_t hi;
} sea_int16x2;
#else
typedef int32_t sea_int16x2;
#endif

/* SEA_OPAQUE(p): makes the compiler forget what pointer p holds (an empty asm on gcc/clang), so loads
 * through it are not hoisted out of a loop: on the M0+ the hoisted inputs would live in high registers,
 * which Thumb-1 arithmetic cannot use directly. No effect on the results.
 * Its contract, for Frama-C (__FRAMAC__, docs/prove.md), where it is an empty statement: assigns nothing,
 * ensures p == \old(p) (the asm is empty; "+r" only hides p from the optimiser). */
#if defined(__GNUC__) && !defined(__FRAMAC__)
#define SEA_OPAQUE(p) __asm__("" : "+r"(p))
#else
#define SEA_OPAQUE(p) ((void)0)
#endif

/* Low (first) int16 of a packed word, as int32; exact, no implementation-defined conversion. */
/*@ assigns \nothing;
    ensures INT16_MIN <= \result <= INT16_MAX; */
static inline int32_t sea_lo16(int32_t w)
{
    return (int32_t)(((uint32_t)w & 0xFFFFu) ^ 0x8000u) - 0x8000;
}

/* High (second) int16 of a packed word, as int32. */
/*@ assigns \nothing;
    ensures INT16_MIN <= \result <= INT16_MAX; */
static inline int32_t sea_hi16(int32_t w)
{
    return (int32_t)(((uint32_t)w >> 16) ^ 0x8000u) - 0x8000;
}

/* Pack two int16 values (lo first) into one word: hi * 2^16 + (lo mod 2^16), never overflows. */
/*@ requires INT16_MIN <= hi <= INT16_MAX;
    assigns \nothing; */
static inline sea_int16x2 sea_pack16x2(int32_t lo, int32_t hi)
{
#if defined(__FRAMAC__) && defined(__ARM_FEATURE_SIMD32)
    sea_int16x2 r;
    r.lo = (int16_t)lo; /* lo mod 2^16, as the word's low half */
    r.hi = (int16_t)hi;
    return r;
#else
    return (hi * 65536) + (int32_t)((uint32_t)lo & 0xFFFFu);
#endif
}

/* Pack two int16 values known to be >= 0 (ReLU outputs): hi * 2^16 | lo, one ORR; equals sea_pack16x2. */
/*@ requires 0 <= lo <= INT16_MAX && 0 <= hi <= INT16_MAX;
    assigns \nothing; */
static inline sea_int16x2 sea_pack_nonneg16x2(int32_t lo, int32_t hi)
{
#if defined(__FRAMAC__) && defined(__ARM_FEATURE_SIMD32)
    return sea_pack16x2(lo, hi);
#else
    return (int32_t)(((uint32_t)hi << 16) | (uint32_t)lo);
#endif
}

/* v0 = p[0], v1 = p[1]; with gcc on a core with the DSP extension as two LDRs back to back in one asm
 * statement: the compiler would interleave the loads with the SMLADs that use them, and the Cortex-M4
 * pipelines a load only behind another load (2 cycles for the first, 1 for each next). The asm's contract
 * is the portable branch (Frama-C analyses that, __FRAMAC__): requires \valid_read(p + (0 .. 1));
 * assigns *v0, *v1; ensures *v0 == p[0] && *v1 == p[1] (backed by tests/test_cortexm.py, bit for bit). */
/*@ requires \valid_read(p + (0 .. 1)) && \valid(v0) && \valid(v1);
    assigns *v0, *v1;
    ensures *v0 == p[0] && *v1 == p[1]; */
static inline void sea_ld2(const int32_t *p, int32_t *v0, int32_t *v1)
{
#if defined(__ARM_FEATURE_SIMD32) && defined(__GNUC__) && !defined(__FRAMAC__)
    int32_t a;
    int32_t b;
    __asm__("ldr %0, %2\n\tldr %1, %3" : "=&r"(a), "=r"(b) : "m"(p[0]), "m"(p[1]));
    *v0 = a;
    *v1 = b;
#else
    *v0 = p[0];
    *v1 = p[1];
#endif
}

/* v0..v3 = p[0..3], four LDRs back to back (see sea_ld2; the same contract on four words). */
/*@ requires \valid_read(p + (0 .. 3)) && \valid(v0) && \valid(v1) && \valid(v2) && \valid(v3);
    assigns *v0, *v1, *v2, *v3;
    ensures *v0 == p[0] && *v1 == p[1] && *v2 == p[2] && *v3 == p[3]; */
static inline void sea_ld4(const int32_t *p, int32_t *v0, int32_t *v1, int32_t *v2, int32_t *v3)
{
#if defined(__ARM_FEATURE_SIMD32) && defined(__GNUC__) && !defined(__FRAMAC__)
    int32_t a;
    int32_t b;
    int32_t c;
    int32_t d;
    __asm__("ldr %0, %4\n\tldr %1, %5\n\tldr %2, %6\n\tldr %3, %7"
            : "=&r"(a), "=&r"(b), "=&r"(c), "=r"(d)
            : "m"(p[0]), "m"(p[1]), "m"(p[2]), "m"(p[3]));
    *v0 = a;
    *v1 = b;
    *v2 = c;
    *v3 = d;
#else
    *v0 = p[0];
    *v1 = p[1];
    *v2 = p[2];
    *v3 = p[3];
#endif
}

#if defined(__ARM_FEATURE_SIMD32)
/* acc + lo(x)*lo(w) + hi(x)*hi(w): one SMLAD (x the packed activations, w a weight word). The generator proves
 * |acc| + the products stay < 2^31. */
/*@ assigns \nothing; */
static inline int32_t sea_smlad(sea_int16x2 x, int32_t w, int32_t acc)
{
    return __smlad(x, w, acc);
}

/* Same into a 64-bit accumulator: one SMLALD. */
/*@ assigns \nothing; */
static inline int64_t sea_smlald(sea_int16x2 x, int32_t w, int64_t acc)
{
    return __smlald(x, w, acc);
}
#else
/* Portable SMLAD: the same exact sum (the generator's bound rules out any overflow). */
/*@ assigns \nothing; */
static inline int32_t sea_smlad(sea_int16x2 x, int32_t w, int32_t acc)
{
    return acc + (sea_lo16(x) * sea_lo16(w)) + (sea_hi16(x) * sea_hi16(w));
}

/* Portable SMLALD. */
/*@ assigns \nothing; */
static inline int64_t sea_smlald(sea_int16x2 x, int32_t w, int64_t acc)
{
    return acc + (int64_t)(sea_lo16(x) * sea_lo16(w)) + (int64_t)(sea_hi16(x) * sea_hi16(w));
}
#endif

/* Round-half-to-even shift of v = acc + 2^(s-1) (the half already folded into the bias), 1 <= s <= 31:
 * floor(v / 2^s), made even when v's low s bits are 0 (the tie). Equals sea_rshift_rne_s32(acc, s). */
/*@ requires 1 <= s <= 31;
    assigns \nothing; */
static inline int32_t sea_rne_folded_s32(int32_t v, int s)
{
    int32_t q = v >> s;
    if (((uint32_t)v << (32 - s)) == 0u) {
        q &= ~1;
    }
    return q;
}

/* Round-half-to-even shift of u = acc + 2^(s-1) - 1 (the bias carries 2^(s-1) - 1), 1 <= s <= 30:
 * (u + bit s of u) >> s, which equals sea_rshift_rne_s32(acc, s). With acc = k 2^s + r (0 <= r < 2^s):
 * r < 2^(s-1) gives k, r > 2^(s-1) gives k + 1, and the tie r = 2^(s-1) gives k + (k & 1), the even one.
 * Three instructions on the M4 with the saturation (UBFX, ADD, USAT/SSAT with the shift), no IT block. */
/*@ requires 1 <= s <= 30;
    assigns \nothing; */
static inline int32_t sea_rne_bit_s32(int32_t u, int s)
{
    const uint32_t bit = ((uint32_t)u >> s) & 1u;
    const int32_t v = u + (int32_t)bit;
    int32_t q = v >> s;
    return q;
}

/* The same for a 64-bit accumulator, 1 <= s <= 62. */
/*@ requires 1 <= s <= 62;
    assigns \nothing; */
static inline int64_t sea_rne_bit_s64(int64_t u, int s)
{
    const uint64_t bit = ((uint64_t)u >> s) & 1u;
    const int64_t v = u + (int64_t)bit;
    int64_t q = v >> s;
    return q;
}

/* The same for a 64-bit accumulator, 1 <= s <= 62. */
/*@ requires 1 <= s <= 62;
    assigns \nothing; */
static inline int64_t sea_rne_folded_s64(int64_t v, int s)
{
    int64_t q = v >> s;
    if (((uint64_t)v << (64 - s)) == 0u) {
        q &= ~(int64_t)1;
    }
    return q;
}

/* ReLU then saturation to int16: clamp(q, 0, 32767) (USAT #15 where available). */
/*@ assigns \nothing;
    ensures 0 <= \result <= INT16_MAX; */
static inline int32_t sea_relu_sat16(int32_t q)
{
#if defined(__ARM_FEATURE_SAT)
    return (int32_t)__usat(q, 15);
#else
    return (q < 0) ? 0 : ((q > 32767) ? 32767 : q);
#endif
}

/* Saturation to int16 of an int32 value (gcc emits SSAT #16 for this on cores that have it). */
/*@ assigns \nothing;
    ensures INT16_MIN <= \result <= INT16_MAX; */
static inline int32_t sea_sat16_s32(int32_t q)
{
    return (q < -32768) ? -32768 : ((q > 32767) ? 32767 : q);
}

/* Saturation to int16 of an int64 value. */
/*@ assigns \nothing;
    ensures INT16_MIN <= \result <= INT16_MAX; */
static inline int32_t sea_sat16_s64(int64_t q)
{
    return (q < -32768) ? -32768 : ((q > 32767) ? 32767 : (int32_t)q);
}

/* ReLU then saturation to int16 of an int64 value. */
/*@ assigns \nothing;
    ensures 0 <= \result <= INT16_MAX; */
static inline int32_t sea_relu_sat16_s64(int64_t q)
{
    return (q < 0) ? 0 : ((q > 32767) ? 32767 : (int32_t)q);
}

/* Narrowing of a value the generator proved to lie in int16 (the layer's output format was chosen so that
 * nothing saturates inside the calibrated box, c_runtime/README.md item 5): sea_sat16 would not act. */
/*@ assigns \nothing; */
static inline int32_t sea_proven16_s32(int32_t q)
{
    return q;
}

/* The same for a 64-bit accumulator's shifted value. */
/*@ assigns \nothing; */
static inline int32_t sea_proven16_s64(int64_t q)
{
    return (int32_t)q;
}

/* ReLU of a value proven to be at most INT16_MAX (the upper saturation would not act): max(q, 0). */
/*@ assigns \nothing; */
static inline int32_t sea_relu_proven_s32(int32_t q)
{
    return (q < 0) ? 0 : q;
}

/* The same for a 64-bit accumulator's shifted value. */
/*@ assigns \nothing; */
static inline int32_t sea_relu_proven_s64(int64_t q)
{
    return (q < 0) ? 0 : (int32_t)q;
}

/* Clamp an input to its calibrated box [lo, hi] (sea_clamp_s16 on one value). */
/*@ assigns \nothing;
    ensures lo <= hi ==> lo <= \result <= hi; */
static inline int32_t sea_clamp_s32(int32_t v, int32_t lo, int32_t hi)
{
    return (v < lo) ? lo : ((v > hi) ? hi : v);
}

/* floor(x * r / 2^s) for an int16 x and int32 r, 16 <= s <= 46 (the surface-fit planner's MIN_SHIFT), by a
 * 16x32 split: r = rh * 2^16 + rl with 0 <= rl < 2^16, so floor(x * r / 2^16) = x * rh + floor(x * rl / 2^16),
 * both products exact in int32 (ARMv6-M has no 32x32->64 multiply). Exact for every such x, r. */
/*@ requires INT16_MIN <= x <= INT16_MAX && 16 <= s <= 46;
    assigns \nothing; */
static inline int32_t sea_mulshr_split_s32(int32_t x, int32_t r, int s)
{
    const int32_t rh = r >> 16;
    const int32_t rl = (int32_t)((uint32_t)r & 0xFFFFu);
    return ((x * rh) + ((x * rl) >> 16)) >> (s - 16);
}

/* The same through a 64-bit product: for s <= 32 the high word of (x * 2^(32 - s)) * r (one SMMUL, or SMMLA
 * with the addend, on ARMv7E-M; x * 2^(32 - s) fits int32 as |x| <= 2^15). The result must fit int32. */
/*@ requires INT16_MIN <= x <= INT16_MAX && 16 <= s <= 62;
    assigns \nothing; */
static inline int32_t sea_mulshr_wide_s32(int32_t x, int32_t r, int s)
{
    if (s <= 32) {
        return (int32_t)(((int64_t)(x * (1 << (32 - s))) * r) >> 32);
    }
    return (int32_t)(((int64_t)x * r) >> s);
}

/* floor(x * r / 2^s): the Horner step's product (c_runtime/README.md, item 7); identical integers on every
 * core, the split form where the core lacks a long multiply (ARMv6-M: Cortex-M0/M0+). */
/*@ requires INT16_MIN <= x <= INT16_MAX && 16 <= s <= 46;
    assigns \nothing; */
static inline int32_t sea_mulshr_s32(int32_t x, int32_t r, int s)
{
#if defined(__ARM_ARCH_6M__)
    return sea_mulshr_split_s32(x, r, s);
#else
    return sea_mulshr_wide_s32(x, r, s);
#endif
}

/* Modular uint32 -> int32 (two's complement reinterpretation) without implementation-defined conversion;
 * compiles to nothing. Used by the M0+ kernel, whose accumulators are uint32 sums proven to end in int32. */
/*@ assigns \nothing; */
static inline int32_t sea_u32_to_s32(uint32_t u)
{
    return (u <= 0x7FFFFFFFu) ? (int32_t)u : ((int32_t)(u - 0x80000000u) - 0x7FFFFFFF - 1);
}

/* Clamp both int16 halves of the packed word x to [lo, hi] (the halves of the packed words lo and hi, each
 * lo half <= its hi half): sea_clamp_s32 on each half. With the DSP extension max then min as SSUB16 (GE
 * flags per half) and SEL, four instructions for two inputs; for Frama-C on the M4 (the struct) that function,
 * half by half (Eva cannot relate SEL's GE flags to the halves SSUB16 compared). */
/*@ assigns \nothing; */
static inline sea_int16x2 sea_clamp16x2(sea_int16x2 x, int32_t lo, int32_t hi)
{
#if defined(__FRAMAC__) && defined(__ARM_FEATURE_SIMD32)
    return sea_pack16x2(sea_clamp_s32(x.lo, sea_lo16(lo), sea_lo16(hi)),
                        sea_clamp_s32(x.hi, sea_hi16(lo), sea_hi16(hi)));
#elif defined(__ARM_FEATURE_SIMD32)
    int32_t m;
    (void)__ssub16(x, lo);
    m = sea_u32_to_s32(__sel((uint32_t)x, (uint32_t)lo));
    (void)__ssub16(m, hi);
    return sea_u32_to_s32(__sel((uint32_t)hi, (uint32_t)m));
#else
    return sea_pack16x2(sea_clamp_s32(sea_lo16(x), sea_lo16(lo), sea_lo16(hi)),
                        sea_clamp_s32(sea_hi16(x), sea_hi16(lo), sea_hi16(hi)));
#endif
}

#ifdef __cplusplus
}
#endif

#endif
