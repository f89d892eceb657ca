"""Several inputs a torch.export program concatenates along the features before anything else
(`torch.cat([a, b], dim=1)` on its (batch, width) inputs): read as one input vector, its features in the
concatenation's order; the original runs on each row's columns split back into its inputs."""

from __future__ import annotations

from typing import Any

from seagen.errors import UserError

Parts = list[tuple[int, int]]  # per piece of the joined vector, in order: (argument position, width)


def user_placeholders(ep: Any) -> list[Any]:
    """The placeholder nodes of a program's user inputs, in the order its forward takes them."""
    users = [s.arg.name for s in ep.graph_signature.input_specs if s.kind.name == "USER_INPUT"]
    by_name = {n.name: n for n in ep.graph.nodes if n.op == "placeholder"}
    return [by_name[u] for u in users if u in by_name]


def joined_inputs(ep: Any, where: str) -> tuple[str, Parts] | None:
    """The aten.cat node that joins every user input once along the features (each (batch, width), one
    batch) and the parts it joins; None when no cat takes exactly the user inputs."""
    phs = user_placeholders(ep)
    names = sorted(n.name for n in phs)
    pos = {n.name: k for k, n in enumerate(phs)}
    for n in ep.graph.nodes:
        if n.op != "call_function" or str(n.target) != "aten.cat.default" or not n.args:
            continue
        pieces = list(n.args[0])
        if sorted(getattr(a, "name", "") for a in pieces) != names:
            continue
        dim = n.args[1] if len(n.args) > 1 else n.kwargs.get("dim", 0)
        shapes = [tuple(getattr(a.meta.get("val"), "shape", ())) for a in pieces]
        if dim not in (1, -1) or any(len(s) != 2 for s in shapes) or len({str(s[0]) for s in shapes}) > 1:
            raise UserError(
                f"{where}: {n.name} ({n.target}) concatenates the program's inputs other than along the "
                "features of (batch, width) inputs; seagen reads inputs joined into one feature vector"
            )
        return n.name, [(pos[a.name], int(s[1])) for a, s in zip(pieces, shapes, strict=True)]
    return None


def split_args(t: Any, parts: Parts | None) -> list[Any]:
    """The forward's arguments for rows t of the joined vector: t itself, or its columns split into the
    inputs in the forward's order."""
    import torch

    if not parts:
        return [t]
    args: list[Any] = [None] * len(parts)
    for (k, _), piece in zip(parts, torch.split(t, [w for _, w in parts], dim=1), strict=True):
        args[k] = piece.contiguous()
    return args
