"""A second MAVLink client on another simulator link sees what helixd is doing during a run:
STATUSTEXT for its phases, each waypoint reached and a fault, NAMED_VALUE_FLOAT xtrack_m and
wp_index — forwarded by the simulator from the companion's link as ArduPilot's routing does."""

from __future__ import annotations

import asyncio
import math
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.sim.sim_config import HELIXD_SYSID
from tests.support.loop_mav import LoopMav
from tests.support.simulated import SimulatedFlight, Steer, moving, simulated_flight

pytestmark = pytest.mark.integration

MAV_SEVERITY_CRITICAL = 2
GCS_WATCHER_SYSID = 250  # a ground station that is not helixd


class Watcher:
    """What a plain GCS on the simulator's second link kept of what helixd sent."""

    def __init__(self, messages: list[Any]) -> None:
        self.texts: list[tuple[int, str, int]] = []  # severity, text, sender sysid
        self.values: dict[str, list[float]] = {}
        for msg in messages:
            kind = msg.get_type()
            if kind == "STATUSTEXT":
                self.texts.append((int(msg.severity), str(msg.text), msg.get_srcSystem()))
            elif kind == "NAMED_VALUE_FLOAT":
                self.values.setdefault(str(msg.name), []).append(float(msg.value))

    def has(self, prefix: str) -> bool:
        return any(t.startswith(prefix) for _, t, _ in self.texts)


async def heartbeating(st: Steer, gcs: LoopMav) -> None:
    """The ground station heartbeats (the simulator learns a route to its link from it)."""
    while not st.flight_done():
        gcs.heartbeat()
        await asyncio.sleep(0.5)


def watched_square(
    tmp_path: Path, fault: Callable[[Steer], Awaitable[None]] | None = None
) -> tuple[SimulatedFlight, Watcher]:
    """The simulator (mud) with a plain GCS watching its second link, and the daemon flying
    the square over its first (``fault``: what the test does once the rover moves)."""

    async def watch(st: Steer) -> list[Any]:
        gcs = st.ground_station(1, GCS_WATCHER_SYSID)
        beat = asyncio.ensure_future(heartbeating(st, gcs))
        if fault is not None:
            await st.until(moving, 60.0)
            await fault(st)
        await st.exited(300.0)
        await beat
        return list(gcs.inbox)

    flown = simulated_flight(tmp_path, "square", during=watch, links=2, terrain="mud")
    return flown, Watcher(flown.steered)


def test_gcs_sees_phases_waypoints_and_progress(tmp_path: Path) -> None:
    flown, w = watched_square(tmp_path)
    code, log = flown.code, flown.log
    assert code == ExitCode.OK, log[-3000:]
    texts = [t for _, t, _ in w.texts]
    for expected in (
        "helixd: preflight",
        "helixd: armed",
        "helixd: fly square: 4 waypoints",
        *(f"helixd: reached WP {i}/4" for i in range(1, 5)),
        "helixd: secured: scrolls neutral, HOLD",
        "helixd: mission complete",
    ):
        assert expected in texts, texts
    assert texts.index("helixd: reached WP 1/4") < texts.index("helixd: reached WP 4/4")
    # forwarded as helixd sent it (the autopilot's own texts, e.g. arming, come from system 1)
    ours = {sysid for _, t, sysid in w.texts if t.startswith("helixd: ")}
    assert ours == {HELIXD_SYSID}, w.texts
    xtrack = w.values.get("xtrack_m", [])
    wp_index = w.values.get("wp_index", [])
    assert xtrack and all(math.isfinite(x) and abs(x) < 10.0 for x in xtrack)
    assert {1.0, 2.0, 3.0} <= set(wp_index), sorted(set(wp_index))


def test_gcs_sees_a_fault_as_critical(tmp_path: Path) -> None:

    async def ekf(st: Steer) -> None:
        st.inject("ekf_unhealthy", duration_s=30.0)

    flown, w = watched_square(tmp_path, ekf)
    code, log = flown.code, flown.log
    assert w.has("helixd: fly") and w.has("helixd: secured"), w.texts
    assert code == ExitCode.FAULT, log[-3000:]
    faults = [(sev, t) for sev, t, _ in w.texts if t.startswith("helixd: FAULT: EKF unhealthy")]
    assert faults and faults[0][0] == MAV_SEVERITY_CRITICAL, w.texts
    assert not any(t == "helixd: mission complete" for _, t, _ in w.texts)
