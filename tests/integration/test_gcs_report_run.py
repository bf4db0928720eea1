"""A second MAVLink client on another simulator link sees what helixd is doing during a run:
STATUSTEXT for its phases, each waypoint reached and a fault, NAMED_VALUE_FLOAT xtrack_m and
wp_index — forwarded by the simulator from the companion's link as ArduPilot's routing does."""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.sim.sim_config import HELIXD_SYSID
from tests.support.daemon import DaemonProc
from tests.support.harness import (
    SPEEDUP,
    MavClient,
    daemon,
    free_udp_port,
    running_sim_links,
    wait_moving,
)

pytestmark = pytest.mark.integration

MAV_SEVERITY_CRITICAL = 2
GCS_WATCHER_SYSID = 250  # a ground station that is not helixd


class Watcher:
    """A plain pymavlink GCS on the simulator's second link, keeping what helixd sent."""

    def __init__(self, port: int) -> None:
        self.client = MavClient(f"udpin:127.0.0.1:{port}", sysid=GCS_WATCHER_SYSID)
        self.texts: list[tuple[int, str, int]] = []  # severity, text, sender sysid
        self.values: dict[str, list[float]] = {}
        self._last_hb_s = 0.0

    def pump_until(self, done: Callable[[], bool], timeout_s: float) -> None:
        deadline = time.monotonic() + timeout_s
        conn = self.client.conn
        while not done():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out; texts {self.texts}")
            if time.monotonic() - self._last_hb_s > 0.5:
                self.client.heartbeat()  # the simulator learns a route to this link from it
                self._last_hb_s = time.monotonic()
            msg = conn.recv_match(blocking=True, timeout=0.1)
            if msg is None:
                continue
            self._note(msg)

    def _note(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "STATUSTEXT" and str(msg.text).startswith("helixd"):
            self.texts.append((int(msg.severity), str(msg.text), msg.get_srcSystem()))
        elif kind == "NAMED_VALUE_FLOAT":
            self.values.setdefault(str(msg.name), []).append(float(msg.value))

    def has(self, prefix: str) -> bool:
        return any(t.startswith(prefix) for _, t, _ in self.texts)


@contextlib.contextmanager
def watched_square(tmp_path: Path) -> Iterator[tuple[Any, Watcher, DaemonProc]]:
    """The simulator (mud) with a plain GCS watching its second link, and the daemon flying
    the square over its first: (simulator, watcher, daemon)."""
    port = free_udp_port()
    links = ["udpin:127.0.0.1:0", f"udpout:127.0.0.1:{port}"]
    with running_sim_links(links, speedup=SPEEDUP, terrain="mud") as srv:
        url = f"udpout:127.0.0.1:{srv.local_ports[0]}"
        w = Watcher(port)
        try:
            with daemon(tmp_path, url, "square") as d:
                yield srv, w, d
        finally:
            w.client.close()


def test_gcs_sees_phases_waypoints_and_progress(tmp_path: Path) -> None:
    with watched_square(tmp_path) as (_, w, d):
        w.pump_until(lambda: w.has("helixd: mission complete"), 180.0)
        code = d.wait_exit(30.0)
        log = d.log_text()
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
    assert {sysid for _, _, sysid in w.texts} == {HELIXD_SYSID}  # forwarded as helixd sent it
    xtrack = w.values.get("xtrack_m", [])
    wp_index = w.values.get("wp_index", [])
    assert xtrack and all(math.isfinite(x) and abs(x) < 10.0 for x in xtrack)
    assert {1.0, 2.0, 3.0} <= set(wp_index), sorted(set(wp_index))


def test_gcs_sees_a_fault_as_critical(tmp_path: Path) -> None:
    with watched_square(tmp_path) as (srv, w, d):
        w.pump_until(lambda: w.has("helixd: fly"), 120.0)
        wait_moving(srv)
        srv.inject("ekf_unhealthy", duration_s=30.0 * SPEEDUP)
        w.pump_until(lambda: w.has("helixd: secured"), 30.0)
        code = d.wait_exit(30.0)
        log = d.log_text()
    assert code == ExitCode.FAULT, log[-3000:]
    faults = [(sev, t) for sev, t, _ in w.texts if t.startswith("helixd: FAULT: EKF unhealthy")]
    assert faults and faults[0][0] == MAV_SEVERITY_CRITICAL, w.texts
    assert not any(t == "helixd: mission complete" for _, t, _ in w.texts)
