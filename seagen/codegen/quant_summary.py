"""The quantization summary: Q formats, accumulator widths, flash and RAM bytes, the error bound."""

from __future__ import annotations

from seagen.ir import QMLP, QModel
from seagen.runtime.features import FEATURES, N_BASE, not_computed
from seagen.runtime.fixed import LINK_TABLE_LEN

STATE_BYTES = 4 * 2 * N_BASE + 4  # sea_features_state: p1, p2 (int32 per base signal), primed (padded)


def buffer_width(qm: QMLP) -> int:
    """Elements of each int16 working buffer of an MLP: the widest of the inputs and every layer's output."""
    return max([len(qm.inputs)] + [q.w_q.shape[0] for q in qm.layers])


def memory(qm: QModel) -> dict[str, int]:
    """Bytes of const data (flash) and of working buffers + state (RAM) of the generated model."""
    flash = 2 * 2 * len(qm.inputs)  # clamp box
    flash += 4 * LINK_TABLE_LEN  # linkage table of the feature pipeline
    if isinstance(qm, QMLP):
        for q in qm.layers:
            flash += q.w_q.size * (qm.weight_bits // 8) + q.b_q.size * (q.acc_bits // 8)
        flash += sum(2 * len(t.values) for t in qm.tables)
        return {"flash_data_bytes": flash, "ram_bytes": 2 * 2 * buffer_width(qm) + STATE_BYTES}
    flash += 4 * sum(1 for op in qm.horner if op.var < 0 or op.add_reg < 0)
    return {"flash_data_bytes": flash, "ram_bytes": 2 * len(qm.inputs) + 4 * qm.n_regs + STATE_BYTES}


def summary_lines(qm: QModel) -> list[str]:
    """Human-readable lines (also printed into the generated header comment)."""
    lines = [f"model: {qm.kind} ({qm.task}), output {qm.output.name} [{qm.output.unit}] in Q{qm.out_frac}"]
    for i, qi in enumerate(qm.inputs):
        s = qi.signal
        lines.append(
            f"in[{i}] {s.name} [{s.unit}] Q{qi.frac}, calibrated {s.lo:.6g}..{s.hi:.6g}, "
            f"clamped to {qi.lo_q}..{qi.hi_q}"
        )
    if isinstance(qm, QMLP):
        for k, q in enumerate(qm.layers):
            shape = f"{q.w_q.shape[1]}->{q.w_q.shape[0]} {q.activation}"
            lines.append(
                f"layer {k}: {shape}, weights int{qm.weight_bits} Q{q.w_frac}, acc int{q.acc_bits} "
                f"Q{q.w_frac + q.in_frac}, out Q{q.out_frac} (shift {q.shift})"
            )
    else:
        lines.append(
            f"surface fit: {len(qm.horner)} Horner steps on {qm.n_regs} int32 registers, floor shifts"
        )
    if missing := not_computed(qm):
        lines.append(
            f"NAME_infer only: no NAME_step, since the firmware feature pipeline does not compute "
            f"{', '.join(missing)} (it computes {', '.join(FEATURES)})"
        )
    m = memory(qm)
    lines.append(f"flash (const data) {m['flash_data_bytes']} B, RAM {m['ram_bytes']} B")
    lines.append(
        f"proven |fixed - float| <= {qm.error_bound:.6g} {qm.output.unit} over the calibrated box "
        f"(widened 12.5 % each side)"
    )
    return lines
