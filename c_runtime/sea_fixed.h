/* sea_fixed.h -- seagen's fixed-point primitives (hand-written C; the numeric contract, c_runtime/README.md).
 *
 * Every primitive here has a Python twin of the same name in seagen/quant/primitives.py; the two are
 * compared bit for bit by tests/test_primitives.py.
 *
 * Requirements on the compiler: two's complement integers and arithmetic right shift of negative values
 * (implementation-defined in C99; true of gcc, clang and arm-none-eabi-gcc -- checked below at compile time).
 */
#ifndef SEA_FIXED_H
#define SEA_FIXED_H

#include <stdint.h>

/* Compile-time check: right shift of a negative value is arithmetic (floor division by 2^s). */
typedef char sea_check_arith_shift[((-1) >> 1) == -1 ? 1 : -1];

/* Rounding right shift, round half to even (matches np.rint, torch.round, ONNX Round).
 * Range: any int64 v, 0 <= s <= 62. Result: round(v / 2^s), ties to even. Never overflows. */
int64_t sea_rshift_rne_s64(int64_t v, int s);

/* Same for int32 accumulators: any int32 v, 0 <= s <= 30. */
int32_t sea_rshift_rne_s32(int32_t v, int s);

/* Saturate to int16: clamp v to [INT16_MIN, INT16_MAX] before narrowing (a cast never saturates). */
int16_t sea_sat16(int64_t v);

/* Saturate to int32. */
int32_t sea_sat32(int64_t v);

/* --- the SEA's geometry in fixed point (Eq. 2, 3, 5) --------------------------------------------------
 * The linkage term of Eq. 2, cos(angle(pot)) * CB - (DE_home - CE), is a table in Q16 mm sampled every
 * 2^SEA_LINK_TABLE_SHIFT pot counts (SEA_LINK_TABLE_LEN entries covering pot 0..4096). The generator
 * emits the table (it depends on the actuator's geometry); the same integers feed every reference. */

#define SEA_COMP_FRAC_BITS 16   /* compression is Q16 millimetres in int32 */
#define SEA_FORCE_FRAC_BITS 16  /* desired force: Q16 newtons at the SEA output shaft, int32 */
#define SEA_LINK_TABLE_SHIFT 4  /* one table entry every 16 pot counts */
#define SEA_LINK_TABLE_LEN 257  /* pot 0..4096 */
#define SEA_MM_PER_COUNT_Q24 73584 /* Eq. 3: 0.00438596 mm per encoder count, Q24 */
#define SEA_POT_MAX 4095
#define SEA_POT_DEG_Q24 217588      /* Eq. 5: 53.12195/4096 deg per pot count, Q24 */
#define SEA_POT_OFFSET_Q24 (-83886080) /* Eq. 5: -5 deg, Q24 */

/* Q16 mm: linkage term for a pot reading (clamped to 0..4095), linear interpolation between entries,
 * rounded half to even. Exact integer arithmetic; |table| < 2^30 is required. */
int32_t sea_linkage_q16(const int32_t table[SEA_LINK_TABLE_LEN], int32_t pot);

/* Q16 mm: spring compression (Eq. 2) = linkage term + enc * MM_PER_COUNT (rounded half to even),
 * saturated to int32. Any int32 enc and pot. */
int32_t sea_compression_q16(const int32_t table[SEA_LINK_TABLE_LEN], int32_t enc, int32_t pot);

/* --- added for the controller (c_runtime/README.md) ------------------------------------------------ */

/* Clamp v to [lo, hi] (lo <= hi expected; if lo > hi the result is lo). Any int64 values. */
int64_t sea_clamp_s64(int64_t v, int64_t lo, int64_t hi);

/* Rounding division num / den, round half to even, for any int32 num and 0 < den (den <= 0 returns 0).
 * Floor quotient and remainder are formed in int64, so INT32_MIN / 1 cannot overflow. */
int32_t sea_div_rne_s32(int32_t num, int32_t den);

#endif
