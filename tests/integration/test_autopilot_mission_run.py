"""`helixd run --mission autopilot` flies what the autopilot holds (uploaded as QGC would), and
`--show-plan` leaves helixd's plan in the autopilot for the ground station to draw — without
the autopilot ever being in AUTO. Real CLI processes against the simulator over UDP; the
``--show-plan`` flight on the simulated clock."""

from __future__ import annotations

import copy
import json
import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
import yaml

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import latlon_to_ne
from helixd.sim.sim_config import SimConfig
from helixd.sim.snapshot import SimSnapshot
from tests.support.cli import helixd_process as helixd
from tests.support.daemon import DaemonProc, deep_merge, spawn_daemon
from tests.support.harness import BASE_CONFIG, SPEEDUP, running_sim, secured
from tests.support.paths import DATA_DIR
from tests.support.simulated import simulated_flight

pytestmark = pytest.mark.integration

PLAN = DATA_DIR / "sim_square.plan"
SIM_ORIGIN = (SimConfig().origin_lat_deg, SimConfig().origin_lon_deg)
MAV_CMD_NAV_WAYPOINT = 16
MAV_CMD_NAV_GUIDED_ENABLE = 92  # Rover hands navigation away: helixd cannot fly it


def write_config(tmp_path: Path, url: str) -> Path:
    path = tmp_path / "helixd.yaml"
    path.write_text(yaml.safe_dump(deep_merge(BASE_CONFIG, {"link": {"url": url}})), "utf-8")
    return path


def upload(plan: Path, url: str, cfg: Path, cwd: Path) -> None:
    res = helixd(["mission", "upload", str(plan), "--connect", url, "--config", str(cfg)], cwd)
    assert res.returncode == 0, res.stderr


def run_autopilot_args(url: str, cfg: Path, tmp_path: Path) -> list[str]:
    return ["run", "--mission", "autopilot", "--mode", "roll", "--connect", url,
            "--config", str(cfg), "--run-dir", str(tmp_path / "runs")]  # fmt: skip


@contextmanager
def run_daemon(tmp_path: Path, args: list[str]) -> Iterator[DaemonProc]:
    run_root = tmp_path / "runs"
    handle = spawn_daemon(["run", *args, "--run-dir", str(run_root)], cwd=tmp_path,
                          run_root=run_root)  # fmt: skip
    try:
        yield handle
    finally:
        handle.kill()


def stored_ne(snap: SimSnapshot) -> list[tuple[float, float]]:
    """The simulator's stored mission items after home, as EKF north/east (m)."""
    out = []
    for it in snap.mission_items[1:]:
        assert it.command == MAV_CMD_NAV_WAYPOINT
        out.append(latlon_to_ne(it.x / 1e7, it.y / 1e7, *SIM_ORIGIN))
    return out


def test_run_flies_the_autopilots_mission(tmp_path: Path) -> None:
    with running_sim(speedup=SPEEDUP, terrain="hard", noise="low") as (server, url):
        cfg = write_config(tmp_path, url)
        upload(PLAN, url, cfg, tmp_path)
        args = ["--mission", "autopilot", "--mode", "roll", "--connect", url, "--config", str(cfg)]
        with run_daemon(tmp_path, args) as d:
            code = d.wait_exit(240.0)
            log = d.log_text()
            run_dir = d.run_dir()
            snap = server.snapshot()
    assert code == ExitCode.OK, log[-3000:]
    assert "autopilot at udpout" in log and "3 mission items" in log
    s = json.loads((run_dir / "summary.json").read_text())
    assert s["completed"] is True and s["waypoints_reached"] == s["waypoints_total"] == 3
    assert s["mode"] == "roll"
    # the simulator's side: the rover ended at the plan's last waypoint (N 0, E 8)
    assert math.hypot(snap.north_m - 0.0, snap.east_m - 8.0) < 1.5
    assert secured(snap)
    recorded = yaml.safe_load((run_dir / "mission.yaml").read_text())
    plan_doc = json.loads(PLAN.read_text())
    assert recorded["name"] == "autopilot" and recorded["frame"] == "global"
    flown = [v for w in recorded["waypoints"] for v in (w["lat"], w["lon"])]
    planned = [v for it in plan_doc["mission"]["items"] for v in it["params"][4:6]]
    assert flown == pytest.approx(planned, abs=1e-7)
    assert len(recorded["geofence_polygon"]) == 4  # the plan's fence came down too


def test_empty_autopilot_mission_is_refused(tmp_path: Path) -> None:
    with running_sim(speedup=SPEEDUP) as (server, url):
        cfg = write_config(tmp_path, url)
        res = helixd(run_autopilot_args(url, cfg, tmp_path), tmp_path)
        snap = server.snapshot()
    errors = [line for line in res.stderr.splitlines() if line.startswith("error:")]
    assert res.returncode == ExitCode.PREFLIGHT, res.stderr
    assert len(errors) == 1 and "holds no mission" in errors[0], res.stderr
    assert not snap.armed and not (tmp_path / "runs").exists()


def test_unsupported_item_is_refused_by_number(tmp_path: Path) -> None:
    doc = json.loads(PLAN.read_text())
    loiter = copy.deepcopy(doc["mission"]["items"][1])
    loiter["command"], loiter["doJumpId"] = MAV_CMD_NAV_GUIDED_ENABLE, 9
    doc["mission"]["items"].insert(1, loiter)
    plan = tmp_path / "loiter.plan"
    plan.write_text(json.dumps(doc), "utf-8")
    with running_sim(speedup=SPEEDUP) as (server, url):
        cfg = write_config(tmp_path, url)
        upload(plan, url, cfg, tmp_path)
        res = helixd(run_autopilot_args(url, cfg, tmp_path), tmp_path)
        snap = server.snapshot()
    errors = [line for line in res.stderr.splitlines() if line.startswith("error:")]
    assert res.returncode == ExitCode.PREFLIGHT, res.stderr
    assert len(errors) == 1, res.stderr
    assert "item 2 NAV_GUIDED_ENABLE" in errors[0] and "offboard" in errors[0], errors
    assert not snap.armed


def test_show_plan_leaves_the_plan_in_the_autopilot_never_in_auto(tmp_path: Path) -> None:
    """``--show-plan`` on the simulated clock (tests.support.simulated)."""
    flown = simulated_flight(tmp_path, "square", show_plan=True, terrain="hard", noise="low")
    modes = {snap.mode for _, snap in flown.trace.samples}
    assert flown.code == ExitCode.OK, flown.log[-3000:]
    assert "show_plan_uploaded" in flown.log
    snap = flown.snapshot
    ne = stored_ne(snap)
    assert len(ne) == 4  # the square's four corners, as flown from the start pose
    sides = [math.dist(ne[i - 1], ne[i]) for i in range(1, 4)]
    assert sides == pytest.approx([10.0, 10.0, 10.0], abs=0.05)
    # the last corner is where the rover ended (the square closes at its start)
    assert math.dist(ne[-1], (snap.est_north_m, snap.est_east_m)) < 1.5
    assert "AUTO" not in modes and {"MANUAL", "HOLD"} <= modes, modes
