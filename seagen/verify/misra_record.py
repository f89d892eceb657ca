# ruff: noqa: E501
"""seagen's MISRA C:2012 deviation record (explained in docs/misra.md): rule, files, the code it covers.

Each entry covers the lines of the files matching `files` (a glob) that match `match` (a regex): one code
location of c_runtime/ or of a template (where a template line repeats, e.g. one line per weight, the entry
covers that one template line). seagen.verify.misra turns it into cppcheck's suppression list."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Deviation:
    """One recorded deviation: `rule` on the lines of files matching `files` (regex) that match `match` (regex)."""

    ident: str  # D1, D2, ... (the heading in docs/misra.md)
    rule: str  # MISRA rule (10.4) or a cppcheck id (unusedFunction)
    files: str  # regex on the file name
    match: str


def _d(ident: str, rule: str, files: str, *matches: str) -> tuple[Deviation, ...]:
    """One deviation at several lines of one location (a function or a template block)."""
    return tuple(Deviation(ident, rule, files, m) for m in matches)


# Model files: NAME.c of any prefix (runtime files are named sea_*).
MODEL_C = r"(?!sea_)\w+\.c"
# The actuator's constants: sea_act_<id>.c (seagen/codegen/actfile.py).
ACT_C = r"sea_act_[a-p]{8}\.c"

RECORD: tuple[Deviation, ...] = (
    # D1 (10.1, required; shiftNegativeLHS): arithmetic right shift of a signed value = floor division.
    *_d(
        "D1",
        "10.1",
        r"sea_fixed(_ctrl)?\.c",
        r"q = v >> s;",
        r"half = \(int(32|64)_t\)1 << \(s - 1\);",
        r"r = \(int(32|64)_t\)\(\(uint(32|64)_t\)v & \(\(\(uint(32|64)_t\)1 << s\) - 1u\)\);",
        r"int32_t i = p >> s;",
        r"int32_t f = \(int32_t\)\(\(uint32_t\)p & \(\(\(uint32_t\)1 << s\) - 1u\)\);",
        r"r = sea_rshift_rne_s32\(\(lo32 \* \(\(1 << s\) - f\)\)",
        r"const int64_t v = \(lo \* \(\(int64_t\)1 << s\)\)",
        r"if \(SEA_ABS_BELOW\(",
    ),
    *_d("D1", "shiftNegativeLHS", r"sea_fixed(_ctrl)?\.c", r"q = v >> s;"),
    *_d(
        "D1",
        "10.1",
        "sea_nn.c",
        r"int64_t p = \(\(int64_t\)x \* t\) >> shift;",
        r"int64_t a = \(align >= 0\) \?",
    ),
    *_d(
        "D1",
        "10.1",
        "sea_nn.h",
        r"if \(v > \(INT16_MAX >> k\)\)",
        r"if \(v < -\(32768 >> k\)\)",
        r"return \(int16_t\)\(\(int32_t\)v \* \(\(int32_t\)1 << k\)\);",
        r"return sea_sat32\(v \* \(\(int64_t\)1 << \(to_frac",
    ),
    *_d(
        "D1",
        "10.1",
        "sea_pid.c",
        r"const int32_t [ab]h = [ab] >> 16;",
        r"const int64_t q = p >> s;",
        r"const uint32_t half = \(uint32_t\)1 << \(s - 1\);",
        r"const uint32_t r = \(uint32_t\)p & ",
        r"const int64_t (lo|hi) = \(int64_t\)p->out_(min|max) \* SEA_PID_ONE_MV;",
        r"int64_t alpha = sea_clamp_s64\(p->d_alpha",
        r"s->integ = o \* SEA_PID_ONE_MV;",
    ),
    *_d("D1", "shiftNegativeLHS", "sea_pid.c", r"const int32_t bh = b >> 16;"),
    *_d(
        "D1",
        "10.1",
        "sea_dsp.h",
        r"const int32_t rh = r >> 16;",
        r"int(32|64)_t q = v >> s;",
        r"const uint(32|64)_t bit = \(\(uint(32|64)_t\)u >> s\) & 1u;",
        r"if \(\(\(uint(32|64)_t\)v << \((32|64) - s\)\) == 0u\)",
        r"return \(\(x \* rh\) \+ \(\(x \* rl\) >> 16\)\)",
        r"return \(int32_t\)\(\(\(int64_t\)\(x \* \(1 << \(32 - s\)\)\) \* r\) >> 32\);",
        r"return \(int32_t\)\(\(\(int64_t\)x \* r\) >> s\);",
    ),
    # D2 (10.4, required): the M0+ kernel's offset-weight product u * x into an int64 accumulator.
    *_d("D2", "10.4", MODEL_C, r"^ +[ab] \+= u\[\d+\] \* xv;$"),
    # D3 (10.8, required): composite expressions cast to another essential type (exact reinterpretations).
    *_d(
        "D3",
        "10.8",
        MODEL_C,
        r"^ +const uint32_t base = 32768u \* \(uint32_t\)\(",
        r"^ +\*o \+= \(uint32_t\)\(\w+_w\d+\[j( \+ 1)?\] \* y[ab]\);$",
        r"^ +\*o \+= \(uint32_t\)\(\w+_w\d+\[\d+\] \* ya\);$",
    ),
    *_d(
        "D3",
        "10.8",
        "sea_dsp.h",
        r"const int32_t rl = \(int32_t\)\(\(uint32_t\)r & 0xFFFFu\);",
        r"return \(hi \* 65536\) \+ \(int32_t\)\(\(uint32_t\)lo & 0xFFFFu\);",
        # sea_pack_nonneg16x2 as an OR of the two non-negative halves (the same word as hi * 65536 + lo)
        r"return \(int32_t\)\(\(\(uint32_t\)hi << 16\) \| \(uint32_t\)lo\);",
        r"return \(int32_t\)\(\(\(uint32_t\)w (& 0xFFFFu|>> 16)\) \^ 0x8000u\) - 0x8000;",
        r"return \(u <= 0x7FFFFFFFu\) \? \(int32_t\)u",
    ),
    *_d(
        "D3",
        "10.8",
        "sea_nn.c",
        r"^    SEA_DENSE_BODY\(int64_t, sea_rshift_rne_s64, SEA_ROM_RD(8|16), SEA_ROM_RD64\)$",
    ),
    *_d("D3", "10.8", "sea_pid.c", r"const int64_t p = \(\(int64_t\)\(ah \* bh\) \* 4294967296\)"),
    *_d("D3", "10.7", "sea_pid.c", r"const int64_t mid = \(int64_t\)\(ah \* \(int32_t\)bl\)"),
    # D4 (20.7, required): the dense kernels' shared body macro (its parameters are a type and functions).
    *_d("D4", "20.7", "sea_nn.c", r"^#define SEA_DENSE_BODY\(ACC, SHIFT_FN, RD_W, RD_B\)"),
    # D5 (11.5, advisory): the predictor callback's void *ctx back to its state type.
    *_d("D5", "11.5", MODEL_C, r"_step\(\(\w+_state_t \*\)ctx, enc, pot"),
    *_d("D5", "11.5", MODEL_C, r"_step_features\(\(const sea_features_out \*\)ctx, "),
    *_d("D5", "11.5", "sea_control_extra.c", r"const sea_kin_params \*k = \(const sea_kin_params \*\)ctx;"),
    # D6 (18.4, advisory): the target kernels step their weight pointer by a constant stride.
    *_d("D6", "18.4", MODEL_C, r"^ +[uw] \+= \d+;$"),
    # D7 (8.9, advisory): constant tables at file scope (one per layer, as the portable kernel's).
    *_d(
        "D7",
        "8.9",
        MODEL_C,
        r"^static const u?int(8|16|32|64)_t \w+_(in_lo|in_hi|w\d+|b\d+|c\d+|t\d+|u\d+|tanh\w*|sigmoid\w*|tab\w*)\[",
        r"^static const sea_pid_params \w+_pid = ",
    ),
    *_d("D7", "8.9", ACT_C, r"^static const int32_t sea_act_[a-p]{8}_link_q16\["),
    # D8 (8.7, advisory): the public API (the actuator's constants and sea_linkage_q16) has external linkage.
    *_d("D8", "8.7", ACT_C, r"^const sea_act sea_act_[a-p]{8} = \{"),
    *_d("D8", "8.7", r"sea_fixed(_ctrl)?\.c", r"^int32_t sea_linkage_q16\("),
    # D9 (2.5, advisory): documented constants of the runtime API that a given export does not use.
    *_d("D9", "2.5", "sea_features.h", r"^#define SEA_FEAT_(ANGLE_FRAC_BITS|EXTERNAL|BASE) "),
    *_d("D9", "2.5", "sea_fixed.h", r"^#define SEA_(FORCE|COMP)_FRAC_BITS "),
    # the table read macros (one per width): an export reads the widths of its own tables only
    *_d("D9", "2.5", "sea_fixed.h", r"^#define SEA_ROM(_RD(8|16|32|64)\(p\) .*)?$"),
    *_d("D9", "2.5", "sea_dsp.h", r"^#define SEA_OPAQUE\(p\) "),
    # the proven domain of NAME_step's raw arguments (docs/prove.md): read by the ACSL contracts and the caller
    *_d("D9", "2.5", r"(?!sea_)\w+\.h", r"^#define [A-Z0-9_]+_(ENC|POT|FORCE|CMD)_(MIN|MAX) "),
    # D10 (2.3, advisory): the compile-time check of the arithmetic right shift.
    *_d("D10", "2.3", "sea_fixed.h", r"^typedef char sea_check_arith_shift\["),
    # D11 (15.5, advisory): early returns of the saturations and rounding shifts.
    *_d(
        "D11",
        "15.5",
        r"sea_fixed(_ctrl)?\.c",
        r"^        return (v|0|INT16_MAX|INT16_MIN|INT32_MAX|INT32_MIN);$",
        r"^        return sea_rshift_rne_s32\(\(int32_t\)v, s\);",
    ),
    *_d(
        "D11",
        "15.5",
        "sea_nn.h",
        r"^            return (INT16_MAX|INT16_MIN);$",
        r"^            return \(int16_t\)\(\(v > 0\)",
    ),
    *_d("D11", "15.5", "sea_features.h", r"^        return "),
    *_d("D11", "15.5", "sea_control.c", r"^        return( 0)?;"),
    # D12 (12.1, advisory): remaining precedence findings on fully bracketed conditional expressions.
    *_d("D12", "12.1", r"sea_fixed(_ctrl)?\.c", r"r = \(ra != 0u\) \? \(d - ra\) : 0u;"),
    *_d("D12", "12.1", "sea_nn.c", r"k = \(k < 0\) \? 0 : \(\(k > \(len - 1\)\)"),
    *_d("D12", "12.1", "sea_pid.c", r"return \(\(r > half\) \|\| \(\(r == half\)"),
    # D13 (2.2, required): a `1 * n` array length in the portable kernel's last layer.
    *_d("D13", "2.2", MODEL_C, r"^static const int(8|16)_t \w+_w\d+\[1 \* \d+\]( SEA_ROM)? = \{"),
    # D14 (unusedFunction): runtime functions not called by the folder's exports (shipped whole per file).
    *_d("D14", "unusedFunction", "sea_nn.c", r"^(void|int32_t) sea_\w+\("),
    # D3 (10.7/10.8): found once the 10.1 findings of the same lines are recorded.
    *_d("D3", "10.7", "sea_dsp.h", r"if \(\(\(uint64_t\)v << \(64 - s\)\) == 0u\)"),
    *_d(
        "D3",
        "10.8",
        "sea_dsp.h",
        r"return \(int32_t\)\(\(\(int64_t\)\(x \* \(1 << \(32 - s\)\)\) \* r\) >> 32\);",
    ),
    *_d(
        "D3",
        "10.8",
        r"sea_fixed(_ctrl)?\.c",
        r"r = \(int(32|64)_t\)\(\(uint(32|64)_t\)v & \(\(\(uint(32|64)_t\)1 << s\) - 1u\)\);",
        r"int32_t f = \(int32_t\)\(\(uint32_t\)p & \(\(\(uint32_t\)1 << s\) - 1u\)\);",
    ),
    *_d("D3", "10.7", r"sea_fixed(_ctrl)?\.c", r"half = \(int64_t\)1 << \(s - 1\);"),
    *_d("D3", "10.7", "sea_nn.h", r"return sea_sat32\(v \* \(\(int64_t\)1 << \(to_frac - from_frac\)\)\);"),
    *_d("D3", "10.8", "sea_pid.c", r"const int64_t mid = \(int64_t\)\(ah \* \(int32_t\)bl\)"),
    # D11 (15.5): more early returns.
    *_d("D11", "15.5", "sea_nn.h", r"^        return \(int16_t\)\(\(int32_t\)v \* \(\(int32_t\)1 << k\)\);"),
    *_d("D11", "15.5", r"sea_fixed(_ctrl)?\.c", r"^        return sea_rshift_rne_s32\(\(a32 \* "),
    *_d("D11", "15.5", "sea_nn.h", r"^        return sea_sat32\(v \* \(\(int64_t\)1 << "),
    *_d(
        "D11",
        "15.5",
        "sea_dsp.h",
        r"^        return \(int32_t\)\(\(\(int64_t\)\(x \* \(1 << \(32 - s\)\)\) \* r\) >> 32\);",
    ),
    # D1 (10.1): the Cortex-M surface-fit kernel's addend floor(r / 2^k) (sf_horner.c.j2).
    *_d("D1", "10.1", MODEL_C, r"^    r\d+ = sea_mulshr_s32\(x\d+, r\d+, \d+\) \+ \(r\d+ >> \d+\);$"),
    # D15 (cppcheck variableScope, style): a one-layer network's kernel declares at function scope.
    *_d("D15", "variableScope", MODEL_C, r"^    int j;$", r"^    int32_t h\d+\[\d+\];$"),
    # D16 (2.7, advisory): the grouped loads' pointer is an operand of their inline assembly on the M4.
    *_d("D16", "2.7", "sea_dsp.h", r"^static inline void sea_ld[24]\(const int32_t \*p, int32_t \*v0, "),
)
