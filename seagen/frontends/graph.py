"""Follow a dataflow graph by its edges: from the output back to the input, one computed edge per node."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from seagen.errors import UserError
from seagen.frontends.chain import SUPPORTED


@dataclass
class Node:
    """One graph node as both frontends see it: op name, path, input/output edge names and attributes."""

    op: str
    path: str
    inputs: list[str]
    outputs: list[str]
    attrs: dict[str, Any] = field(default_factory=dict)
    raw: Any = None  # the producer's own node object


def chain_nodes(
    nodes: list[Node], consts: set[str], graph_input: str, graph_output: str, where: str
) -> list[Node]:
    """The nodes from graph_input to graph_output, in order; every node on the way must take exactly one
    computed input (the others constants). Nodes that do not reach the output are ignored (dead code)."""
    producer = {o: n for n in nodes for o in n.outputs if o}
    path: list[Node] = []
    edge = graph_output
    seen_consts: dict[str, Node] = {}
    while edge != graph_input:
        node = producer.get(edge)
        if node is None:
            raise UserError(f"{where}: edge '{edge}' is neither computed from the input nor a constant")
        computed = list(dict.fromkeys(i for i in node.inputs if i and i not in consts))  # x + x: one edge
        if len(computed) != 1:
            what = ", ".join(computed) if computed else "nothing"
            raise UserError(
                f"{where}: {node.path} ({node.op}) takes {len(computed)} computed inputs ({what}): not a "
                f"chain (a residual add, a weight given as a graph input?); {SUPPORTED}"
            )
        for c in node.inputs:
            if c in consts and c in seen_consts and _is_weight(node) and _is_weight(seen_consts[c]):
                raise UserError(
                    f"{where}: {node.path} ({node.op}) uses the weights '{c}' of {seen_consts[c].path} again "
                    f"(a layer called twice); {SUPPORTED}"
                )
            seen_consts.setdefault(c, node)
        path.append(node)
        edge = computed[0]
    return path[::-1]


def _is_weight(node: Node) -> bool:
    """Nodes whose constant inputs are layer weights (sharing them means a layer is called twice)."""
    return node.op in (
        "Gemm",
        "MatMul",
        "aten.linear.default",
        "aten.addmm.default",
        "aten.mm.default",
        "aten.matmul.default",
    )
