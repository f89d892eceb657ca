"""Effect forms written apart from the discrepancy naming rule, each with its expected catalogue name(s).

Written by a separate author who had not read the naming/claim rule (seagen/discrepancy/candidates.py,
workflow.py's naming, signature.py's scoring): only the Plant interface (seagen/plant/) and the family
module's conventions were read. Each form is a law a real SEA could show, physically different from the
catalogue's own law and from the benchmark families (seagen/discrepancy/families.py). The expected names
were fixed, with the reason, before any run.

Conventions (as in families.py): a form that stands in for an effect the default plant enables switches that
effect off in both the truth and the base (`replaces`), so the workflow has to find something; every other
effect of the default plant stays as it is. Parameters are drawn per seed from the stated ranges (plausible
magnitudes for the paper's actuator: visible above the sensor noise, not absurd).

Outcomes (fixed before any run):
- `first_ok`: the workflow's first name is in `expected` (forms with expected names only).
- a *wrong sure claim*: any name the workflow claims (added or recalibrated, `claimed` true) at confidence
  >= 0.9 that is not in `expected`; for a form expected "none", every claim at >= 0.9 is wrong (the right
  answer there is "unexplained / closest, not claimed").
The issue's goal: first_ok in >= 90 % of the named cases, a wrong sure claim in <= 5 % of all cases.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from seagen.plant import Plant, PlantConfig, pick


class LoadFriction(Plant):
    """Guide friction from the side load the linkage puts on the shaft: F0 + mu |F_spring|, lower in
    reverse (a plain bushing whose normal force grows with the force carried)."""

    f0, mu, back = 1.0, 0.12, 0.7

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's other friction plus the load-proportional band."""
        fwd, rev = super().friction_limits(angle_deg)
        load = np.abs(self.spring_force(self.nut_mm - self.shaft_mm))
        band = self.f0 + self.mu * load
        return fwd + band, rev + self.back * band


class TightSpot(Plant):
    """A tight spot in the guide bore: extra friction A exp(-((y - y_t)/w)^2) around shaft advance y_t
    (a burr or a bore misaligned over a short length), the same both ways."""

    amp, y_t, w = 2.0, 1.2, 0.6

    def friction_limits(self, angle_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The plant's other friction plus the bump where the shaft is now."""
        fwd, rev = super().friction_limits(angle_deg)
        bump = self.amp * np.exp(-(((self.shaft_mm - self.y_t) / self.w) ** 2))
        return fwd + bump, rev + bump


class SealDrag(Plant):
    """Drag of a lip seal / grease film growing with the square of the speed: F = c |v| v on the shaft
    (solved implicitly like the catalogue's viscous term, with |v| from the previous step)."""

    c = 0.008  # N s^2 / mm^2

    def viscous_n_s_per_mm(self) -> float | np.ndarray:
        """The plant's viscous coefficient plus the speed-squared drag as a lagged viscous coefficient."""
        return super().viscous_n_s_per_mm() + self.c * np.abs(self.v_shaft)


class LoadedBacklash(Plant):
    """Clearance of width 2b in the nut, the nut pushed to a flank by the spring: it floats where the
    spring is unloaded when it can, nut = clip(shaft, motor - b, motor + b). The dead band appears where the
    spring force changes sign (start of a push, end of a retract), not at reversals of the motor."""

    half = 0.08  # mm

    def _move_nut(self) -> None:
        """Nut at the spring's zero if inside the clearance, else on the flank."""
        self.nut_mm = np.clip(self.shaft_mm, self.motor_mm - self.half, self.motor_mm + self.half)


class DualRateSpring(Plant):
    """Spring whose first coils close progressively: rate k below d1, rising smoothly to k2 above it
    (k d + (k2 - k) s softplus((d - d1)/s)), a dual-rate spring."""

    k2_over_k, d1, soft = 1.4, 2.0, 0.3  # k2 / k, mm, mm

    def _extra(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The coil-closing force and its slope at compression d."""
        dk = (self.k2_over_k - 1.0) * self.geo.spring_n_per_mm
        u = (np.maximum(d, 0.0) - self.d1) / self.soft
        return dk * self.soft * np.logaddexp(0.0, u), dk / (1.0 + np.exp(-u)) * (d >= 0)

    def spring_force(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The plant's spring plus the coil-closing force (zero at d = 0 up to softplus(-d1/s))."""
        f0 = self._extra(np.zeros(1))[0]
        return super().spring_force(d, idx) + (self._extra(d)[0] - f0) * (d >= 0)

    def _spring_slope(self, d: np.ndarray, idx: np.ndarray | None = None) -> np.ndarray:
        """The slope of spring_force."""
        return super()._spring_slope(d, idx) + self._extra(d)[1]


class SeatingMount(Plant):
    """A 3D-printed housing that seats under load: deflection d = F/k + g (1 - exp(-F/Fg)) in series with
    the spring (a take-up of g mm in the first few newtons, then linear)."""

    k, gap, fg = 30.0, 0.25, 2.0  # N/mm, mm, N

    def structure_force(self, y: np.ndarray, idx: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Invert d(F) by Newton (monotone from the left after the first step); slope 1 / d'(F)."""
        yc = pick(self.y_contact, idx)
        d = np.maximum(y - yc, 0.0)
        f = self.k * d  # an upper bound of the root
        for _ in range(40):
            e = np.exp(-f / self.fg)
            h = f / self.k + self.gap * (1 - e) - d
            f_new = np.maximum(f - h / (1 / self.k + self.gap / self.fg * e), 0.0)
            done = np.all(np.abs(f_new - f) <= 1e-12)
            f = f_new
            if done:
                break
        slope = 1.0 / (1 / self.k + self.gap / self.fg * np.exp(-f / self.fg))
        return f, np.where(y > yc, slope, 0.0)


class CellCreep(Plant):
    """Strain-gauge creep: the reading adds z, which follows c x (tip force) with time constant tau under
    load and relaxes back after it (the cell reads high after a sustained load)."""

    c, tau = 0.03, 0.6

    def read(self):
        """The reading plus the creep (updated per sample)."""
        s = super().read()
        a = 1 - np.exp(-0.01 / self.tau)
        z = getattr(self, "_z", np.zeros_like(s.load_cell_n))
        self._z = z + a * (self.c * self.shaft_force * self.ratio - z)
        s.load_cell_n = s.load_cell_n + self._z
        s.force_n = s.load_cell_n / self.ratio
        return s


class HeldAdc(Plant):
    """A sigma-delta load-cell ADC converting at its own rate (period P, 40-80 Hz): each conversion
    averages the force over its window and is held until the next one; the loop reads the held value."""

    period = 0.0125  # s

    def step(self, motor_v: Any) -> None:
        """Step, then integrate the tip force and complete a conversion at each window boundary."""
        super().step(motor_v)
        tip = self.shaft_force * self.ratio
        acc = getattr(self, "_acc", np.zeros_like(tip)) + tip
        n = getattr(self, "_n", 0) + 1
        held = getattr(self, "_held", np.zeros_like(tip))
        edge = getattr(self, "_edge", self.period)
        if self.t >= edge - 1e-12:
            held, acc, n, edge = acc / n, np.zeros_like(tip), 0, edge + self.period
        self._acc, self._n, self._held, self._edge = acc, n, held, edge

    def read(self):
        """The held conversion plus this sample's noise (and whatever else the plant adds)."""
        s = super().read()
        held = getattr(self, "_held", np.zeros_like(s.load_cell_n))
        s.load_cell_n = s.load_cell_n - self.shaft_force * self.ratio + held
        s.force_n = s.load_cell_n / self.ratio
        return s


class DutySagPot(Plant):
    """The pot's reference shares the motor rail, which sags with the PWM duty |V|/V_supply (not with the
    current): the pot reads high by gain x duty, through a lag tau."""

    gain, tau = 100.0, 0.04  # counts per unit duty, s

    def step(self, motor_v: Any) -> None:
        """Step, then move the sag toward gain x duty."""
        super().step(motor_v)
        m = self.cfg.motor
        volts = np.abs(np.broadcast_to(np.asarray(motor_v, float), self.nut_mm.shape))
        duty = np.minimum(volts, m.supply_v) / m.supply_v
        sag = getattr(self, "_sag", np.zeros_like(duty))
        self._sag = sag + (self.gain * duty - sag) * min(self.cfg.dt_s / self.tau, 1.0)

    def read(self):
        """The reading plus the sag."""
        s = super().read()
        sag = getattr(self, "_sag", np.zeros(s.pot.shape))
        s.pot = np.clip(np.rint(s.pot + sag), 0, self.geo.adc_max).astype(np.int64)
        return s


class PwmDeadZone(Plant):
    """An H-bridge driver with a dead zone: |V| below V_dz does nothing, above it the motor sees
    |V| - V_dz (dead time plus the motor's own starting voltage)."""

    v_dz = 0.5  # V

    def step(self, motor_v: Any) -> None:
        """Step with the dead-zoned command."""
        v = np.asarray(motor_v, float)
        super().step(np.sign(v) * np.maximum(np.abs(v) - self.v_dz, 0.0))


@dataclass(frozen=True)
class Form:
    """A form: truth plant class, the default effect it replaces, parameter ranges, expected names, why."""

    cls: type[Plant]
    replaces: str | None
    ranges: dict[str, tuple[float, float]]
    expected: frozenset[str]  # empty: no catalogue effect is close
    why: str


FORMS: dict[str, Form] = {
    "load_friction": Form(
        LoadFriction,
        "actuator_friction",
        {"f0": (0.6, 1.4), "mu": (0.08, 0.16)},
        frozenset({"actuator_friction"}),
        "a Coulomb band on the shaft, lower in reverse; only its level grows with load",
    ),
    "tight_spot": Form(
        TightSpot,
        "linkage_friction",
        {"amp": (1.5, 2.5), "y_t": (0.8, 1.6), "w": (0.4, 0.8)},
        frozenset({"linkage_friction"}),
        "Coulomb friction on the shaft that depends on where the shaft is (hence on the contact angle)",
    ),
    "seal_drag": Form(
        SealDrag,
        None,
        {"c": (0.004, 0.010)},
        frozenset({"viscous_friction"}),
        "a speed-dependent drag on the shaft, zero at rest",
    ),
    "loaded_backlash": Form(
        LoadedBacklash,
        None,
        {"half": (0.05, 0.12)},
        frozenset({"backlash"}),
        "a clearance between motor (encoder) and nut",
    ),
    "dual_rate_spring": Form(
        DualRateSpring,
        None,
        {"k2_over_k": (1.3, 1.6), "d1": (1.5, 2.5)},
        frozenset({"spring_nonlinearity"}),
        "a progressive spring (stiffening with compression; the catalogue's compliance only softens)",
    ),
    "seating_mount": Form(
        SeatingMount,
        "series_compliance",
        {"k": (25.0, 40.0), "gap": (0.15, 0.35), "fg": (1.0, 3.0)},
        frozenset({"series_compliance"}),
        "a deflection of the structure in series with the spring, nonlinear in force",
    ),
    "cell_creep": Form(
        CellCreep,
        None,
        {"c": (0.02, 0.05), "tau": (0.3, 1.0)},
        frozenset({"load_cell_offset"}),
        "an additive load-cell error of one sign that stays after unloading (no physics gives force at rest)",
    ),
    "held_adc": Form(
        HeldAdc,
        None,
        {"period": (0.0125, 0.025)},
        frozenset({"transport_delay"}),
        "the load cell reads the force late (by about one conversion period)",
    ),
    "duty_sag_pot": Form(
        DutySagPot,
        "pot_voltage_drop",
        {"gain": (60.0, 160.0), "tau": (0.02, 0.08)},
        frozenset({"pot_voltage_drop"}),
        "the pot reads high while the motor is driven, and recovers with a lag",
    ),
    "pwm_dead_zone": Form(
        PwmDeadZone,
        None,
        {"v_dz": (0.3, 0.7)},
        frozenset(),
        "none: no catalogue effect acts on the motor's voltage-to-speed law",
    ),
}


def form_case(name: str, seed: int) -> tuple[type[Plant], PlantConfig, dict[str, float]]:
    """(plant class with drawn parameters, truth = base config, drawn parameters) of one case of `name`."""
    rng = np.random.default_rng(seed)
    form = FORMS[name]
    params = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in form.ranges.items()}
    cls = type(f"{form.cls.__name__}_{seed}", (form.cls,), params)
    cfg = PlantConfig() if form.replaces is None else PlantConfig().with_effect(form.replaces, False)
    return cls, cfg, params


SURE = 0.9  # confidence at which a claim counts as sure (the threshold)


def run_form(name: str, seed: int, fast: bool = False) -> dict:
    """One case: the form's data as the measured runs, the workflow from its base, the outcomes above."""
    from seagen.discrepancy.bench import measure
    from seagen.discrepancy.report import gap_cut
    from seagen.discrepancy.workflow import identify

    t0 = time.perf_counter()
    cls, cfg, params = form_case(name, seed)
    expected = FORMS[name].expected
    runs = measure(cfg, seed=seed, fast=fast, plant_cls=cls)
    res = identify(runs, cfg)
    changed = [(n, "added") for n in res.effects] + [(n, "recalibrated") for n in res.recalibrated]
    sure = [(n.name, how) for n, how in changed if n.claimed and n.confidence >= SURE]
    wrong = [f"{nm} ({how})" for nm, how in sure if nm not in expected]
    return {
        "form": name,
        "seed": seed,
        "params": params,
        "expected": "+".join(sorted(expected)) or "none",
        "first": res.first or "-",
        "first_ok": (res.first in expected) if expected else None,
        "closest": res.ranking[0][0] if res.ranking else "-",
        "changed": [
            {"name": n.name, "how": how, "confidence": float(n.confidence), "claimed": bool(n.claimed)}
            for n, how in changed
        ],
        "wrong_sure": wrong,
        "wrong_sure_added": [w for w in wrong if w.endswith("(added)")],
        "verdict": res.verdict,
        "rms_before": float(res.rms_before),
        "rms_after": float(res.rms_after),
        "noise_floor": float(res.noise_floor),
        "gap_cut_physics": gap_cut(res.rms_before, res.rms_after, res.noise_floor),
        "learned": res.learned is not None,
        "seconds": time.perf_counter() - t0,
    }


def rates(rows: list[dict]) -> dict:
    """The issue's two rates: closest named first (named forms) and wrong sure claims (all cases)."""
    named = [r for r in rows if r["first_ok"] is not None]
    return {
        "cases": len(rows),
        "named_cases": len(named),
        "closest_first_rate": sum(r["first_ok"] for r in named) / max(len(named), 1),
        "wrong_sure_rate": sum(bool(r["wrong_sure"]) for r in rows) / max(len(rows), 1),
        "wrong_sure_added_rate": sum(bool(r["wrong_sure_added"]) for r in rows) / max(len(rows), 1),
    }


def _claims(r: dict) -> str:
    """The changes of a row in words: name (added/recal.) confidence, '*' when claimed."""
    return (
        ", ".join(
            f"{c['name']} ({'add' if c['how'] == 'added' else 'recal'}) "
            f"{c['confidence']:.2f}{'*' if c['claimed'] else ''}"
            for c in r["changed"]
        )
        or "-"
    )


def table(rows: list[dict]) -> str:
    """A markdown table of the rows, then the two rates."""
    out = [
        "| form | seed | expected | named first | ok | changes (confidence, * claimed) | wrong sure claim "
        "| verdict | RMS before → after (floor) | s |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        ok = "–" if r["first_ok"] is None else ("yes" if r["first_ok"] else "**no**")
        out.append(
            f"| {r['form']} | {r['seed']} | {r['expected']} | {r['first']} | {ok} | {_claims(r)} "
            f"| {', '.join(r['wrong_sure']) or '-'} | {r['verdict']} "
            f"| {r['rms_before']:.2f} → {r['rms_after']:.2f} ({r['noise_floor']:.2f}) | {r['seconds']:.0f} |"
        )
    k = rates(rows)
    out.append("")
    out.append(
        f"Closest named first: {k['closest_first_rate']:.0%} of {k['named_cases']} named cases; a wrong name "
        f"claimed at >= {SURE}: {k['wrong_sure_rate']:.0%} of {k['cases']} cases "
        f"({k['wrong_sure_added_rate']:.0%} counting added effects only)."
    )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    """Run the forms one case at a time (one process), print each row as it ends, then the table."""
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, default=1, help="seeds per form (0, 1, ...)")
    p.add_argument("--forms", default=",".join(FORMS), help="comma-separated form names")
    p.add_argument("--quick", action="store_true", help="the benchmark's quick moves")
    p.add_argument("--json", help="also write the rows to this JSON file (appends to an existing one)")
    a = p.parse_args(argv)
    rows = json.loads(Path(a.json).read_text()) if a.json and Path(a.json).exists() else []
    for seed in range(a.seeds):
        for name in a.forms.split(","):
            if any(r["form"] == name and r["seed"] == seed for r in rows):
                continue
            rows.append(run_form(name, seed, a.quick))
            print(json.dumps(rows[-1]), flush=True)
            if a.json:
                tmp = Path(a.json + ".tmp")
                tmp.write_text(json.dumps(rows, indent=1))
                tmp.replace(a.json)
    print(table(rows))
    return 0


class Harness:
    """This harness (form_case, run_form, main) run on another set's forms (sets B, C, D): FORMS is theirs
    while inside, set A's again afterwards (the functions above read FORMS at call time)."""

    def __init__(self, forms: dict[str, Form]) -> None:
        """The harness for `forms`."""
        self.forms = forms

    @contextmanager
    def _active(self) -> Iterator[None]:
        """This set's forms as FORMS while inside."""
        global FORMS
        saved, FORMS = FORMS, self.forms
        try:
            yield
        finally:
            FORMS = saved

    def form_case(self, name: str, seed: int) -> tuple[type[Plant], PlantConfig, dict[str, float]]:
        """form_case for a form of this set."""
        with self._active():
            return form_case(name, seed)

    def run_form(self, name: str, seed: int, fast: bool = False) -> dict:
        """run_form for a form of this set."""
        with self._active():
            return run_form(name, seed, fast)

    def main(self, argv: list[str] | None = None) -> int:
        """main on this set's forms."""
        with self._active():
            return main(argv)


if __name__ == "__main__":
    raise SystemExit(main())
