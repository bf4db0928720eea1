"""``helixd mission upload|download`` (the real CLI) against the simulator over UDP, and the
daemon's link ``.tlog`` read back by pymavlink. Assertions on the simulator's side where it
matters: what the autopilot stored, what it saw."""

from __future__ import annotations

import asyncio
import itertools
import math
import os
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

os.environ.setdefault("MAVLINK20", "1")

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import latlon_to_ne
from helixd.mav.mission_item import MissionItem
from helixd.mission.formats import read_gcs
from helixd.mission.formats.items import GcsMission
from helixd.sim.sim_config import HELIXD_SYSID, SimConfig
from tests.support.harness import (
    FORCE_ARM,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_RESULT_ACCEPTED,
    client,
    free_udp_port,
    running_sim,
)
from tests.support.mavmsgs import read_tlog
from tests.support.paths import DATA_DIR, REPO_ROOT
from tests.support.simulated import Steer, moving, simulated_flight

pytestmark = pytest.mark.integration

DATA = DATA_DIR
PLAN = DATA / "pond_survey.plan"  # QGC: a waypoint, a Survey, RTL; fence: 2 polygons, 1 circle


def helixd(*args: str, timeout_s: float = 90.0) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "helixd", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout_s,
        check=False,
    )


def wire_params(it: MissionItem) -> tuple[float, ...]:
    """What an item's params become on the wire: QGC's unset (NaN) goes out as 0."""
    return tuple(
        v if math.isfinite(v) else 0.0 for v in (it.param1, it.param2, it.param3, it.param4)
    )


def flat(points: Any) -> list[float]:
    return [float(v) for p in points for v in p]


def assert_same_items(a: GcsMission, b: GcsMission) -> None:
    assert len(a.items) == len(b.items)
    for x, y in zip(a.items, b.items, strict=True):
        assert (x.seq, x.command, x.frame, x.autocontinue) == (
            y.seq,
            y.command,
            y.frame,
            y.autocontinue,
        )
        assert wire_params(x) == pytest.approx(wire_params(y))
        assert (x.x, x.y) == pytest.approx((y.x, y.y), abs=1e-7)  # degE7 on the wire


def test_plan_upload_then_download_gives_it_back(tmp_path: Path) -> None:
    sent = read_gcs(PLAN)
    with running_sim(speedup=5.0) as (server, url):
        up = helixd("mission", "upload", PLAN, "--connect", url)
        snap = server.snapshot()
        back = tmp_path / "back.plan"
        down = helixd("mission", "download", back, "--connect", url)
        as_yaml = tmp_path / "back.yaml"
        down_yaml = helixd("mission", "download", as_yaml, "--connect", url, "--mode", "roll")
        summary = helixd("mission", "download", "--connect", url)
    assert up.returncode == 0, up.stderr
    assert "Traceback" not in up.stderr
    # the autopilot stored home + every item, and the fence vertex by vertex, as QGC sends it
    assert len(snap.mission_items) == 1 + len(sent.items)
    stored = snap.mission_items[1:]
    assert [s.command for s in stored] == [it.command for it in sent.items]
    assert [(s.x, s.y) for s in stored if s.command == 16] == [
        (round(it.x * 1e7), round(it.y * 1e7)) for it in sent.items if it.command == 16
    ]
    n_vertices = sum(len(p.vertices_latlon_deg) for p in sent.polygons)
    assert len(snap.fence_items) == n_vertices + len(sent.circles)
    assert {s.command for s in snap.fence_items} == {5001, 5002, 5004}
    # downloaded back: the same items and fence, written as a .plan
    assert down.returncode == 0, down.stderr
    got = read_gcs(back)
    assert_same_items(sent, got)
    assert [p.inclusion for p in got.polygons] == [p.inclusion for p in sent.polygons]
    for p, q in zip(got.polygons, sent.polygons, strict=True):
        assert flat(p.vertices_latlon_deg) == pytest.approx(flat(q.vertices_latlon_deg), abs=1e-7)
    assert [(c.inclusion, c.radius_m) for c in got.circles] == [
        (c.inclusion, c.radius_m) for c in sent.circles
    ]
    assert got.circles[0].centre_latlon_deg == pytest.approx(sent.circles[0].centre_latlon_deg)
    # ... and as a helixd mission: every item, the Survey's camera items and the RTL included
    assert down_yaml.returncode == 0, down_yaml.stderr
    msn = yaml.safe_load(as_yaml.read_text())
    n_wp = sum(it.command == 16 for it in sent.items)
    assert msn["frame"] == "global" and len(msn["waypoints"]) == len(sent.items)
    assert sum("command" not in w for w in msn["waypoints"]) == n_wp
    assert [w["command"] for w in msn["waypoints"] if "command" in w] == [
        "DO_SET_CAM_TRIGG_DIST",
        "DO_SET_CAM_TRIGG_DIST",
        "NAV_RETURN_TO_LAUNCH",
    ]
    assert flat(msn["geofence_polygon"]) == pytest.approx(
        flat(sent.polygons[0].vertices_latlon_deg), abs=1e-7
    )
    # the downloaded .plan feeds `mission convert` like any QGC file
    conv = helixd("mission", "convert", back, tmp_path / "conv.waypoints", "--mode", "roll")
    assert conv.returncode == 0, conv.stderr
    assert f"{len(sent.items)} items" in conv.stdout
    # without OUT: a summary on stdout
    assert summary.returncode == 0, summary.stderr
    assert f"mission : {len(sent.items)} items" in summary.stdout
    assert "fence   : 2 polygons, 1 circles (1 inclusion, 2 exclusion)" in summary.stdout


def test_a_local_ned_mission_is_uploaded_through_the_autopilots_origin() -> None:
    """The autopilot knows its EKF origin: a local_ned mission goes up in lat/lon through it
    (and a start mission at the rover's pose), as the daemon would fly it."""
    with running_sim(speedup=5.0) as (server, url):
        local = helixd("mission", "upload", REPO_ROOT / "config/missions/pond-crossing.yaml",
                       "--connect", url)  # fmt: skip
        stored = server.snapshot().mission_items[1:]
        start = helixd("mission", "upload", REPO_ROOT / "config/missions/square.yaml",
                       "--connect", url)  # fmt: skip
        square = server.snapshot().mission_items[1:]
    assert local.returncode == 0, local.stderr
    assert "placed through the autopilot's EKF origin" in local.stderr
    sim = SimConfig()
    ne = [
        latlon_to_ne(s.x / 1e7, s.y / 1e7, sim.origin_lat_deg, sim.origin_lon_deg) for s in stored
    ]
    expected = [(40.0, 0.0), (40.0, 20.0), (5.0, 25.0)]  # config/missions/pond-crossing.yaml
    assert ne == [pytest.approx(p, abs=0.02) for p in expected]  # 1e-7 degree steps
    assert start.returncode == 0, start.stderr
    ne = [
        latlon_to_ne(s.x / 1e7, s.y / 1e7, sim.origin_lat_deg, sim.origin_lon_deg) for s in square
    ]
    # the rover stands at the origin facing North: x forward is north, y left is west
    assert ne == [pytest.approx(p, abs=0.3) for p in [(10, 0), (10, -10), (0, -10), (0, 0)]]


def waypoints_file(path: Path, n: int) -> Path:
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t53.5232500\t-113.5263200\t0\t1"]
    for i in range(1, n + 1):
        lat = 53.5232500 + 1e-5 * i
        rows.append(f"{i}\t0\t3\t16\t0\t0\t0\t0\t{lat:.7f}\t-113.5263200\t0\t1")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_upload_too_many_items_is_refused_by_name(tmp_path: Path) -> None:
    small = waypoints_file(tmp_path / "small.waypoints", 3)
    big = waypoints_file(tmp_path / "big.waypoints", 700)  # + home: 701 > the sim's 700
    with running_sim(speedup=5.0) as (server, url):
        ok = helixd("mission", "upload", small, "--connect", url)
        res = helixd("mission", "upload", big, "--connect", url)
        snap = server.snapshot()
    assert ok.returncode == 0, ok.stderr
    assert res.returncode == ExitCode.PREFLIGHT, res.stderr
    assert "Traceback" not in res.stderr
    lines = res.stderr.strip().splitlines()
    assert [ln for ln in lines if ln.startswith("error:")] == [
        f"error: {url}: mission upload refused: MAV_MISSION_NO_SPACE "
        "(autopilot: Only 700 items are supported)"
    ]
    assert len(snap.mission_items) == 4  # the earlier mission is kept, untouched


def test_upload_to_an_armed_autopilot_warns(tmp_path: Path) -> None:
    small = waypoints_file(tmp_path / "small.waypoints", 3)
    with running_sim(speedup=5.0) as (server, url):
        server.wait_for(lambda s: not s.booting and s.mode == "MANUAL", 20.0)
        with client(url) as c:
            assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM) == MAV_RESULT_ACCEPTED
        server.wait_for(lambda s: s.armed, 10.0)
        res = helixd("mission", "upload", small, "--connect", url)
        snap = server.snapshot()
    assert res.returncode == 0, res.stderr
    assert "warning: the autopilot is armed (mode MANUAL)" in res.stderr
    assert len(snap.mission_items) == 4


def test_no_autopilot_exits_as_a_link_error(tmp_path: Path) -> None:
    cfg = tmp_path / "helixd.yaml"
    cfg.write_text(yaml.safe_dump({"startup": {"connect_timeout_s": 1.0}}))
    url = f"udpout:127.0.0.1:{free_udp_port()}"
    res = helixd("mission", "download", "--connect", url, "--config", cfg)
    assert res.returncode == ExitCode.LINK, res.stderr
    assert "Traceback" not in res.stderr
    assert res.stderr.count("error:") == 1 and "no HEARTBEAT" in res.stderr


def list_dirs(root: Path) -> list[Path]:
    return sorted(p for p in root.iterdir() if p.is_dir())


def tlog_has_override(path: Path) -> bool:
    return path.exists() and any(m.get_type() == "RC_CHANNELS_OVERRIDE" for m in read_tlog(path))


def test_daemon_writes_the_link_tlog(tmp_path: Path) -> None:

    async def in_flight(st: Steer) -> Path:
        await st.until(moving, 40.0)
        (run_dir,) = list_dirs(tmp_path / "runs")
        tlog = run_dir / "link.tlog"
        # flushed while flying (not only at close): the overrides driving the rover are on disk
        # within 2 s (the file re-read at each control period)
        deadline = st.now_s() + 2.0
        while not tlog_has_override(tlog):
            assert st.now_s() < deadline, "no RC_CHANNELS_OVERRIDE in the .tlog in flight"
            await asyncio.sleep(0.02)
        return tlog

    flown = simulated_flight(tmp_path, "square", during=in_flight, terrain="hard", noise="low")
    code, log, tlog = flown.code, flown.log, flown.steered
    assert code == ExitCode.OK, log[-3000:]
    msgs = read_tlog(tlog)
    kinds = {(m.get_type(), m.get_srcSystem()) for m in msgs}
    assert ("HEARTBEAT", 1) in kinds  # in: the autopilot's
    assert ("HEARTBEAT", HELIXD_SYSID) in kinds  # out: ours
    assert ("RC_CHANNELS_OVERRIDE", HELIXD_SYSID) in kinds
    assert ("LOCAL_POSITION_NED", 1) in kinds
    stamps = [m._timestamp for m in msgs]
    # calendar stamps of this run, at the pace it was flown (simulated: 72 s of flight)
    assert all(abs(t - time.time()) < 600 for t in stamps)
    assert stamps[-1] - stamps[0] > 60.0
    assert sum(b < a - 0.05 for a, b in itertools.pairwise(stamps)) == 0
