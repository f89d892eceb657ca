"""The wireless link between the glove's MCU and the PC that runs a cloud predictor (paper §VI, Figs. 11-12).

The paper: the control frequency is 10 Hz, limited by the Bluetooth link; the MCU runs the compression PID at
100 Hz with the pot averaged and refreshed at 10 Hz and a 0.1 mm margin; new data fed to the predictor update
the desired compression it sends back. Where the paper is silent the numbers below come from the sources
named beside them (docs/cloud.md lists them with their plausible ranges).

`BleLink` is that link over Bluetooth LE: at each 10 Hz slot with no round in flight the MCU notifies one
sample (its tick, encoder, averaged pot; 8 bytes, one packet); packets move only at connection events (every
`interval_s`, from a random anchor); a packet received in error is retransmitted at the next event; the PC
answers after its turnaround and scheduling jitter; the reply is applied at the MCU's next tick.
`IdealLink` is the earlier, generous model (100 Hz samples with each request, a fixed round trip).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from seagen.runtime.actq import ActQ
from seagen.runtime.control import ControlConfig
from seagen.runtime.fixed import COMP_FRAC_BITS

if TYPE_CHECKING:
    from seagen.control.loop import CloudPredictor

# Bluetooth Core Specification v5.3, Vol 6 (Low Energy Controller), Part B (Link Layer), §4.5.1 "Connection
# events": connInterval is a multiple of 1.25 ms from 7.5 ms to 4.0 s.
INTERVAL_UNIT_S = 0.00125
INTERVAL_RANGE_S = (0.0075, 4.0)
# The interval a phone or PC central grants by default: Linux (net/bluetooth/hci_core.c:
# le_conn_min_interval 0x0018 = 30 ms, le_conn_max_interval 0x0028 = 50 ms), Android (BluetoothGatt
# CONNECTION_PRIORITY_BALANCED, 30-50 ms) and iOS (Apple Accessory Design Guidelines, Bluetooth LE
# connection parameters: 30 ms) all allow 30 ms.
INTERVAL_S = 0.030
# The PC's turnaround: HCI over USB moves a packet in 1 ms USB frames (Core Specification Vol 4, Part B, USB
# transport: events on an interrupt endpoint polled every 1 ms, ACL data on bulk endpoints), one frame each
# way; the float MLP itself takes ~0.02 ms (numpy, measured here: docs/cloud.md).
HOST_S = 0.002
# The PC's scheduling jitter: a user thread wakes on the OS timer tick, 15.625 ms by default on Windows
# (Microsoft, timeBeginPeriod documentation: the default timer resolution, 64 Hz); uniform over one tick.
JITTER_S = 0.015625
# Packet error rate per connection-event attempt: 0 on a link well inside its range; ~10 % at its edge (Core
# Specification Vol 6 Part A §4.1: receiver sensitivity is specified at a bit error rate of 0.1 %, ~15 % of
# our 160-bit PDUs; the IEEE 802.15.6 body-area-network requirements ask for a packet error rate below 10 %).
LOSS = 0.0
LINK_STREAM = 0x4C494E4B  # the link's random stream, apart from the plant's noise of the same seed
# Paper §VI-A: "The control margin is set to 0.1mm compression difference" (~0.5 N on its 4.2 N/mm spring).
PAPER_MARGIN_MM = 0.1


@dataclass(frozen=True)
class BleLink:
    """A Bluetooth LE link: connection interval, packet error rate, PC turnaround and jitter (seconds)."""

    interval_s: float = INTERVAL_S
    loss: float = LOSS
    host_s: float = HOST_S
    jitter_s: float = JITTER_S
    per_tick: bool = True  # the PC turns the samples' differences into per-tick rates (the model's units)


def cloud_control(a: ActQ, stiffness_n_per_mm: float, paper_stiffness: float) -> ControlConfig:
    """The MCU's controller behind the link: actuator `a`'s configuration with the paper's 0.1 mm margin
    (as a force: the same share of its spring, `stiffness_n_per_mm`, as of the paper's)."""
    cfg = ControlConfig.for_act(a)
    margin_mm = PAPER_MARGIN_MM * paper_stiffness / stiffness_n_per_mm
    return replace(cfg, pid=replace(cfg.pid, margin=round(margin_mm * (1 << COMP_FRAC_BITS))))


def with_link(factory: Any, link: BleLink) -> Any:
    """A configuration factory whose cloud predictor (if any) talks over `link` instead."""
    from seagen.control.loop import CloudPredictor

    def make() -> Any:
        pred, cfg = factory()
        return (replace(pred, link=link) if isinstance(pred, CloudPredictor) else pred), cfg

    return make


def make_link(cloud: CloudPredictor, tick_s: float, seed: int) -> IdealLink | BleRounds:
    """The link runtime of `cloud` for one run (its random stream from the run's `seed`)."""
    if cloud.link is None:
        return IdealLink(cloud, tick_s)
    return BleRounds(cloud, cloud.link, tick_s, np.random.default_rng([LINK_STREAM, seed]))


def to_q16(mm: Any) -> np.ndarray:
    """Compression in mm as Q16 integers (rounded half to even)."""
    return np.rint(np.asarray(mm, float) * 65536.0).astype(np.int64)


class IdealLink:
    """The generous link: the last three loop-rate samples with each request, one request in flight, a reply
    `latency_s` after it (at most every max(period, latency))."""

    def __init__(self, cloud: CloudPredictor, tick_s: float) -> None:
        self.cloud = cloud
        self.period = max(int(round(1.0 / (cloud.refresh_hz * tick_s))), 1)
        self.delay = int(round(cloud.latency_s / tick_s))
        self.hist: np.ndarray | None = None  # (3, 2, n): rows k-2, k-1, k of (enc, pot)
        self.reply: tuple[int, np.ndarray] | None = None

    def tick(self, ctrl: Any, k: int, enc: np.ndarray, pot: np.ndarray, f_n: float) -> None:
        """Record this tick's sample; apply a due reply; send a request at an idle slot."""
        now = np.stack([enc, pot]).astype(np.int64)
        self.hist = np.stack([now] * 3) if self.hist is None else np.concatenate([self.hist[1:], now[None]])
        if self.reply is not None and self.reply[0] <= k:
            ctrl.set_desired(self.reply[1])
            self.reply = None
        if self.reply is None and k % self.period == 0:
            mm = self.cloud.fn(self.hist[:, 0], self.hist[:, 1], np.full(enc.shape, f_n))
            self.reply = (k + self.delay, to_q16(mm))
            if self.delay == 0:
                ctrl.set_desired(self.reply[1])
                self.reply = None


def per_tick_rows(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Three rows, one tick apart, whose differences are the per-tick rates of samples x (3, n) taken at
    ticks t (3, n): d = backward difference over the last gap, dd = change of d over the last gap."""
    h1, h2 = t[1] - t[0], t[2] - t[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        d2 = np.where(h2 > 0, (x[2] - x[1]) / h2, 0.0)
        d1 = np.where(h1 > 0, (x[1] - x[0]) / h1, 0.0)
        dd = np.where(h2 > 0, (d2 - d1) / h2, 0.0)
    x2 = x[2].astype(float)
    return np.stack([x2 - 2 * d2 + dd, x2 - d2, x2])


class BleRounds:
    """A cloud predictor's rounds over a BleLink for a batch of actuators (one connection each)."""

    def __init__(self, cloud: CloudPredictor, link: BleLink, tick_s: float, rng: np.random.Generator) -> None:
        self.cloud, self.link, self.tick_s, self.rng = cloud, link, tick_s, rng
        self.period = max(int(round(1.0 / (cloud.refresh_hz * tick_s))), 1)
        self.phase = np.zeros(0)  # each connection's first event (s), drawn at the first tick
        self.hist = np.zeros((3, 3, 0), dtype=np.int64)  # rows: last three samples sent; (tick, enc, pot)
        self.busy = np.zeros(0, dtype=bool)  # a round in flight
        self.due = np.zeros(0, dtype=np.int64)  # the tick its reply is applied at
        self.reply = np.zeros(0, dtype=np.int64)  # its desired compression, Q16 mm
        self.fresh = np.zeros(0, dtype=bool)  # no sample sent yet

    def start(self, n: int) -> None:
        """n connections, each with a random anchor within one interval of the MCU's tick 0."""
        self.phase = self.rng.uniform(0.0, self.link.interval_s, n)
        self.hist = np.zeros((3, 3, n), dtype=np.int64)
        self.busy, self.due, self.reply = np.zeros(n, bool), np.zeros(n, np.int64), np.zeros(n, np.int64)
        self.fresh = np.ones(n, dtype=bool)  # no sample sent yet

    def next_event(self, t: np.ndarray) -> np.ndarray:
        """The first connection event strictly after time t (s)."""
        ci = self.link.interval_s
        return self.phase + (np.floor((t - self.phase) / ci + 1e-9) + 1.0) * ci

    def retries(self, n: int) -> np.ndarray:
        """Connection events lost before a packet gets through (link-layer retransmission), per actuator."""
        return self.rng.geometric(1.0 - self.link.loss, n) - 1

    def trip(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """When a round sent at tick k reaches the PC and comes back (s): uplink at a connection event, the
        PC's turnaround and jitter, downlink at a later event; a packet in error goes at the next event."""
        n, ci = len(self.phase), self.link.interval_s
        up = self.next_event(np.full(n, k * self.tick_s)) + ci * self.retries(n)
        ready = up + self.link.host_s + self.rng.uniform(0.0, 1.0, n) * self.link.jitter_s
        return up, self.next_event(ready) + ci * self.retries(n)

    def arrival(self, k: int) -> np.ndarray:
        """The MCU tick at which a round sent at tick k is applied: the first at or after its reply."""
        return np.ceil(self.trip(k)[1] / self.tick_s - 1e-6).astype(np.int64)

    def tick(self, ctrl: Any, k: int, enc: np.ndarray, pot: np.ndarray, f_n: float) -> None:
        """Apply due replies; at a 10 Hz slot, idle connections send (tick, enc, averaged pot)."""
        if len(self.phase) != len(enc):
            self.start(len(enc))
        done = self.busy & (self.due <= k)
        if done.any():
            ctrl.set_desired(np.where(done, self.reply, ctrl.field("desired")))
            self.busy &= ~done
        send = ~self.busy
        if k % self.period or not send.any():
            return
        sample = np.stack([np.full(len(enc), k), enc, ctrl.field("pot_avg")]).astype(np.int64)
        hist = np.concatenate([self.hist[1:], sample[None]])
        hist[:2, :, self.fresh] = sample[:, self.fresh]  # the first sample: no differences yet
        self.hist[:, :, send] = hist[:, :, send]
        self.fresh &= ~send
        mm = self.cloud.fn(*self.rows(), np.full(len(enc), f_n))
        self.reply = np.where(send, to_q16(mm), self.reply)
        self.due = np.where(send, self.arrival(k), self.due)
        self.busy |= send

    def rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The encoder and pot rows the PC feeds its model: per-tick rates, or the samples as received."""
        t, enc, pot = self.hist[:, 0], self.hist[:, 1], self.hist[:, 2]
        if not self.link.per_tick:
            return enc, pot
        return per_tick_rows(t, enc), per_tick_rows(t, pot)
