"""The experiment's force targets against the desired-force range a user's control model was trained on:
outside it the model's C clamps its input (and its float model extrapolates), so `simulate` refuses."""

from __future__ import annotations

from typing import Any

from seagen.control import experiment
from seagen.errors import UserError


def check_targets(model: str, act: Any, features: str | None = None, allow_pickle: bool = False) -> None:
    """Refuse (exit 2) a control model whose input force_n range (its calibrated box: the training data's
    desired forces) leaves out one of the experiment's targets on actuator `act`."""
    from seagen.frontends.load import load_float_model

    fm = load_float_model(model, features, None, allow_pickle)
    force = next((s for s in fm.inputs if s.name == "force_n"), None)
    if force is None:
        return
    targets = experiment.targets_n(act)
    out = [t for t in targets if not force.lo <= t <= force.hi]
    if out:
        shares = ", ".join(f"{f:g}" for f in experiment.TARGET_FRACTIONS)
        raise UserError(
            f"--model {model}: trained on desired forces {force.lo:.3g} to {force.hi:.3g} N (its force_n "
            f"input range), but {', '.join(f'{t:g}' for t in out)} N of the experiment's targets "
            f"{', '.join(f'{t:g}' for t in targets)} N ({shares} of control.force_max_n "
            f"{act.control.force_max_n:g} N of '{act.name}') lie outside it, where its "
            f"C clamps the input: train it on data reaching {max(targets):g} N (`seagen data summary` shows "
            "the force the data reach) or lower control.force_max_n"
        )
