"""Matplotlib set-up shared by every plot: figures on the non-interactive backend, PNGs written atomically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from seagen.atomic import write_with


def figure(**kw: Any) -> Any:
    """A new figure (plt.figure(**kw)) on the non-interactive Agg backend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.figure(**kw)


def save_png(fig: Any, path: Path, **savefig: Any) -> None:
    """Write a figure atomically as PNG and close it."""
    import matplotlib.pyplot as plt

    write_with(path, lambda tmp: fig.savefig(tmp, format="png", **savefig))
    plt.close(fig)


def target_line(ax: Any, target: float, band: float | None, unit: str, color: str = "grey") -> None:
    """A labelled target line (its value at the right edge) and, if `band`, the settling band around it."""
    if band:
        ax.axhspan(target - band, target + band, color=color, alpha=0.12, lw=0)
    ax.axhline(target, color=color, lw=0.8, ls="--")
    ax.annotate(
        f"target {target:g} {unit}",
        xy=(1.0, target),
        xycoords=("axes fraction", "data"),
        xytext=(-4, 3),
        textcoords="offset points",
        ha="right",
        fontsize=8,
        color="0.3",
    )


def band_legend(ax: Any, band: float, unit: str) -> None:
    """The legend with one extra entry naming the shaded settling band."""
    from matplotlib.patches import Patch

    handles, labels = ax.get_legend_handles_labels()
    handles.append(Patch(color="grey", alpha=0.12))
    labels.append(f"settling band (target ± {band:g} {unit})")
    ax.legend(handles, labels, fontsize=8)


def masked_cmap(name: str, no_data: str = "0.8") -> Any:
    """A colour map whose masked (no data) cells are drawn grey, distinct from every value."""
    import matplotlib

    return matplotlib.colormaps[name].with_extremes(bad=no_data)
