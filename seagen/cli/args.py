"""Argument types shared by the commands: a bad value is an argparse usage error (exit 2), not a traceback."""

from __future__ import annotations

import argparse
import math


def seed(text: str) -> int:
    """A random seed: a non-negative integer."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if v < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {v}")
    return v


def seconds(text: str) -> float:
    """A finite, non-negative time of at most an hour (s)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not math.isfinite(v) or not 0.0 <= v <= 3600.0:
        raise argparse.ArgumentTypeError(f"expected a time from 0 to 3600 s, got {text}")
    return v
