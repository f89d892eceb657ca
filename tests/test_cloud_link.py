"""The cloud set-up's Bluetooth LE link (seagen.control.link, docs/cloud.md): its timing on small direct
cases, the samples the PC gets, the CLI's refusals of its options, the MCU configurations it leaves alone."""

from __future__ import annotations

import json

import numpy as np
import pytest

from seagen.cli import main
from seagen.control import experiment
from seagen.control.link import BleLink, BleRounds, per_tick_rows, with_link
from seagen.control.loop import CloudPredictor, run_closed_loop
from seagen.control.predictors import kinematic_float

TICK_S = 0.01  # the paper's 100 Hz loop


def rounds(link: BleLink, n: int = 1, seed: int = 0, phase: float | None = None) -> BleRounds:
    """A link runtime for n connections; every anchor at `phase` (s) if given."""
    r = BleRounds(
        CloudPredictor(lambda e, p, f: np.zeros(np.shape(f))), link, TICK_S, np.random.default_rng(seed)
    )
    r.start(n)
    if phase is not None:
        r.phase = np.full(n, phase)
    return r


def on_events(t: np.ndarray, r: BleRounds) -> bool:
    """Every time in t falls on a connection event of its connection."""
    m = (t - r.phase) / r.link.interval_s
    return bool(np.allclose(m, np.round(m), atol=1e-6) and (m > -1e-6).all())


def test_a_round_trip_on_connection_events():
    """Anchor at 0, 30 ms interval, 2 ms PC, no jitter: a round sent at tick 10 (100 ms) goes up at the 120 ms
    event, comes down at 150 ms and is applied at tick 15; with random anchors and jitter both legs still
    fall on events of their connection, the uplink within one interval of the send, the downlink after the
    PC's turnaround."""
    r = rounds(BleLink(interval_s=0.03, host_s=0.002, jitter_s=0.0), phase=0.0)
    up, down = r.trip(10)
    assert np.allclose(up, 0.12) and np.allclose(down, 0.15) and r.arrival(10)[0] == 15
    r = rounds(BleLink(interval_s=0.0375, host_s=0.002, jitter_s=0.05), n=200, seed=3)
    up, down = r.trip(7)
    assert on_events(up, r) and on_events(down, r)
    assert (up > 0.07).all() and (up <= 0.07 + 0.0375 + 1e-9).all() and (down >= up + 0.002).all()
    assert (down <= up + 0.002 + 0.05 + 0.0375 + 1e-9).all()


def test_a_lost_packet_goes_at_a_later_event():
    """A packet received in error is sent again at the next event (the link layer retransmits): with loss
    the legs still fall on events, later by whole intervals; without loss never later."""
    link = BleLink(interval_s=0.03, host_s=0.002, jitter_s=0.0)
    clean = rounds(link, n=500, seed=5, phase=0.004)
    lossy = rounds(BleLink(interval_s=0.03, loss=0.5, host_s=0.002, jitter_s=0.0), n=500, seed=5, phase=0.004)
    (up0, down0), (up1, down1) = clean.trip(20), lossy.trip(20)
    assert np.allclose(up0, 0.214) and np.allclose(down0, 0.244)
    assert on_events(up1, lossy) and on_events(down1, lossy)
    late = np.round((down1 - down0) / 0.03)
    assert (late >= 0).all() and (late > 0).any() and 1.7 < late.mean() < 2.3  # 2 legs x p / (1 - p)


class FakeController:
    """The controller fields the link reads (desired, the averaged pot) and the setpoints it writes."""

    def __init__(self, n: int) -> None:
        self.desired = np.zeros(n, dtype=np.int64)
        self.pot_avg = np.full(n, 1234, dtype=np.int64)
        self.writes: list[tuple[int, np.ndarray]] = []
        self.k = 0

    def field(self, name: str) -> np.ndarray:
        """One field, as the controllers return it."""
        return getattr(self, name).copy()

    def set_desired(self, d: np.ndarray) -> None:
        """Record the tick and the setpoints written."""
        self.writes.append((self.k, np.array(d)))
        self.desired = np.array(d)


def test_one_round_in_flight_and_the_averaged_pot():
    """With a 125 ms interval a round outlasts the 10 Hz slot: the MCU sends again only at the first slot
    after the reply is applied; the PC gets the tick, the encoder and the averaged pot (not the raw pot);
    the reply is the prediction made from that sample."""
    sent: list[tuple[np.ndarray, np.ndarray]] = []

    def fn(enc, pot, force):
        """A PC model that records what it got and answers the newest encoder count / 1000 mm."""
        sent.append((np.array(enc), np.array(pot)))
        return np.asarray(enc, float)[-1] / 1000.0

    link = BleLink(interval_s=0.125, host_s=0.002, jitter_s=0.0, per_tick=False)
    r = BleRounds(CloudPredictor(fn, refresh_hz=10.0, link=link), link, TICK_S, np.random.default_rng(0))
    r.start(1)
    r.phase = np.array([0.05])  # events at 50, 175, 300 ms, ...: up at 50, down at 175 -> tick 18
    ctrl = FakeController(1)
    for k in range(61):
        ctrl.k = k
        r.tick(ctrl, k, np.array([100 + k]), np.array([999]), 5.0)
    # sent at tick 0 (up 50 ms, down 175 ms: applied at 18), not at 10; at 20 (300, 425: 43), not at 30 or 40
    assert [w[0] for w in ctrl.writes] == [18, 43]
    assert [int(s[0][-1, 0]) for s in sent] == [100, 120, 150]
    assert all((s[1] == 1234).all() for s in sent)  # the averaged pot, never the raw 999
    assert ctrl.writes[0][1][0] == round(0.100 * 65536)


def test_the_pc_turns_samples_into_per_tick_rates():
    """Samples 10 ticks apart become three rows one tick apart whose first and second differences are the
    per-tick rate and its change (x = t^2: d = 30, dd = 2 at t = 20); a first sample has none."""
    t = np.array([[0], [10], [20]])
    rows = per_tick_rows(t, t.astype(float) ** 2)
    d, dd = rows[2] - rows[1], rows[2] - 2 * rows[1] + rows[0]
    assert rows[2, 0] == 400 and np.isclose(d[0], 30.0) and np.isclose(dd[0], 2.0)
    same = per_tick_rows(np.zeros((3, 1)), np.full((3, 1), 7.0))
    assert (same == 7.0).all()


BAD = [
    (["--link-interval-ms", "31"], "--link-interval-ms"),  # not a multiple of 1.25 ms
    (["--link-interval-ms", "5"], "--link-interval-ms"),
    (["--link-interval-ms", "4001.25"], "--link-interval-ms"),
    (["--link-interval-ms", "nan"], "--link-interval-ms"),
    (["--link-loss", "1"], "--link-loss"),
    (["--link-loss", "-0.1"], "--link-loss"),
    (["--link-jitter-ms", "-1"], "--link-jitter-ms"),
    (["--link-jitter-ms", "inf"], "--link-jitter-ms"),
    (["--latency", "-0.001"], "--latency"),
]


@pytest.mark.parametrize("argv,option", BAD, ids=[" ".join(a) for a, _o in BAD])
def test_bad_link_options_exit_2(argv, option, capsys):
    """A link option out of its range: exit 2, one line naming it, before anything runs."""
    assert main(["simulate", "--config", "mlp_cloud", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert option in err and len(err.splitlines()) == 1 and "Traceback" not in err


def test_the_link_leaves_mcu_configurations_alone(monkeypatch, capsys):
    """The link options replace only a cloud predictor's link: the MCU configurations' rows are identical
    with the slowest link options given (one target, two angles, 2 s)."""
    from seagen.setups.shipped import CONFIGS

    link = BleLink(interval_s=0.125, loss=0.5)
    cloud = with_link(CONFIGS["mlp_cloud"], link)()[0]
    assert isinstance(cloud, CloudPredictor) and cloud.link == link
    monkeypatch.setattr(experiment, "TARGET_FRACTIONS", (0.5,))
    monkeypatch.setattr(experiment, "N_CONTACT", 2)
    monkeypatch.setattr(experiment, "DURATION_S", 2.0)
    base = ["simulate", "--json", "--config", "kin_mcu", "--config", "sf_mcu"]
    slow = ["--link-interval-ms", "125", "--link-loss", "0.5", "--link-jitter-ms", "100", "--latency", "1"]
    tables = []
    for argv in (base, [*base, *slow]):
        assert main(argv) == 0
        tables.append(json.loads(capsys.readouterr().out))
    assert tables[0] == tables[1]


def test_cloud_over_ble_c_and_twin_same_trajectory():
    """Over the BLE link (per-actuator rounds and setpoints) the C controller and its Python twin give the
    same trajectory, and the setpoint changes only at the ticks the link applies replies at."""
    pred = CloudPredictor(kinematic_float(), refresh_hz=10.0, link=BleLink())
    angles = np.array([8.0, 14.0, 22.0])
    runs = [run_closed_loop(pred, 10.0, angles, impl=i, duration_s=1.5, seed=2) for i in ("c", "py")]
    for key in runs[0]:
        assert np.array_equal(runs[0][key], runs[1][key]), key
    desired = runs[0]["desired"]
    changes = np.flatnonzero((np.diff(desired, axis=0) != 0).any(axis=1))
    assert len(changes) >= 3 and (runs[0]["true_force_n"][-1] > 1.0).all()


def test_demo_says_what_the_cloud_rows_are():
    """The demo's note under Table II names the link's sourced interval and jitter (from the link model, so
    it cannot drift from it) and where the sources and the sensitivity table are."""
    from seagen.control.link import INTERVAL_S, JITTER_S
    from seagen.demo.steps import cloud_note

    note = cloud_note()
    assert f"{INTERVAL_S * 1e3:g} ms connection interval" in note and f"{JITTER_S * 1e3:g} ms" in note
    assert "2.7-3.2 s" in note and "docs/cloud.md" in note
