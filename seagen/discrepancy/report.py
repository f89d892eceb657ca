"""The report: augmented plant.toml, Markdown summary, region tables and residual maps before/after."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from seagen.discrepancy.recalibrate import PIN_SHARE, PIN_SIGMAS, change_lines, json_safe, plausible, unit_of
from seagen.discrepancy.residuals import SCORE_CHANNELS, channel_rms, region_labels, region_table, rms
from seagen.discrepancy.workflow import DRIVE, Result, worse_channels
from seagen.plant import save_config
from seagen.plant.config import pot_full_scale

NOISE_TEXT = (
    "noise sigma per trial and channel from the measured data: robust (1.4826 MAD) spread of second "
    "differences / sqrt(6) for pot and load cell; the encoder's floor is its rounding (1/sqrt 12 count). "
    "The replay is noise-free, so residuals are measurement noise plus model error; the noise floor is "
    "the RMS of the high-pass (second-difference) part of the measured signals in the same units"
)
TEST_TEXT = (
    "one-sample t-test of the mean residual per region and channel, Holm-corrected at family-wise 0.01, "
    "and only regions whose mean is at least 0.25 noise sigma count"
)


def _labels(res: Result) -> dict[str, np.ndarray]:
    """The held-out region labels (computed by identify; recomputed for a Result built without them)."""
    return res.labels or region_labels(res.held, res.config.motor, res.config.actuator.control.force_max_n)


def region_gap(res: Result) -> pd.DataFrame:
    """Held-out residual RMS before and after, per region."""
    labels = _labels(res)
    rows = []
    for kind, lab in labels.items():
        for region in sorted(set(lab[res.held.mask])):
            sel = res.held.mask & (lab == region)
            rows.append((kind, region, int(sel.sum()), rms(res.z_before, sel), rms(res.z_after, sel)))
    return pd.DataFrame(rows, columns=["by", "region", "samples", "rms_before", "rms_after"])


def residual_maps(
    res: Result, path: Path, after: dict[str, np.ndarray] | None = None, what: str = ""
) -> None:
    """Mean residual (noise sigmas) over measured force x contact angle, per channel, before and after (the
    catalogue's fit, or `after`: the discovered term's, named `what` in the titles)."""
    import matplotlib

    from seagen.plotting import masked_cmap

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    held, m = res.held, res.held.mask
    force = held.meas["force_n"][m]
    angle = np.broadcast_to(held.angle[:, None], m.shape)[m]
    fe = np.linspace(min(force.min(), 0.0), max(force.max(), 1.0), 13)
    ae = np.unique(held.angle)
    ae = np.concatenate([[ae[0] - 1], (ae[1:] + ae[:-1]) / 2, [ae[-1] + 1]])
    fig, axes = plt.subplots(2, len(SCORE_CHANNELS), figsize=(12, 6), constrained_layout=True)
    n, _, _ = np.histogram2d(force, angle, [fe, ae])
    means = {}
    for title, z in (("before", res.z_before), ("after", res.z_after if after is None else after)):
        for c in SCORE_CHANNELS:
            s, _, _ = np.histogram2d(force, angle, [fe, ae], weights=z[c][m])
            means[title, c] = np.where(n > 0, s / np.maximum(n, 1), np.nan)
    for row, title in enumerate(("before", "after")):
        for col, c in enumerate(SCORE_CHANNELS):
            # one colour scale for a channel's before and after maps (the larger of the two)
            lim = max(3.0, *(float(np.nanmax(np.abs(means[k, c]), initial=0.0)) for k in ("before", "after")))
            cells = np.ma.masked_invalid(means[title, c].T)  # no data: grey, not the white of a zero residual
            im = axes[row, col].pcolormesh(fe, ae, cells, cmap=masked_cmap("RdBu_r"), vmin=-lim, vmax=lim)
            axes[row, col].set_title(f"{c} residual, {title}{' ' + what if what and row else ''}")
            axes[row, col].set_xlabel("measured force at the shaft (N)")
            axes[row, col].set_ylabel("contact angle (deg)")
            fig.colorbar(im, ax=axes[row, col], label="mean residual (noise sigma)")
    fig.suptitle("grey cells: no samples there (not a zero residual)", fontsize=9)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _md_table(df: pd.DataFrame) -> str:
    """A DataFrame as a Markdown table (numbers to 3 significant digits)."""
    fmt = df.apply(lambda col: col.map(lambda v: f"{v:.3g}" if isinstance(v, float) else str(v)))
    lines = ["| " + " | ".join(df.columns) + " |", "|" + " --- |" * len(df.columns)]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in fmt.to_numpy().tolist()])


def markdown(res: Result, source: str, before: pd.DataFrame, after: pd.DataFrame, gap: pd.DataFrame) -> str:
    """The one-minute report."""
    fs = pot_full_scale(res.config.actuator)
    eff = pd.DataFrame(
        [
            (n.name, ", ".join(f"{k}={v:.4g}" for k, v in n.params.items()), n.confidence, _claim(n))
            for n in res.effects
        ],
        columns=["effect", "fitted parameters", "confidence", "claim"],
    )
    sig = before[before["significant"]].head(10)
    parts = [
        f"# Discrepancy report: {source}",
        f"Actuator: {res.config.actuator.name} (sha256 {res.config.actuator.digest()[:12]}; its description "
        "is not changed: plant.toml holds only the effects).",
        f"**Verdict: {res.verdict}.** Added: {', '.join(n.name for n in res.effects) or 'nothing'}. "
        f"Recalibrated: {', '.join(n.name for n in res.recalibrated) or 'nothing'}.",
        _closest(res),
        f"Held-out residual RMS {res.rms_before:.3g} -> {res.rms_after:.3g} noise sigmas "
        f"(noise floor {res.noise_floor:.3g}; {res.rms_after / res.noise_floor:.2f} x floor).",
        _timing(res),
        "## Per channel (held-out RMS, noise sigmas)\n" + _md_table(channel_table(res)),
        "\n".join(f"- **{note}.**" for note in res.notes),
        "## What the residual depends on (held-out, before fitting)\n"
        + ("\n".join(f"- {w}" for w in res.signature) or "- nothing beyond the noise")
        + "\n\nCatalogue effects by likeness of their own signature (cosine, 1 = same dependences): "
        + (", ".join(f"{e} {c:.2f}" for e, c in res.ranking[:5]) or "not ranked (no structured residual)"),
        _remainder(res),
        discovered_section(res),
        _learned(res),
        "## Parameter changes of the base (recalibrated)\n"
        + (
            "\n".join(f"- {line}" for n in res.recalibrated for line in _changes(n, fs, res.config.actuator))
            or "none"
        ),
        _pinning(res),
        "## Effects added\n" + (_md_table(eff) if len(eff) else "none"),
        "![residual maps](residual_maps.png)",
        f"## Where the base plant disagrees (held-out, ranked)\n{_md_table(sig) if len(sig) else 'nowhere'}",
        f"Significant regions after: {int(after['significant'].sum())} of {len(after)}.",
        "## Gap per region (held-out RMS, noise sigmas)\n" + _md_table(gap),
    ]
    for i, t in enumerate(res.rounds, 1):
        parts.append(f"## Round {i}: candidates scored on held-out trials\n{_md_table(t.head(8))}")
    parts += [
        f"## Method\n- drive: {DRIVE}.\n- noise: {NOISE_TEXT}.\n- test: {TEST_TEXT}.",
        "- names: every effect off in the base (not pot_noise) fitted alone on the fitting trials "
        "(batched zooming grid, then scipy least_squares), and every effect on in the base re-fitted "
        "(a recalibration, from its base values); the best one also in pairs with the others. All are "
        "scored together on held-out trials by BIC = chi2 + k ln n; a change is made when BIC drops by "
        ">= 10; confidence = bootstrap (over held-out trials) frequency of the winner including the effect; "
        "± = 1 sigma from the Gauss-Newton covariance on the fitting trials.",
        f"- run time {res.seconds:.1f} s.",
    ]
    return "\n\n".join(p for p in parts if p) + "\n"


def channel_table(res: Result) -> pd.DataFrame:
    """Held-out residual RMS per channel before and after, and whether the change made it worse."""
    before, after = channel_rms(res.z_before), channel_rms(res.z_after)
    worse = set(worse_channels(before, after))
    return pd.DataFrame(
        [
            (
                c,
                before[c],
                after[c],
                after[c] / before[c] if before[c] else np.nan,
                "WORSE" if c in worse else "",
            )
            for c in before
        ],
        columns=["channel", "rms_before", "rms_after", "after/before", "note"],
    )


def _timing(res: Result) -> str:
    """The command timing the replay used, and a warning when a declared convention disagrees."""
    if res.timing is None:
        return ""
    warn = f"\n\n**Warning: {res.timing.warning}.**" if res.timing.warning else ""
    warn += f"\n\n**Timing problem: {res.timing.problem}.**" if res.timing.problem else ""
    return f"## Command timing\n{res.timing.words()}.{warn}"


def _claim(n) -> str:
    """'named' for a claimed change, else why not (workflow._decide): at the edge of its search box, a
    compensation, or too little evidence where it acts (closest, not claimed)."""
    if n.claimed:
        return "named"
    return n.why or "compensation only (the data's form differs; not a claim)"


def _closest(res: Result) -> str:
    """The name given first and the closest single change, in words ('' when nothing changed)."""
    if res.first is None:
        return ""
    alone = (
        f"; of the catalogue's effects alone, {res.closest} fits the data best"
        if res.closest and res.closest != res.first
        else " (of the catalogue's effects alone, it fits the data best)"
        if res.closest
        else ""
    )
    return f"Named first: **{res.first}**{alone}."


def _remainder(res: Result) -> str:
    """'closest: X; the data's form differs: ...' when a structured residual is left."""
    if not res.remainder:
        return ""
    closest = res.first or (res.ranking[0][0] if res.ranking else "none")
    return f"## What is left\nclosest: {closest}; the data's form differs: " + "; ".join(res.remainder) + "."


def _learned(res: Result) -> str:
    """The learned remainder: channel, inputs and how much of the held-out gap it closes."""
    if res.learned is None:
        return ""
    lr = res.learned
    return (
        f"## Learned remainder (effect learned_residual in plant.toml)\nA smooth correction added to "
        f"{lr.channel}, from {', '.join(lr.inputs)} ({len(lr.coef)} coefficients, see sim.learned_basis): "
        f"held-out RMS {res.rms_after:.3g} -> {res.rms_learned:.3g} noise sigmas; the gap to the noise "
        f"floor is cut by {gap_cut(res.rms_before, res.rms_learned, res.noise_floor):.0%} in all "
        f"(physics alone: {gap_cut(res.rms_before, res.rms_after, res.noise_floor):.0%})."
    )


def discovered_lines(res: Result) -> list[str]:
    """The discovered term in words: form class, formula, parameters with 1-sigma, gap, claim ([] if none)."""
    d = res.discovered
    if d is None:
        return []
    pars = ", ".join(
        f"{p} = {v:.4g} ± {d.sigma.get(p, float('nan')):.2g}{' ' + unit_of(p) if unit_of(p) else ''}"
        for p, v in d.params.items()
    )
    return [
        f"discovered: {d.form} ({d.term}){'' if d.claimed else ', not claimed'}",
        f"formula: {d.formula()}",
        f"parameters: {pars}",
        *(
            [
                "fitted together with "
                + "; ".join(
                    f"{e} ({', '.join(f'{k} = {v:.4g}' for k, v in p.items())})"
                    for e, p in d.with_change.items()
                )
                + " (the catalogue's closest change, which the form stands in for or adds to)"
            ]
            if d.with_change
            else []
        ),
        f"held-out residual RMS {d.rms_before:.3g} -> {d.rms_after:.3g} noise sigmas (floor {d.floor:.3g}; "
        f"the catalogue's best: {d.rms_catalogue:.3g}); gap cut {d.cut:.0%}",
        f"unlike the closest catalogue effect, {d.unlike()}",
        f"found by: {d.basis}",
        *([d.why] if d.why else []),
    ]


def discovered_section(res: Result) -> str:
    """The report's section on the term library's search ('' when it did not run or found nothing)."""
    lines = discovered_lines(res)
    if not lines:
        return ""
    d = res.discovered
    assert d is not None
    head = "plant.toml carries it" if d.claimed else "not written to plant.toml"
    if d.table is None:  # found from the readings themselves (discover.lattice), not by the search
        return f"## Discovered: {d.form}\n" + "\n".join(f"- {x}" for x in lines) + f"\n\n{head}."
    return (
        f"## Discovered: {d.form}\n" + "\n".join(f"- {x}" for x in lines) + f"\n\n{head}. "
        "Every term of the library (discrepancy/terms.py) fitted alone (a start grid, a zoom, least squares) "
        "and scored on the held-out trials by BIC; claimed on the rule for named effects (>= 80 % of the "
        "gap closed on the channels it acts on, no significant region left there, no channel worse, no "
        "parameter at its box's edge).\n\n![discovered term's residual maps](discovered_maps.png)\n\n"
        + _md_table(d.table.drop(columns=["chi2_fit"]).head(6))
    )


def gap_cut(before: float, after: float, floor: float) -> float:
    """Share of the held-out gap (RMS above the noise floor) closed."""
    return float(1 - max(after - floor, 0.0) / max(before - floor, 1e-12))


def _changes(n, full_scale: float, act=None) -> list[str]:
    """Change lines of one recalibrated effect, with its bootstrap confidence (and claim); `full_scale`: the
    pot's counts (the plausible ranges of pot counts scale with it)."""
    return [
        f"{line} (confidence {n.confidence:.0%}{'' if n.claimed else '; ' + _claim(n)})"
        for line in change_lines(n.name, n.before, n.params, n.sigma, full_scale, act)
    ]


def write_report(res: Result, out: str | os.PathLike[str], source: str) -> None:
    """Write every report file into a temporary folder, then move it onto `out` (no partial report)."""
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out.parent, prefix=f".{out.name}."))
    try:
        labels = _labels(res)
        before = region_table(res.held, res.z_before, labels)
        after = region_table(res.held, res.z_after, labels)
        gap = region_gap(res)
        save_config(res.config, tmp / "plant.toml")
        before.to_csv(tmp / "regions_before.csv", index=False)
        after.to_csv(tmp / "regions_after.csv", index=False)
        gap.to_csv(tmp / "gap_by_region.csv", index=False)
        residual_maps(res, tmp / "residual_maps.png")
        if (d := res.discovered) is not None and d.z_after:
            residual_maps(res, tmp / "discovered_maps.png", d.z_after, f"({d.term})")
        (tmp / "report.md").write_text(markdown(res, source, before, after, gap))
        if out.exists():
            shutil.rmtree(out)
        os.replace(tmp, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def unpinned_words(res: Result) -> str:
    """The base parameters this data cannot pin, in words ('' when it pins them all)."""
    if res.check is None or not res.check.unpinned:
        return ""
    idle = res.check.unexercised
    what = ", ".join(f"{k} (1-sigma {v:.1%})" for k, v in res.check.unpinned.items() if k not in idle)
    out = []
    if what:
        out.append(
            f"this data cannot pin {what}: a change of {PIN_SHARE:.0%} of the value is below {PIN_SIGMAS:g} "
            "noise-only sigmas (all present parameters together); a wrong value there may go unnoticed"
        )
    if idle:
        out.append(f"{', '.join(idle)} not pinned: the data do not exercise it (1-sigma infinite)")
    return "; ".join(out)


def _pinning(res: Result) -> str:
    """The base-check section: the score test of the base's parameters and the ones the data cannot pin."""
    if res.check is None or not res.check.sigma:
        return ""
    c = res.check
    verdict = "off (searched)" if c.off else "consistent"
    return (
        f"## The base's own parameters\nScore test of the base's values on the fitting trials: "
        f"{c.score:.3g} (p = {c.p_value:.2g}, {len(c.sigma)} parameters): {verdict}. "
        + (unpinned_words(res).capitalize() + "." if c.unpinned else "This data pins every one within 5 %.")
    )


def summary(res: Result) -> dict:
    """The --json object."""
    fs = pot_full_scale(res.config.actuator)  # the plausible ranges of pot counts scale with the pot
    return {
        "effects": [
            {
                "name": n.name,
                "params": n.params,
                "sigma": n.sigma,
                "confidence": n.confidence,
                "claimed": n.claimed,
                "why": n.why,
                "edge": n.edge,
            }
            for n in res.effects
        ],
        "recalibrated": [
            {
                "effect": n.name,
                "param": p,
                "before": n.before[p],
                "after": v,
                "sigma": n.sigma.get(p),
                "plausible": plausible(n.name, p, v, fs, res.config.actuator),
                "confidence": n.confidence,
                "claimed": n.claimed,
                "why": n.why,
            }
            for n in res.recalibrated
            if n.before is not None
            for p, v in n.params.items()
        ],
        "verdict": res.verdict,
        "named_first": res.first,
        "closest_single": res.closest,
        "notes": res.notes,
        "channels": channel_table(res).to_dict(orient="records"),
        "timing": None
        if res.timing is None
        else {
            "lag": res.timing.lag,
            "fitted_lag": res.timing.fitted,
            "pinned_lag": res.timing.pinned,
            "offset_ms": res.timing.offset_ms,
            "median_period_s": res.timing.period_s,
            "warning": res.timing.warning,
            "problem": res.timing.problem,
        },
        "unpinned": {} if res.check is None else json_safe(res.check.unpinned),
        "unexercised": [] if res.check is None else res.check.unexercised,
        "base_check": None
        if res.check is None
        else {"score": res.check.score, "p_value": res.check.p_value, "sigma": json_safe(res.check.sigma)},
        "signature": res.signature,
        "signature_ranking": [[e, c] for e, c in res.ranking],
        "remainder": res.remainder,
        "learned": None
        if res.learned is None
        else {"channel": res.learned.channel, "inputs": res.learned.inputs, "rms_after": res.rms_learned},
        "discovered": None
        if res.discovered is None
        else {
            "form": res.discovered.form,
            "term": res.discovered.term,
            "params": res.discovered.params,
            "sigma": json_safe(res.discovered.sigma),
            "claimed": res.discovered.claimed,
            "why": res.discovered.why,
            "formula": res.discovered.formula(),
            "unlike": res.discovered.unlike(),
            "rms_after": res.discovered.rms_after,
            "gap_cut": res.discovered.cut,
        },
        "gap_cut": gap_cut(res.rms_before, res.rms_learned, res.noise_floor),
        "rms_before": res.rms_before,
        "rms_after": res.rms_after,
        "noise_floor": res.noise_floor,
        "seconds": res.seconds,
    }
