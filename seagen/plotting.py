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
