"""Float IR -> quantized IR, for either kind of model."""

from __future__ import annotations

from seagen.errors import UserError
from seagen.ir import FloatMLP, FloatModel, QModel
from seagen.quant.mlp import quantize_mlp
from seagen.quant.sf import quantize_sf


def quantize(model: FloatModel, weight_bits: int = 16) -> QModel:
    """Float IR -> quantized IR (MLP or surface fit)."""
    if weight_bits not in (8, 16):
        raise UserError(f"--weights must be int16 or int8, not int{weight_bits}")
    if isinstance(model, FloatMLP):
        return quantize_mlp(model, weight_bits)
    return quantize_sf(model)
