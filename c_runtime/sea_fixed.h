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

/* Constant tables in program memory. SEA_ROM marks a constant table (weights, biases, activation tables, the
 * actuator's linkage table); SEA_ROM_RD8/16/32/64(p) read the element p points to, one macro per width.
 * On an AVR (avr-gcc, __AVR__) a const table is otherwise copied into RAM at start-up (an Uno has 2 KB): there
 * SEA_ROM is avr-libc's PROGMEM and the reads are its pgm_read_*. Everywhere else (host, Cortex-M, Frama-C,
 * cppcheck) SEA_ROM is empty and a read is a plain dereference: the same C as before. */
#if defined(__AVR__) && !defined(__FRAMAC__)
#include <avr/pgmspace.h>
#define SEA_ROM PROGMEM
#define SEA_ROM_RD8(p) ((int8_t)pgm_read_byte(p))
#define SEA_ROM_RD16(p) ((int16_t)pgm_read_word(p))
#define SEA_ROM_RD32(p) ((int32_t)pgm_read_dword(p))
#define SEA_ROM_RD64(p) \
    ((int64_t)(((uint64_t)pgm_read_dword((const uint8_t *)(p) + 4) << 32) | (uint64_t)pgm_read_dword(p)))
#else
#define SEA_ROM
#define SEA_ROM_RD8(p) (*(p))
#define SEA_ROM_RD16(p) (*(p))
#define SEA_ROM_RD32(p) (*(p))
#define SEA_ROM_RD64(p) (*(p))
#endif

#ifdef __cplusplus
extern "C" {
#endif

/* Compile-time check: right shift of a negative value is arithmetic (floor division by 2^s). */
typedef char sea_check_arith_shift[((-1) >> 1) == -1 ? 1 : -1];

/* Rounding right shift, round half to even (matches np.rint, torch.round, ONNX Round).
 * Range: any int64 v, 0 <= s <= 62. Result: round(v / 2^s), ties to even. Never overflows. */
/*@ requires s <= 62;
    assigns \nothing;
    ensures s <= 0 ==> \result == v; */
int64_t sea_rshift_rne_s64(int64_t v, int s);

/* Same for int32 accumulators: any int32 v, 0 <= s <= 30. */
/*@ requires s <= 30;
    assigns \nothing;
    ensures s <= 0 ==> \result == v; */
int32_t sea_rshift_rne_s32(int32_t v, int s);

/* Saturate to int16: clamp v to [INT16_MIN, INT16_MAX] before narrowing (a cast never saturates). */
/*@ assigns \nothing;
    ensures INT16_MIN <= \result <= INT16_MAX; */
int16_t sea_sat16(int64_t v);

/* Saturate to int32. */
/*@ assigns \nothing;
    ensures INT32_MIN <= \result <= INT32_MAX; */
int32_t sea_sat32(int64_t v);

/* --- the SEA's geometry in fixed point (Eq. 2, 3, 5) --------------------------------------------------
 * Every number of the actuator is a field of a `const sea_act` (below) that the exporter emits per actuator
 * description in sea_act_<id>.c (<id>: the digest's first 32 bits as letters); the runtime reads
 * it through a pointer, so actuators of different designs share one firmware. seagen/runtime/actq.py chooses
 * and proves the formats for each description (or refuses it); the same object feeds every reference.
 * The linkage term of Eq. 2, cos(angle(pot)) * CB - (DE_home - CE), is a table in Q16 mm of
 * SEA_LINK_TABLE_LEN entries, one every 2^link_shift pot counts (link_shift = ADC bits - 8). */

#define SEA_COMP_FRAC_BITS 16   /* compression is Q16 millimetres in int32 */
#define SEA_FORCE_FRAC_BITS 16  /* desired force: Q16 newtons at the SEA output shaft, int32 */
#define SEA_LINK_TABLE_LEN 257  /* 2^8 + 1 entries: pot 0..2^adc_bits */

/* One actuator's constants (field order: seagen/runtime/actq.py ActQ.struct_fields). */
typedef struct {
    const int32_t *link_q16;  /* SEA_LINK_TABLE_LEN entries, Q16 mm, |entry| < 2^30 */
    int32_t link_shift;       /* one entry every 2^link_shift pot counts (0..8) */
    int32_t link_i32_bits;    /* 30 - link_shift: entries in [-2^k, 2^k) interpolate in int32 */
    int32_t pot_max;          /* the largest pot reading, 2^adc_bits - 1 */
    int32_t travel_q;         /* Eq. 3: mm per encoder count in Q(16 + travel_shift), 1..2^31 - 1 */
    int32_t travel_shift;     /* 8..30 */
    int32_t enc_i32_bits;     /* -2^k <= enc < 2^k: enc * travel_q fits int32 */
    int32_t pot_deg_q24;      /* Eq. 5: deg per pot count, Q24 */
    int32_t pot_offset_q24;   /* Eq. 5: deg at pot 0, Q24 */
    int32_t motor_max_mv;     /* the motor supply: command range +-motor_max_mv (int32 mV, sea_pid.h) */
    int32_t enc_jump_max;     /* default encoder-jump bound: twice the no-load counts per tick */
    int32_t pot_avg_ticks;    /* ticks per pot average (refreshed at 10 Hz) */
    int32_t pot_stuck_ticks;  /* default: rail readings over 100 ms = stuck */
} sea_act;

/* Q16 mm: linkage term for a pot reading (clamped to 0..pot_max), linear interpolation between entries,
 * rounded half to even. Exact integer arithmetic. */
/*@ requires \valid_read(a) && \valid_read(a->link_q16 + (0 .. SEA_LINK_TABLE_LEN - 1));
    requires 0 <= a->link_shift <= 8 && a->link_i32_bits == 30 - a->link_shift;
    requires 0 <= a->pot_max && (a->pot_max >> a->link_shift) < SEA_LINK_TABLE_LEN - 1;
    assigns \nothing; */
int32_t sea_linkage_q16(const sea_act *a, int32_t pot);

/* Q16 mm: spring compression (Eq. 2) = linkage term + enc * travel (rounded half to even), saturated to
 * int32. Any int32 enc and pot. */
/*@ requires \valid_read(a) && \valid_read(a->link_q16 + (0 .. SEA_LINK_TABLE_LEN - 1));
    requires 0 <= a->link_shift <= 8 && 8 <= a->travel_shift <= 30 && 0 <= a->enc_i32_bits <= 30;
    requires 0 <= a->pot_max && (a->pot_max >> a->link_shift) < SEA_LINK_TABLE_LEN - 1;
    assigns \nothing; */
int32_t sea_compression_q16(const sea_act *a, int32_t enc, int32_t pot);

/* --- added for the controller (c_runtime/README.md) ------------------------------------------------ */

/* Clamp v to [lo, hi] (lo <= hi expected; if lo > hi the result is lo). Any int64 values. */
/*@ assigns \nothing;
    ensures lo <= hi ==> lo <= \result <= hi;
    ensures lo > hi ==> \result == lo; */
int64_t sea_clamp_s64(int64_t v, int64_t lo, int64_t hi);

/* Rounding division num / den, round half to even, for any int32 num and 0 < den (den <= 0 returns 0).
 * Floor quotient and remainder are formed in int64, so INT32_MIN / 1 cannot overflow. */
/*@ assigns \nothing;
    ensures den <= 0 ==> \result == 0; */
int32_t sea_div_rne_s32(int32_t num, int32_t den);

#ifdef __cplusplus
}
#endif

#endif
