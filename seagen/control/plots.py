"""Step-response plots (paper Fig. 17): reference force against time from contact, per target."""

from __future__ import annotations

from pathlib import Path

from seagen.plotting import band_legend, figure, save_png, target_line


def _angle(results: dict[str, dict], angle_index: int) -> tuple[int, float]:
    """The plotted actuator's index (clamped to the runs') and its contact angle (deg), from the traces."""
    rec = next(iter(results.values()))["trace"]
    i = min(angle_index, rec["force_n"].shape[1] - 1)
    return i, float(rec["contact_deg"][0, i])


def step_plot(name: str, results: dict[str, dict], path: Path, angle_index: int = 2) -> None:
    """One configuration: smoothed shaft force vs time for each target at one contact angle."""
    save_png(step_figure(name, results, angle_index), path, dpi=120)


def step_figure(name: str, results: dict[str, dict], angle_index: int = 2):
    """The step-response figure: force per target, each target's labelled line and its settling band, and
    a calibration model's force estimate (dotted) when the runs carry one."""
    from seagen.control.experiment import BAND_N, smoothed

    fig = figure(figsize=(6, 3.5))
    ax = fig.add_subplot()
    angle_index, angle = _angle(results, angle_index)
    for k, (target, r) in enumerate(results.items()):
        rec = r["trace"]
        f = smoothed(rec)[:, angle_index]
        t = rec["t_s"][:, angle_index]
        ax.plot(t, f, color=f"C{k}", label=f"load cell, {target} N target")
        if "estimate_n" in rec:
            est = smoothed(rec, "estimate_n")[:, angle_index]
            ax.plot(t, est, ":", color=f"C{k}", label=f"calibration model, {target} N target")
        target_line(ax, float(target), BAND_N, "N")
    ax.set(xlabel="time (s)", ylabel="force at the SEA shaft (N)")
    ax.set_title(f"{name}: contact at {angle:.0f} deg")
    band_legend(ax, BAND_N, "N")
    fig.tight_layout()
    return fig


def comparison_plot(results: dict[str, dict[str, dict]], path: Path, angle_index: int = 2) -> None:
    """Paper Fig. 17 style: every configuration's force at every target, one contact angle, one panel."""
    from seagen.control.experiment import BAND_N, smoothed

    fig = figure(figsize=(7, 4))
    ax = fig.add_subplot()
    angle_index, angle = _angle(next(iter(results.values()), {}), angle_index)
    styles = dict(zip(results, ("-", "--", ":", "-."), strict=False))
    end = max(
        (float(r["trace"]["t_s"][-1].max()) for res in results.values() for r in res.values()), default=0
    )
    for (name, res), color in zip(results.items(), ("C0", "C1", "C2", "C3"), strict=False):
        for k, r in enumerate(res.values()):
            rec = r["trace"]
            f = smoothed(rec)[:, angle_index]
            ax.plot(rec["t_s"][:, angle_index], f, styles[name], color=color, label=name if k == 0 else None)
    for target in next(iter(results.values()), {}):
        target_line(ax, float(target), BAND_N, "N")
    ax.set(xlabel="time (s)", ylabel="force at the SEA shaft (N)", xlim=(0, end or 1.0))  # the runs' length
    targets = " / ".join(next(iter(results.values()), {}))
    ax.set_title(f"{targets} N, contact at {angle:.0f} deg")
    band_legend(ax, BAND_N, "N")
    fig.tight_layout()
    save_png(fig, path, dpi=120)
