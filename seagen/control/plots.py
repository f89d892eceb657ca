"""Step-response plots (paper Fig. 17): reference force against time from contact, per target."""

from __future__ import annotations

from pathlib import Path

from seagen.plotting import figure, save_png


def step_plot(name: str, results: dict[str, dict], path: Path, angle_index: int = 2) -> None:
    """One configuration: smoothed shaft force vs time for each target at one contact angle."""
    from seagen.control.experiment import CONTACT_DEG, smoothed

    fig = figure(figsize=(6, 3.5))
    ax = fig.add_subplot()
    angle_index = min(angle_index, len(CONTACT_DEG) - 1)
    for target, r in results.items():
        rec = r["trace"]
        f = smoothed(rec["force_n"])[:, angle_index]
        ax.plot(rec["t_s"][:, angle_index], f, label=f"{target} N")
        ax.axhline(float(target), color="grey", lw=0.5, ls="--")
    ax.set(xlabel="time (s)", ylabel="force at the SEA shaft (N)")
    ax.set_title(f"{name}: contact at {CONTACT_DEG[angle_index]:.0f} deg")
    _save(fig, ax, path)


def comparison_plot(results: dict[str, dict[str, dict]], path: Path, angle_index: int = 2) -> None:
    """Paper Fig. 17 style: every configuration's force at every target, one contact angle, one panel."""
    from seagen.control.experiment import CONTACT_DEG, smoothed

    fig = figure(figsize=(7, 4))
    ax = fig.add_subplot()
    angle_index = min(angle_index, len(CONTACT_DEG) - 1)
    styles = dict(zip(results, ("-", "--", ":", "-."), strict=False))
    for (name, res), color in zip(results.items(), ("C0", "C1", "C2", "C3"), strict=False):
        for k, (target, r) in enumerate(res.items()):
            rec = r["trace"]
            f = smoothed(rec["force_n"])[:, angle_index]
            ax.plot(rec["t_s"][:, angle_index], f, styles[name], color=color, label=name if k == 0 else None)
            ax.axhline(float(target), color="grey", lw=0.5)
    ax.set(xlabel="time (s)", ylabel="force at the SEA shaft (N)", xlim=(0, 4))
    ax.set_title(f"5 / 10 / 15 N, contact at {CONTACT_DEG[angle_index]:.0f} deg")
    _save(fig, ax, path)


def _save(fig, ax, path: Path) -> None:
    """Legend, tight layout, PNG written atomically, figure closed."""
    ax.legend()
    fig.tight_layout()
    save_png(fig, path, dpi=120)
