"""``helixd serve`` in tests: the daemon as a subprocess with the test configuration, and the
simulator with a QGC-like ground station on a second link (tests.support.gcs)."""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.server import SimServer
from helixd.sim.snapshot import SimSnapshot
from tests.support.daemon import DaemonProc, deep_merge, spawn_daemon
from tests.support.gcs import QGC_SYSID, set_mode_command, shows_armed, shows_mode
from tests.support.harness import (
    BASE_CONFIG,
    MavClient,
    overrides_released,
    running_sim_links,
    time_until,
)

SWITCH_CH = 7
LOW_US, HIGH_US = 1100, 1900
SPEEDUP = 5.0
MOVING_MPS = 0.1  # faster than this is driving
CONFIG: dict[str, Any] = {
    "mission": {"ground_station_mode": "roll"},
    "startup": {"start_switch_channel": SWITCH_CH},
    "serve": {"mission_poll_s": 1.0, "tick_s": 0.05, "state_rate_hz": 2.0},
}


def serve_proc(tmp_path: Path, url: str, extra: dict[str, Any] | None = None) -> DaemonProc:
    cfg = deep_merge(deep_merge(BASE_CONFIG, CONFIG), {"link": {"url": url}})
    cfg = deep_merge(cfg, extra or {})
    cfg_path = tmp_path / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg), encoding="utf-8")
    run_root = tmp_path / "runs"
    return spawn_daemon(
        ["serve", "--config", str(cfg_path), "--run-dir", str(run_root)],
        cwd=tmp_path,
        run_root=run_root,
    )


@contextmanager
def sim_with_ground_station(
    speedup: float = SPEEDUP, links: int = 2, **overrides: Any
) -> Iterator[tuple[SimServer, list[str], MavClient]]:
    """The simulator with ``links`` UDP links: helixd's URL first, the ground station (system
    255, connected) on the second, any others for the test; yields (server, urls, gcs).
    ``overrides``: more simulator settings (SimConfig keys)."""
    links_ = ["udpin:127.0.0.1:0"] * links
    with running_sim_links(links_, speedup=speedup, **overrides) as server:
        urls = [f"udpout:127.0.0.1:{p}" for p in server.local_ports]
        with MavClient(urls[1], sysid=QGC_SYSID) as gcs:
            yield server, urls, gcs


def moving(s: SimSnapshot) -> bool:
    """Armed and driving (from the simulator's side)."""
    return s.armed and s.speed_mps > MOVING_MPS


@contextmanager
def serving(tmp_path: Path, url: str, extra: dict[str, Any] | None = None) -> Iterator[DaemonProc]:
    """``helixd serve`` (:func:`serve_proc`, its output pumped) for the ``with`` block; then
    killed if still up and its log kept in ``tmp_path``/serve.log."""
    d = serve_proc(tmp_path, url, extra)
    d.start_pump()
    try:
        yield d
    finally:
        d.kill()
        (tmp_path / "serve.log").write_text(d.log_text(), encoding="utf-8")


def flight_summaries(tmp_path: Path) -> list[dict[str, Any]]:
    """summary.json of each flight ``helixd serve`` recorded under ``tmp_path``/runs, in order."""
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    return [json.loads((r / "summary.json").read_text()) for r in runs]


def set_mode(gcs: MavClient, name: str) -> float:
    """QGroundControl's Vehicle::setFlightMode for ArduPilot: MAV_CMD_DO_SET_MODE to the
    autopilot with the custom mode; returns the monotonic time it was sent."""
    sent = time.monotonic()
    result = gcs.command(*set_mode_command(name))
    assert result == MAV_RESULT_ACCEPTED, (name, result)
    return sent


def heartbeat_shows(gcs: MavClient, condition: Any) -> None:
    """What QGroundControl's _setFlightModeAndValidate / _armVehicleAndValidate wait for: the
    autopilot's HEARTBEAT on the ground station's own link showing the change."""
    gcs.expect("HEARTBEAT", 10.0, lambda m: m.get_srcSystem() == 1 and condition(m))


def upload_and_start(
    server: SimServer, gcs: MavClient, d: DaemonProc, upload_mission: Callable[[], None]
) -> None:
    """QGroundControl's Plan view Upload (``upload_mission``) once ``helixd serve`` finds no
    mission, then Start Mission on the disarmed rover once it is ready
    (APMFirmwarePlugin::startMission: GUIDED, arm, MAV_CMD_MISSION_START to the autopilot):
    until helixd starts driving in AUTO."""
    d.wait_line("no mission on the autopilot", 60.0)
    upload_mission()
    d.wait_line("event=serve_state state=ready", 30.0)
    set_mode(gcs, "GUIDED")
    heartbeat_shows(gcs, shows_mode("GUIDED"))
    assert gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    heartbeat_shows(gcs, shows_armed)
    assert gcs.command(MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
    d.wait_line("event=auto_start", 10.0)  # item 0 or 1: MISSION_CURRENT may lag the start
    server.wait_for(moving, 20.0)


def let_go_in_manual(server: SimServer, gcs: MavClient, d: DaemonProc) -> None:
    """The crew picks MANUAL: helixd releases its overrides within 5 s and pauses."""
    mark = d.mark()
    t_manual = set_mode(gcs, "MANUAL")
    time_until(server, overrides_released, t_manual, 5.0)
    d.wait_line("event=serve_state state=paused", 30.0, after=mark)


@contextmanager
def serving_crew(
    tmp_path: Path, extra: dict[str, Any] | None = None, **sim: Any
) -> Iterator[tuple[SimServer, MavClient, DaemonProc]]:
    """:func:`sim_with_ground_station` (``sim``: its arguments) with :func:`serving` on its
    first link; yields (server, gcs, d)."""
    with (
        sim_with_ground_station(**sim) as (server, urls, gcs),
        serving(tmp_path, urls[0], extra) as d,
    ):
        yield server, gcs, d
