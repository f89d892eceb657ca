"""`seagen simulate`: the paper's force-control experiment in closed loop, per configuration."""

from __future__ import annotations

import argparse
import json
import sys
from functools import partial
from typing import TYPE_CHECKING

from seagen.defaults import model_arg
from seagen.errors import UserError

if TYPE_CHECKING:
    from seagen.actuator import Actuator


def register(sub: argparse._SubParsersAction) -> None:
    """Add the `simulate` and `tune` commands."""
    from seagen.cli.linkopts import add_link_options
    from seagen.setups.shipped import CONFIGS

    _register_tune(sub)

    p = sub.add_parser(
        "simulate",
        help="closed-loop force control on the simulated SEA (paper Table II)",
        description="The paper's force-control experiment on the simulated SEA: start at rest "
        "(linkage.home_deg), close on the load cell at ten contact angles over the linkage's range, "
        "targets 1/4, 1/2 and 3/4 of control.force_max_n (5/10/15 N on the paper's actuator), 6 s runs, "
        "one controller tick per control.loop_hz (100 Hz on the paper's); prints the average error and "
        "settling time per configuration and target. Configurations: sf_mcu (the shipped SF in C), "
        "mlp_cloud (the shipped float MLP on a PC behind a Bluetooth LE link in 10 Hz rounds, the MCU "
        "holding the paper's 0.1 mm margin; --latency and --link-* set the link) and mlp_mcu (the shipped "
        "MLP in C) run the shipped models, trained for the paper's actuator; kin_mcu (the kinematics "
        "baseline) needs no model and runs on any actuator. Default: sf_mcu, mlp_cloud, mlp_mcu on the "
        "paper's actuator; with another --actuator, kin_mcu only (the others are refused there: they need "
        "--model). With --model, the same experiment on your own control model: NAME_mcu (exported to C, "
        "at the loop rate) and NAME_cloud (its float model behind the 10 Hz link); --calibration adds "
        "your calibration model's force estimate from the recorded sensors and its error. Every model "
        "must be trained for the simulated actuator.",
    )
    p.add_argument(
        "--model",
        metavar="CONTROL_MODEL",
        type=model_arg,
        help="your control model (seagen train --task control, or a supported network with --features), "
        "or default:NAME; runs NAME_mcu and NAME_cloud instead of the default configurations",
    )
    p.add_argument(
        "--calibration",
        metavar="CAL_MODEL",
        type=model_arg,
        help="your calibration model: estimates the force of every run from its sensors (est. err column); "
        "one trained for another actuator than the simulated one is refused",
    )
    p.add_argument("--features", metavar="SPEC", help="feature specification of --model (bare networks)")
    p.add_argument(
        "--actuator",
        metavar="FILE",
        help="actuator description TOML of the simulated SEA (default: the one --model records, else the "
        "paper's); one that disagrees with the model's is refused",
    )
    p.add_argument(
        "--allow-pickle",
        action="store_true",
        help="unpickle model files holding arbitrary Python objects (RUNS CODE: trusted files only)",
    )
    p.add_argument("--json", action="store_true", help="print one JSON object keyed by configuration")
    p.add_argument("--plots", metavar="DIR", help="write a step-response plot per configuration (first seed)")
    p.add_argument(
        "--config", action="append", choices=sorted(CONFIGS), help="configurations (default: see above)"
    )
    add_link_options(p)
    p.add_argument(
        "--impl",
        choices=("c", "py", "pil"),
        default="c",
        help="controller: C via cffi, the Python twin, or the firmware on an emulated board (QEMU; --core)",
    )
    p.add_argument(
        "--core",
        choices=("cortex-m4", "cortex-m0plus"),
        default="cortex-m4",
        help="with --impl pil: the board's core (mps2-an386 or microbit; default cortex-m4)",
    )
    p.add_argument("--seed", type=int, default=0, help="plant noise seed (default 0)")
    p.add_argument(
        "--seeds",
        type=int,
        default=1,
        metavar="N",
        help="repeat over N noise seeds (seed..seed+N-1) and report the mean and range (default 1)",
    )
    p.set_defaults(func=cmd_simulate)


def cmd_simulate(args: argparse.Namespace) -> int:
    """Run each configuration at its actuator's targets over the contact angles; print Table II or JSON."""
    from seagen.actuator import ActuatorError, is_default
    from seagen.cli.linkopts import link_from
    from seagen.control.experiment import TABLE2_CONFIGS, format_table2, model_free_setups, simulate, sweep
    from seagen.control.link import with_link
    from seagen.data.protocol import sample_every
    from seagen.plant import PlantConfig
    from seagen.setups.pil import loop_controller
    from seagen.setups.shipped import CONFIGS, MODEL_FREE

    link = link_from(args)  # NaN fails too
    if args.seed < 0:
        raise UserError(f"--seed must be >= 0, got {args.seed}")
    if args.seeds < 1:
        raise UserError(f"--seeds must be >= 1, got {args.seeds}")
    act = plant_actuator(args)  # refused before anything is built
    plant_cfg = PlantConfig(actuator=act)
    sample_every(plant_cfg)  # a loop rate the plant cannot run is refused, naming the description's file
    paper = is_default(act)
    setups, rows, estimator = dict(CONFIGS), {}, None
    free_only = not (args.config or args.model or paper)  # another design, nothing chosen: kin_mcu
    names = tuple(args.config or (() if args.model else TABLE2_CONFIGS if paper else MODEL_FREE))
    setups |= model_free_setups(act)  # kin_mcu with this actuator's constants (the paper's: CONFIGS' own)
    if not paper:
        refuse_shipped(names, act, args.model)
    if args.calibration:  # first: one for another actuator is refused before the control model's export
        from seagen.setups.user import force_estimator

        try:
            estimator = force_estimator(args.calibration, args.allow_pickle, act)
        except ActuatorError as e:  # say where the simulated ("given") actuator came from
            origin = (
                f"the one --model {args.model} was trained for"
                if args.model
                else f"--actuator {args.actuator}"
                if args.actuator
                else "the paper's (no --model or --actuator)"
            )
            raise ActuatorError(f"--calibration {e}; the simulated actuator is {origin}") from None
    if args.model:
        from seagen.setups.targets import check_targets
        from seagen.setups.user import control_setups

        check_targets(args.model, act, args.features, args.allow_pickle)  # no silent clamp at a target
        mine, row = control_setups(args.model, args.features, args.allow_pickle, act)
        setups |= mine
        rows = dict.fromkeys(mine, row)
        names = (*names, *mine)
    setups = {n: with_link(f, link) for n, f in setups.items()}  # the cloud rows' link: the options'
    if free_only:  # said once everything is accepted
        print(model_free_note(act), file=sys.stderr)
    impl = partial(loop_controller, args.core) if args.impl == "pil" else args.impl  # pil: a board's
    if args.seeds == 1:
        table = simulate(setups, names, impl, args.seed, args.plots, estimator, plant_cfg)
    else:
        from tqdm import tqdm

        with tqdm(total=args.seeds, desc="seeds", unit="seed", disable=args.json) as bar:
            table = sweep(
                setups,
                names,
                args.seeds,
                impl,
                args.seed,
                lambda _k: bar.update(),
                args.plots,
                estimator,
                plant_cfg,
            )
    print(json.dumps(table, indent=2) if args.json else format_table2(table, rows, paper_figures=paper))
    sf = {n for n in names if n.startswith("sf_")} | (set(mine) if args.model and row == "SF" else set())
    for note in limit_notes(table, act) + offset_notes(table, act, sf):
        print(note, file=sys.stderr)
    return 0


def offset_notes(table: dict[str, dict[str, dict]], act: Actuator, sf: set[str]) -> list[str]:
    """One line per configuration whose unsettled runs reach a steady level off the target band, not held at
    the command limit: the predictor is off there, not the loop; for a surface fit (`sf`: the configuration
    names running one), why a static map of force and angle misses on this design's friction loop."""
    from seagen.control.experiment import BAND_N

    k, fric = act.stiffness_n_per_mm, act.friction_n
    out = []
    for name, rows in table.items():
        off = [
            (t, r["error_avg_n"])
            for t, r in rows.items()
            if r["settled"] < r["angles"]
            and r["settling_final_s"] is not None
            and r["error_avg_n"] > BAND_N
            and r["at_limit"] < LIMIT_NOTE_SHARE
        ]
        if not off:
            continue
        where = ", ".join(f"{t} N ({e:.2g} N off)" for t, e in off)
        line = (
            f"seagen simulate: note: {name}'s runs reach a steady force outside the +-{BAND_N:g} N band at "
            f"{where}: its predicted compression is off there, not the loop (the band is {BAND_N / k:.2g} mm "
            f"of compression on the {k:g} N/mm spring)"
        )
        if name in sf:
            line += (
                f"; a surface fit is a static map of force and angle, and this design's friction loop spans "
                f"{2 * fric / k:.2g} mm of compression (2 x transmission.friction_n {fric:g} N / spring): "
                "fitted by least squares (`--loss mse`, train's default) it sits between the loading and "
                "unloading branches; `--loss mae` (the paper's SF loss, the shipped SF's) follows the "
                "loading branch, where the loop ends, and a model whose inputs carry the motion (`seagen "
                "train --model mlp --task control`) can follow both"
            )
        out.append(line)
    return out


LIMIT_NOTE_SHARE = 0.5  # runs that never settle and sit at the command limit this share of the time


def limit_notes(table: dict[str, dict[str, dict]], act: Actuator) -> list[str]:
    """One line per configuration whose unsettled runs sit at the command limit most of the time after
    contact: the limit, where it comes from, and what to change."""
    from seagen.actuator import default_actuator

    lim = min(act.control.limit_v, act.motor.supply_v)
    left_out = act.control.limit_v == default_actuator().control.limit_v
    out = []
    for name, rows in table.items():
        hit = [(t, r["at_limit"]) for t, r in rows.items() if r["settled"] < r["angles"]]
        hit = [(t, share) for t, share in hit if share >= LIMIT_NOTE_SHARE]
        if hit:
            where = ", ".join(f"{t} N ({share:.0%})" for t, share in hit)
            why = ", the paper's value, taken when left out" if left_out else ""
            advice = (
                "a higher control.limit_v may let them settle (`seagen tune` searches it with the gains)"
                if lim < act.motor.supply_v
                else "the limit is already the whole supply: the motor cannot push harder (a stronger or "
                "faster drive, or a lower control.force_max_n)"
            )
            out.append(
                f"seagen simulate: note: {name}'s runs that never settle sit at the command limit "
                f"+-{lim:g} V ({act.source}: control.limit_v{why}; supply {act.motor.supply_v:g} V) for "
                f"this share of the time after contact: {where}; {advice}"
            )
    return out


def model_free_note(act: Actuator) -> str:
    """What the default configurations are on a design other than the paper's, and how to run the others."""
    from seagen.setups.shipped import MODEL_FREE, NEEDS_SHIPPED

    return (
        f"seagen simulate: {act.source}: running {', '.join(MODEL_FREE)} (needs no model); "
        f"{', '.join(NEEDS_SHIPPED)} run the shipped models of the paper's actuator: for this design pass "
        "--model (a control model trained on its data)"
    )


def refuse_shipped(names: tuple[str, ...], act: Actuator, model: str | None) -> None:
    """A configuration running a shipped (paper) model on another design: refused naming it (exit 2)."""
    from seagen.actuator import ActuatorError, default_actuator
    from seagen.setups.shipped import MODEL_FREE, NEEDS_SHIPPED
    from seagen.setups.user import prefix_of

    free, paper = " / ".join(MODEL_FREE), default_actuator()
    for n in names:
        if n in NEEDS_SHIPPED:
            hint = (
                f"--model {model} runs as {prefix_of(model)}_mcu and {prefix_of(model)}_cloud: leave out "
                f"--config {n} (--config {free} needs no model)"
                if model
                else f"for this design pass --model with a control model trained on its data, or --config "
                f"{free} (needs no model)"
            )
            raise ActuatorError(
                f"--config {n}: runs the shipped model default:{NEEDS_SHIPPED[n]}, trained for actuator "
                f"'{paper.name}' (sha256 {paper.digest()[:12]}), not the simulated '{act.name}' (sha256 "
                f"{act.digest()[:12]}, from {act.source}); {hint}"
            )


def plant_actuator(args: argparse.Namespace) -> Actuator:
    """The simulated actuator: the one --model was trained for (a bare network: --actuator, else the
    paper's), else --actuator's, else the paper's; an --actuator disagreeing with --model's is refused."""
    from seagen.actuator import default_actuator
    from seagen.cli.data import given_actuator
    from seagen.modelfile import load_model, model_actuator

    given = given_actuator(args)
    if args.model:
        try:
            model = load_model(args.model, args.allow_pickle)
        except UserError:  # a bare network: it records no actuator
            return given or default_actuator()
        return model_actuator(model, args.model, given)
    return given or default_actuator()


def _register_tune(sub: argparse._SubParsersAction) -> None:
    """Add the `tune` command."""
    p = sub.add_parser(
        "tune",
        help="search PID gains, margin and command limit for your design in closed loop (Optuna)",
        description="Search the controller's [control] settings (kp, ki, kd, d_alpha, margin, limit_v) on "
        "the simulated SEA: each trial runs `seagen simulate`'s experiment (3 targets x 10 contact angles, "
        "6 s each, per seed) and scores the worst target's mean settling time plus 0.3 x the mean over the "
        "targets (a run that never settles counts 6 s). The search ranges are the paper's, widened for the "
        "design (gains by the nut speed per volt, kp and ki also by the compression the stalled motor "
        "holds per volt, the margin's top at the paper's as a force on the spring, inside the settling "
        "band, limit like the calibration "
        "pushes' volts, within the supply and what the C's gains hold); the first trial is the "
        "description's own settings. Prints the best as [control] "
        "lines to paste into the description (then regenerate the data and retrain: the description's "
        "hash changes). With --model: your control model's MCU configuration; without, on another "
        "design: kin_mcu (the kinematics baseline), scored on settling to the force's final level with the "
        "loop's measured compression within the band (as a force) of its setpoint, as its estimate is "
        "biased; on the paper's "
        "actuator without --model: the search behind the shipped gains (the shipped MLP and SF).",
    )
    p.add_argument("--model", metavar="CONTROL_MODEL", type=model_arg, help="your control model to tune for")
    p.add_argument("--features", metavar="SPEC", help="feature specification of --model (bare networks)")
    p.add_argument(
        "--actuator",
        metavar="FILE",
        help="actuator description TOML (default: the one --model records, else the paper's)",
    )
    p.add_argument(
        "--allow-pickle",
        action="store_true",
        help="unpickle model files holding arbitrary Python objects (RUNS CODE: trusted files only)",
    )
    p.add_argument(
        "--trials", type=int, default=40, help="Optuna trials (default 40; ~25 s each on the paper's)"
    )
    p.add_argument("--seeds", type=int, default=4, help="plant-noise seeds per trial (default 4)")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_tune)


def cmd_tune(args: argparse.Namespace) -> int:
    """Run the search and print the best settings, their settling times and the [control] lines."""
    from seagen.actuator import is_default
    from seagen.control.experiment import BAND_N, model_free_setups, targets_n
    from seagen.control.tune import NEVER_S, control_table, tune, worst_plus_mean
    from seagen.setups.shipped import CONFIGS

    if args.trials < 1:
        raise UserError(f"--trials must be >= 1, got {args.trials}")
    if args.seeds < 1:
        raise UserError(f"--seeds must be >= 1, got {args.seeds}")
    act = plant_actuator(args)
    setup, name, metric = None, "shipped mlp_mcu and sf_mcu", "settling_s"
    if args.model:
        from seagen.setups.user import control_setups

        mine, _row = control_setups(args.model, args.features, args.allow_pickle, act)
        name = next(n for n in mine if n.endswith("_mcu"))
        setup = mine[name]
    elif not is_default(act):
        name, metric = "kin_mcu", "settling_held_s"
        setup = model_free_setups(act)[name]
        print(
            f"seagen tune: {act.source}: tuning kin_mcu (no --model given) on its settling to the force's "
            "final level with the loop at its own setpoint (its estimate is biased, so the force need not "
            "reach the target's band; a loop held off its setpoint does not settle)",
            file=sys.stderr,
        )
    seeds = tuple(10 * k for k in range(args.seeds))
    study = tune(
        args.trials,
        seeds,
        setup=setup,
        act=act,
        progress=not args.json,
        name=name,
        metric=metric,
        shipped=CONFIGS,
    )
    best = study.best_trial

    def shown(trial) -> dict[str, dict[str, float]]:  # a trial's settling per configuration and target
        return {k: {f"{t:g}": round(v, 3) for t, v in d.items()} for k, d in trial.user_attrs.items()}

    settling, first = shown(best), shown(study.trials[0])
    table = control_table(best.params)
    if args.json:
        print(
            json.dumps(
                {
                    "configuration": name,
                    "params": best.params,
                    "settling_s": settling,
                    "first_trial_settling_s": first,
                    "control": table,
                }
            )
        )
    else:
        print(f"tuned {name} on {act.name} over {args.trials} trials x {args.seeds} seeds")
        to = " to the final level, held" if metric == "settling_held_s" else ""
        for label, trial in (("best", settling), ("first trial: the description's own", first)):
            for k, d in trial.items():
                print(f"mean settling s{to} ({k}), {label}:", ", ".join(f"{t} N {v}" for t, v in d.items()))
        print(table)
    if best.value >= worst_plus_mean(dict.fromkeys(targets_n(act), NEVER_S)):
        print(
            f"seagen tune: note: no run of {name} settled in any trial (within {BAND_N:g} N for good within "
            f"{NEVER_S:g} s), so the trials could not be ranked: check its error in `seagen simulate` (a "
            "force estimate further off than the band never settles; without --model, tune kin_mcu)",
            file=sys.stderr,
        )
    return 0
