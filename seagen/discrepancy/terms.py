"""The term library: plant-side forms the catalogue lacks, with their form class, fit box and formula."""

from __future__ import annotations

from dataclasses import dataclass

from seagen.plant.config import TERMS

# The form classes a discovery names ("discovered: <class>"): exactly these.
CLASSES = (
    "periodic",
    "drift",
    "state_friction",
    "hysteresis",
    "nonlinear_stiffness",
    "sensor_lag",
    "quantisation",
    "saturation",
)


@dataclass(frozen=True)
class Term:
    """One term: its plant effect (config.TERMS), form class, formula in the plant's signals, where it acts,
    and how it differs from the catalogue effect closest to it."""

    name: str
    form: str  # one of CLASSES
    formula: str
    acts_on: str
    unlike: str  # the catalogue effect it is closest to, and the difference


LIBRARY: dict[str, Term] = {
    t.name: t
    for t in (
        Term(
            "lead_error",
            "periodic",
            "nut = motor + a cos(2 pi x / P + phi), x the motor's travel at the nut",
            "the nut's position (screw lead error): compression, force, pot",
            "backlash (a dead band at reversals, not a ripple along the travel)",
        ),
        Term(
            "cogging",
            "periodic",
            "F_motor += A cos(2 pi x / P + phi), x the motor's travel at the nut",
            "the motor's load: its speed (encoder), then compression and force",
            "actuator_friction (a constant band, not a ripple along the travel)",
        ),
        Term(
            "spring_drift",
            "drift",
            "k(t) = k (1 + s (1 - exp(-t / tau))), t the time into the trial",
            "the spring's stiffness: force per compression",
            "series_compliance (a fixed stiffness, not one that changes in time)",
        ),
        Term(
            "cell_drift",
            "drift",
            "load_cell += A (1 - exp(-t / tau)), t the time into the trial",
            "the load cell's zero",
            "load_cell_offset (a constant zero, not one that settles in time)",
        ),
        Term(
            "rate_friction",
            "state_friction",
            "F_friction += dF exp(-w / v_c), dw/dt = (|v| - w) / tau (a lagged speed state)",
            "the shaft's friction band at low speed and after starts",
            "stribeck_friction (Gaussian in the present speed, no state)",
        ),
        Term(
            "bristle_friction",
            "state_friction",
            "F_friction += F_b (1 - exp(-s / x0)), s the shaft's travel since its last reversal",
            "the shaft's friction band after reversals",
            "actuator_friction (the full band at once, no presliding build-up)",
        ),
        Term(
            "spring_hysteresis",
            "hysteresis",
            "F += k_h (d - h), h = clip(h, d - w, d + w) (an elastoplastic element beside the spring)",
            "the spring force on loading versus unloading",
            "actuator_friction (a band on the shaft's motion, not on the spring's compression)",
        ),
        Term(
            "spring_poly",
            "nonlinear_stiffness",
            "F = k d + k2 d^2 + k3 d^3 (d >= 0, either sign)",
            "the spring force at large compression",
            "spring_nonlinearity (a hardening cube only)",
        ),
        Term(
            "cell_lag",
            "sensor_lag",
            "dF_cell/dt = (F - F_cell) / tau (a first-order lag)",
            "the load cell during force changes",
            "transport_delay (a pure delay: the same shape later, not smoothed)",
        ),
        Term(
            "cell_quantisation",
            "quantisation",
            "F_cell = q round(F_cell / q)",
            "the load cell's resolution",
            "none in the catalogue (the pot and encoder are read in their own counts)",
        ),
        Term(
            "pot_lag",
            "sensor_lag",
            "dpot/dt = (pot_angle - pot) / tau (a first-order lag of the pot's angle reading)",
            "the pot during moves",
            "pot_voltage_drop (a reading offset while current flows, not a lag of the angle)",
        ),
        Term(
            "pot_hysteresis",
            "hysteresis",
            "pot = h, h = clip(h, pot_in - w, pot_in + w) (a play in the pot's reading)",
            "the pot on reversals",
            "backlash (a play between motor and nut: it moves the force, not only the pot)",
        ),
        Term(
            "pot_quantisation",
            "quantisation",
            "pot = q round(pot / q) (a coarser converter)",
            "the pot's resolution",
            "pot_noise (a random error, not a staircase)",
        ),
        Term(
            "drive_saturation",
            "saturation",
            "V_motor = clip(V, -V_sat, V_sat)",
            "the motor's speed at large commands (encoder), then force",
            "viscous_friction or actuator_friction (a drag, not a limit on the drive)",
        ),
        Term(
            "cell_saturation",
            "saturation",
            "F_cell = clip(F_cell, -L, L)",
            "the load cell at large forces",
            "spring_nonlinearity or series_compliance (a smooth curve, not a hard limit)",
        ),
        Term(
            "pot_drift",
            "drift",
            "pot += A (1 - exp(-t / tau)) counts, t the time into the trial",
            "the pot's zero",
            "pot_voltage_drop (an offset while current flows, not one that settles in time)",
        ),
        Term(
            "pot_saturation",
            "saturation",
            "pot = min(pot, C) (its divider or converter clamps above C counts)",
            "the pot at large angles",
            "none in the catalogue (the pot reads its full range)",
        ),
        Term(
            "pot_reading_lag",
            "sensor_lag",
            "c += (pot - c) (1 - exp(-dt / tau)) per reading, pot its whole reading (angle and voltage drop)",
            "the pot during moves (an RC filter on its line, read at the log's rate)",
            "pot_voltage_drop (a reading offset while current flows, not a lag of the reading)",
        ),
        Term(
            "cell_soft_saturation",
            "saturation",
            "F_cell = F / (1 + |F / L|^n)^(1 / n) (n the knee's sharpness; n -> inf: the clip at +-L)",
            "the load cell at large forces",
            "spring_nonlinearity or series_compliance (a curve of the spring, not of the reading)",
        ),
        Term(
            "cell_hysteresis",
            "hysteresis",
            "F_cell += h z, dz = (dF / w) (1 - sign(dF) sign(z) |z|^n) per reading (Bouc-Wen type: n = 1 an "
            "exponential approach, large n a play of width 2 w), F the tip force",
            "the load cell on loading versus unloading",
            "load_cell_offset (a constant zero, not one that follows the force's history)",
        ),
        Term(
            "breakaway_friction",
            "state_friction",
            "F_friction += dF / (1 + (w / v_s)^delta), dw/dt = (|v| - w) / tau (a lagged speed state; delta "
            "the shape: 2 the Lorentzian)",
            "the shaft's friction band at low speed and after starts",
            "stribeck_friction (Gaussian in the present speed, no state)",
        ),
        Term(
            "spring_bouc_wen",
            "hysteresis",
            "F += h z while compressed, dz = (dd / w) (1 - sign(dd) sign(z) |z|^n) per step (Bouc-Wen type: "
            "n = 1 an exponential approach, large n a play of width 2 w), d the compression",
            "the spring force on loading versus unloading",
            "actuator_friction (a band on the shaft's motion, not on the spring's compression)",
        ),
        Term(
            "load_friction",
            "state_friction",
            "F_friction += mu |F|, F the force the structure carried at the last step (Coulomb's mu N)",
            "the shaft's friction band under load",
            "actuator_friction (a constant band, not one that grows with the load)",
        ),
        Term(
            "position_friction",
            "state_friction",
            "F_friction += A exp(-|(y - c) / w|^n), y the shaft's advance (n = 2 a bump, large n a flat "
            "rough stretch)",
            "the shaft's friction band along its travel",
            "linkage_friction (a smooth quadratic in the linkage angle, not a local stretch)",
        ),
        Term(
            "spring_knee",
            "nonlinear_stiffness",
            "F = k d + dk max(d - d0, 0) (a stiffness step at compression d0)",
            "the spring force beyond a compression",
            "spring_nonlinearity (a smooth hardening cube, not a step in stiffness)",
        ),
        Term(
            "drive_gain_drift",
            "drift",
            "V_motor = V (1 + s (1 - exp(-t / tau))), t the time into the trial",
            "the motor's speed per volt over a trial (encoder), then force",
            "viscous_friction (a drag at speed, not a gain that changes in time)",
        ),
        Term(
            "current_limit",
            "saturation",
            "V_motor = clip(V, V_s (v / v_max - i), V_s (v / v_max + i)) (the current within i of stall)",
            "the motor's force and its acceleration at large commands",
            "drive_saturation (a limit on the volts, not on the current)",
        ),
        Term(
            "cell_gain_drift",
            "drift",
            "F_cell = F (1 + s (1 - exp(-t / tau))), t the time into the trial",
            "the load cell's sensitivity",
            "load_cell_offset (a constant zero, not a gain that settles in time)",
        ),
        Term(
            "pot_ripple",
            "periodic",
            "pot += A cos(2 pi c / P + phi), c the pot's angle reading (counts)",
            "the pot along its travel (a gear pair driving it, a wavy track)",
            "pot_noise (a random error, not a ripple periodic in the angle)",
        ),
    )
}
assert set(LIBRARY) == set(TERMS) and all(t.form in CLASSES for t in LIBRARY.values())

# Fit box per term parameter: (low, high, log-scaled), as candidates.SPACE. A phase box spans two turns so
# that no phase is at its edge; it is reported modulo 2 pi.
TERM_SPACE: dict[str, dict[str, tuple[float, float, bool]]] = {
    "lead_error": {
        "amplitude_mm": (0.002, 0.3, True),
        "period_mm": (0.2, 10.0, True),
        "phase_rad": (-6.5, 6.5, False),
    },
    "cogging": {
        "force_n": (0.05, 5.0, True),
        "period_mm": (0.1, 10.0, True),
        "phase_rad": (-6.5, 6.5, False),
    },
    "spring_drift": {"share": (-0.5, 0.5, False), "time_constant_s": (0.1, 30.0, True)},
    "cell_drift": {"offset_n": (-4.0, 4.0, False), "time_constant_s": (0.1, 30.0, True)},
    "rate_friction": {
        "extra_n": (0.1, 5.0, True),
        "v_c_mm_s": (0.05, 5.0, True),
        "time_constant_s": (0.001, 0.5, True),
    },
    "bristle_friction": {"force_n": (0.1, 6.0, True), "x0_mm": (0.002, 1.0, True)},
    "spring_hysteresis": {"k_n_per_mm": (0.05, 10.0, True), "half_width_mm": (0.005, 1.0, True)},
    "spring_poly": {"k2_n_per_mm2": (-0.6, 0.6, False), "k3_n_per_mm3": (-0.15, 0.15, False)},
    "cell_lag": {"time_constant_s": (0.001, 0.3, True)},
    "cell_quantisation": {"step_n": (0.01, 2.0, True)},
    "cell_saturation": {"limit_n": (1.0, 60.0, True)},
    "pot_lag": {"time_constant_s": (0.001, 0.3, True)},
    "pot_hysteresis": {"half_width_counts": (0.5, 60.0, True)},
    "pot_quantisation": {"step_counts": (1.5, 128.0, True)},
    "drive_saturation": {"limit_v": (0.5, 12.0, True)},
    "pot_drift": {"offset_counts": (-80.0, 80.0, False), "time_constant_s": (0.1, 30.0, True)},
    "pot_saturation": {"limit_counts": (100.0, 5000.0, True)},
    "pot_reading_lag": {"time_constant_s": (0.001, 0.3, True)},
    "cell_soft_saturation": {"limit_n": (1.0, 60.0, True), "sharpness": (1.0, 40.0, True)},
    "cell_hysteresis": {
        "force_n": (0.02, 5.0, True),
        "width_n": (0.05, 20.0, True),
        "shape": (0.5, 30.0, True),
    },
    "breakaway_friction": {
        "extra_n": (0.1, 5.0, True),
        "v_s_mm_s": (0.05, 5.0, True),
        "time_constant_s": (0.001, 0.5, True),
        "shape": (0.5, 8.0, True),
    },
    "spring_bouc_wen": {
        "force_n": (0.05, 10.0, True),
        "width_mm": (0.005, 1.0, True),
        "shape": (0.5, 30.0, True),
    },
    "load_friction": {"mu": (0.002, 0.5, True)},
    "position_friction": {
        "extra_n": (0.1, 5.0, True),
        "center_mm": (-1.0, 20.0, False),
        "width_mm": (0.05, 5.0, True),
        "shape": (1.0, 8.0, True),
    },
    "spring_knee": {"dk_n_per_mm": (-3.0, 8.0, False), "onset_mm": (0.05, 10.0, True)},
    "drive_gain_drift": {"share": (-0.5, 0.5, False), "time_constant_s": (0.1, 30.0, True)},
    "current_limit": {"limit_share": (0.02, 1.0, True)},
    "cell_gain_drift": {"share": (-0.3, 0.3, False), "time_constant_s": (0.1, 30.0, True)},
    "pot_ripple": {
        "amplitude_counts": (0.5, 100.0, True),
        "period_counts": (40.0, 1500.0, True),
        "phase_rad": (-6.5, 6.5, False),
    },
}
# Start grids: this many points along a parameter whose objective has many valleys (a period, a phase).
DENSE = {
    ("lead_error", "period_mm"): 24,
    ("cogging", "period_mm"): 24,
    ("lead_error", "phase_rad"): 4,
    ("cogging", "phase_rad"): 4,
    ("pot_ripple", "period_counts"): 96,
    ("pot_ripple", "phase_rad"): 4,
    ("position_friction", "center_mm"): 8,
    ("spring_knee", "onset_mm"): 6,
}
STARTS = 3  # start points along every other parameter (its box's 1/6, 1/2 and 5/6)


def form_of(name: str) -> str:
    """The form class of a term."""
    return LIBRARY[name].form
