"""Write the 61-trial rig session of docs/discrepancy.md (rig.csv, map.toml, base.toml) into OUT.

    python examples/rig_session.py OUT [lugre|none] [--repeat N]

61 protocol pushes (PUSH_MOVES) at the 12 contact angles, logged by the simulated rig loop (~250 Hz jittered
integer-ms clock, from_row, seed 4). `lugre`: a steady-state LuGre friction in place of the catalogue's
actuator friction (out of the catalogue; base.toml is the plant without actuator friction); `none`: the
default plant, nothing hidden. `--repeat N` writes the session N times one after the other (later clock,
2 s gaps): a large log for timing `seagen data import` (44 repeats: ~102 MB).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from seagen import fmath
from seagen.data.protocol import PUSH_MOVES, scaled_move, train_angles
from seagen.discrepancy import riglog
from seagen.geometry import geometry
from seagen.plant import Plant, PlantConfig, save_config


class LuGrePlant(Plant):
    """Steady-state LuGre friction band (Fc + (Fs-Fc) e^{-|v|/vs}) + s2 |v| on top of the other friction."""

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's friction plus the velocity-shaped band (symmetric)."""
        fwd, rev = super().friction_limits(angle_deg)
        v = np.abs(getattr(self, "v_shaft", np.zeros_like(fwd)))
        band = 2.2 + 0.9 * fmath.exp(-v / 0.8) + 0.02 * v
        return fwd + band, rev + band


def main(argv: list[str]) -> None:
    """Simulate, log and write the session."""
    out = Path(argv[0])
    kind = argv[1] if len(argv) > 1 and not argv[1].startswith("--") else "lugre"
    repeat = int(argv[argv.index("--repeat") + 1]) if "--repeat" in argv else 1
    out.mkdir(parents=True, exist_ok=True)
    truth = PlantConfig()
    angles = train_angles(geometry(truth.actuator))
    moves = [
        scaled_move(angles[i % len(angles)], PUSH_MOVES[i % len(PUSH_MOVES)], truth.actuator)
        for i in range(61)
    ]
    if kind == "lugre":
        riglog.Plant = LuGrePlant  # type: ignore[misc]  # the rig loop steps this plant
        truth = truth.with_effect("actuator_friction", False)
    frames = riglog.rig_trials(truth, moves, seed=4, convention="from_row")
    end = riglog.rig_csv(frames).split("\r\n")
    span = int(float(end[-2].split(",")[0])) - 12_345 + 2_000  # one session's clock span, with its gap
    with (out / "rig.csv").open("w", newline="") as f:
        for k in range(repeat):
            lines = riglog.rig_csv(frames, start_ms=12_345 + k * span).split("\r\n")
            f.write("\r\n".join(lines[1:] if k else lines).rstrip("\r\n") + "\r\n")
    (out / "map.toml").write_text(riglog.RIG_MAP)
    save_config(truth, out / "base.toml")
    print(f"{out}/rig.csv: {sum(len(f) for f in frames) * repeat} rows")


if __name__ == "__main__":
    main(sys.argv[1:])
