"""`seagen simulate`'s options of the cloud configurations' Bluetooth LE link (seagen.control.link)."""

from __future__ import annotations

import argparse

from seagen.control.link import (
    HOST_S,
    INTERVAL_RANGE_S,
    INTERVAL_S,
    INTERVAL_UNIT_S,
    JITTER_S,
    LOSS,
    BleLink,
)
from seagen.errors import UserError


def add_link_options(p: argparse.ArgumentParser) -> None:
    """Add --latency and the --link-* options (defaults: the sourced values of docs/cloud.md)."""
    p.add_argument(
        "--latency",
        type=float,
        default=HOST_S,
        metavar="S",
        help="cloud configurations: the PC's turnaround per round, s, from a request's arrival to its reply "
        f"handed to its Bluetooth controller (default {HOST_S:g}: HCI over USB, one 1 ms frame each way)",
    )
    p.add_argument(
        "--link-interval-ms",
        type=float,
        default=INTERVAL_S * 1000,
        metavar="MS",
        help="cloud configurations: the Bluetooth LE connection interval, a multiple of 1.25 ms from 7.5 to "
        f"4000 (Core Specification Vol 6 Part B 4.5.1); default {INTERVAL_S * 1000:g}, what Linux, "
        "Android (balanced) and iOS centrals grant",
    )
    p.add_argument(
        "--link-loss",
        type=float,
        default=LOSS,
        metavar="P",
        help="cloud configurations: packet error rate per connection event, 0 to below 1; a lost packet is "
        f"sent again at the next event (default {LOSS:g}; 0.1 is a link at the edge of its range)",
    )
    p.add_argument(
        "--link-jitter-ms",
        type=float,
        default=JITTER_S * 1000,
        metavar="MS",
        help="cloud configurations: the PC's scheduling jitter, uniform from 0 to MS (default "
        f"{JITTER_S * 1000:g}: one tick of Windows' default timer)",
    )


def link_from(args: argparse.Namespace) -> BleLink:
    """The link the options describe; a value out of its range is refused naming its option (exit 2)."""
    ms, (lo, hi) = args.link_interval_ms, INTERVAL_RANGE_S
    units = ms / 1000.0 / INTERVAL_UNIT_S
    if not (lo * 1000 - 1e-6 <= ms <= hi * 1000 + 1e-6 and abs(units - round(units)) < 1e-6):  # NaN fails
        raise UserError(
            "--link-interval-ms must be a multiple of 1.25 from 7.5 to 4000 (Bluetooth Core Specification "
            f"Vol 6 Part B 4.5.1), got {ms:g}"
        )
    if not 0.0 <= args.link_loss < 1.0:
        raise UserError(f"--link-loss must be a packet error rate from 0 to below 1, got {args.link_loss:g}")
    if not 0.0 <= args.latency <= 3600.0:
        raise UserError(f"--latency must be a time from 0 to 3600 s, got {args.latency:g}")
    if not 0.0 <= args.link_jitter_ms <= 3.6e6:
        raise UserError(f"--link-jitter-ms must be a time from 0 to 3600000 ms, got {args.link_jitter_ms:g}")
    return BleLink(ms / 1000.0, args.link_loss, args.latency, args.link_jitter_ms / 1000.0)
