"""Typed readers for the fields of user dicts (model files, feature specs): a bad value is one line naming the
file and the field, before anything else reads it."""

from __future__ import annotations

import math
import numbers
import os
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from seagen.errors import UserError


def read_toml(path: str | os.PathLike[str], error: type[UserError] = UserError) -> dict[str, Any]:
    """A TOML file's tables (a plant config, an actuator description, a column map); a missing, unreadable,
    binary or malformed file is one `error` naming it."""
    p = Path(path)
    try:
        return tomllib.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(f"{p}: no such file") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise error(f"{p}: not valid TOML: {e}") from None
    except OSError as e:  # a folder, no permission
        raise error(f"{p}: cannot read: {e.strerror}") from None


def _what(v: Any) -> str:
    """A short description of a value for a message (its type, and its text when short)."""
    text = repr(v)
    return f"{type(v).__name__} {text}" if len(text) <= 40 else type(v).__name__


def bad(where: str, name: str, why: str) -> UserError:
    """The one-line refusal of a field: file, field, why."""
    return UserError(f"{where}: field '{name}' {why}")


def real(v: Any, where: str, name: str) -> float:
    """A finite real number (int or float, not bool, not text)."""
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        raise bad(where, name, f"must be a number, not {_what(v)}")
    f = float(v)
    if not math.isfinite(f):
        raise bad(where, name, f"must be finite, not {f}")
    return f


def positive(v: Any, where: str, name: str) -> float:
    """A finite real number > 0."""
    f = real(v, where, name)
    if not f > 0:
        raise bad(where, name, f"must be > 0, not {f:g}")
    return f


def integer(v: Any, where: str, name: str) -> int:
    """An integer (int or numpy integer, not bool, not a float such as 0.5 or 1.0)."""
    if isinstance(v, bool) or not isinstance(v, numbers.Integral):
        raise bad(where, name, f"must be an integer, not {_what(v)}")
    return int(v)


def text(v: Any, where: str, name: str) -> str:
    """A string."""
    if not isinstance(v, str):
        raise bad(where, name, f"must be a string, not {_what(v)}")
    return v


def seq(v: Any, where: str, name: str) -> Sequence[Any]:
    """A list or tuple, or a 1-D numpy array or torch tensor as its list (a string is not a list of its
    characters)."""
    if type(v).__name__ in ("ndarray", "Tensor") and getattr(v, "ndim", 0) >= 1:
        v = v.tolist()
    if not isinstance(v, list | tuple):
        raise bad(where, name, f"must be a list, not {_what(v)}")
    return v


def reals(v: Any, where: str, name: str) -> tuple[float, ...]:
    """A list of finite real numbers."""
    return tuple(real(x, where, f"{name}[{i}]") for i, x in enumerate(seq(v, where, name)))


def texts(v: Any, where: str, name: str) -> tuple[str, ...]:
    """A list of strings."""
    return tuple(text(x, where, f"{name}[{i}]") for i, x in enumerate(seq(v, where, name)))


def pair(v: Any, where: str, name: str) -> tuple[float, float]:
    """A [lo, hi] pair of finite numbers with lo < hi."""
    p = reals(v, where, name)
    if len(p) != 2:
        raise bad(where, name, f"must be a [lo, hi] pair, not {len(p)} numbers")
    if not p[0] < p[1]:
        raise bad(where, name, f"is [{p[0]:g}, {p[1]:g}]: needs lo < hi")
    return p[0], p[1]


def mapping(v: Any, where: str, name: str) -> dict[str, Any]:
    """A dict."""
    if not isinstance(v, dict):
        raise bad(where, name, f"must be a table/dict, not {_what(v)}")
    return v
