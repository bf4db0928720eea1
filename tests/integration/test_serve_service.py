"""``helixd serve`` as a service: it reconnects, survives its own restart with the interrupted
mission remembered, and stays flat in memory and file descriptors over many flights.

Real UDP against the in-process simulator, on the simulated clock (tests.support.simulated);
three tests run the daemon as a subprocess on the wall clock (tests.support.daemon): the
reconnect (the autopilot comes and goes), the mission file, and the twenty flights, which
measure the daemon's own process (memory and descriptors)."""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path
from typing import Any

import pytest

from helixd.mav.constants import (
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_CMD_NAV_LOITER_UNLIM,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.snapshot import SimSnapshot
from tests.support import gcs as wall
from tests.support.gcs import QGC_SYSID
from tests.support.harness import free_udp_port, running_sim_links, secured
from tests.support.loop_gcs import command, upload
from tests.support.serve import serve_proc, sim_with_ground_station
from tests.support.simulated import Steer, moving, simulated_serve

NO_SWITCH: dict[str, Any] = {"startup": {"start_switch_channel": None}}
LOITER = MAV_CMD_NAV_LOITER_UNLIM


def rss_kib(pid: int) -> int:
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def open_fds(pid: int) -> int:
    return len(os.listdir(f"/proc/{pid}/fd"))


def test_reconnects_when_the_autopilot_comes_goes_and_comes_back(tmp_path: Path) -> None:
    port = free_udp_port()
    fast = {"serve": {"reconnect_initial_s": 0.2, "reconnect_max_s": 1.0}, **NO_SWITCH}
    d = serve_proc(tmp_path, f"udpout:127.0.0.1:{port}", fast)
    d.start_pump()
    try:
        d.wait_line("event=serve_state state=connecting", 30.0)
        for _ in range(2):  # up, down, up again
            mark = d.mark()
            with running_sim_links([f"udpin:127.0.0.1:{port}"], speedup=5.0):
                d.wait_line("no mission on the autopilot", 60.0, after=mark)
                mark = d.mark()
            d.wait_line("event=serve_state state=connecting", 30.0, after=mark)
        assert d.ended() is None
        lines = [ln for ln in d.lines if "event=serve_state state=connecting" in ln]
        assert len(lines) == 3  # once per change, not once per attempt
    finally:
        d.stop(20.0)
    assert d.proc.returncode == 0


def test_a_restarted_service_remembers_the_interrupted_mission_and_waits(tmp_path: Path) -> None:
    async def interrupted(st: Steer) -> None:
        gcs = st.ground_station(1, QGC_SYSID)
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, [(12.0, 0.0), (12.0, -4.0)])
        await st.line("event=serve_state state=ready", 30.0)
        assert await command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        await st.until(moving, 40.0)
        assert await command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 0) == MAV_RESULT_ACCEPTED
        await st.line("event=serve_state state=paused", 30.0)
        await st.until(secured, 10.0)
        st.signal(signal.SIGTERM)

    records: list[dict[str, Any]] = []

    async def continued(st: Steer) -> None:
        records.append(json.loads((tmp_path / "runs" / "serve-state.json").read_text()))
        gcs = st.ground_station(1, QGC_SYSID)
        await st.line("event=serve_state_loaded", 30.0)
        await st.line("interrupted: a start continues it", 60.0)
        assert not st.snapshot().armed  # remembered, and still waiting
        assert await command(gcs, MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED
        await st.line("event=run_resumed", 30.0)
        await st.line("event=serve_state state=completed", 90.0)
        st.signal(signal.SIGTERM)

    served = simulated_serve(tmp_path, [interrupted, continued], NO_SWITCH)
    assert served.codes == [0, 0], served.log[-3000:]
    (record,) = records
    assert record["state"] == "paused" and Path(record["run_dir"]).is_dir()
    summaries = [
        json.loads((r / "summary.json").read_text())
        for r in sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    ]
    assert [s["completed"] for s in summaries] == [False, True]
    assert summaries[1]["resumed_from"]["path"] == record["run_dir"]


def test_a_loiter_without_end_holds_until_the_ground_station_continues(tmp_path: Path) -> None:
    async def loiter(st: Steer) -> SimSnapshot:
        gcs = st.ground_station(1, QGC_SYSID)
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, [(4.0, 0.0), (4.0, -4.0), (0.0, 0.0)], commands={2: LOITER})
        await st.line("event=serve_state state=ready", 30.0)
        assert await command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        await st.line("kind=hold_started", 60.0)
        held = await st.until(lambda s: s.armed and s.speed_mps < 0.02, 10.0)
        mark = st.mark()
        assert await command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 1) == MAV_RESULT_ACCEPTED
        await st.line("event=hold_released", 10.0, after=mark)
        await st.line("event=serve_state state=completed", 60.0, after=mark)
        st.signal(signal.SIGTERM)
        return held

    (held,) = simulated_serve(tmp_path, loiter, NO_SWITCH).steered
    assert (held.north_m, held.east_m) == pytest.approx((4.0, -4.0), abs=0.5)
    (run,) = [p for p in (tmp_path / "runs").iterdir() if p.is_dir()]
    assert json.loads((run / "summary.json").read_text())["completed"] is True


def test_a_crew_without_a_ground_station_flies_a_mission_file(tmp_path: Path) -> None:
    """serve.mission_file: checked as `helixd run` checks it, started by the switch; the
    autopilot's own mission (and current item) is left alone."""
    mission = tmp_path / "short.yaml"
    mission.write_text(
        "name: short\nmode: roll\nframe: start\nwaypoints:\n  - {x: 4, y: 0}\n  - {x: 4, y: 3}\n"
    )
    with running_sim_links(["udpin:127.0.0.1:0"], speedup=5.0) as server:
        server.set_rc(7, 1100)
        url = f"udpout:127.0.0.1:{server.local_ports[0]}"
        d = serve_proc(tmp_path, url, {"serve": {"mission_file": str(mission)}})
        d.start_pump()
        try:
            d.wait_line("short.yaml checked, 2 waypoints", 60.0)
            assert not server.snapshot().armed
            server.set_rc(7, 1900)
            d.wait_line("event=serve_state state=completed", 60.0)
            snap = server.wait_for(secured, 10.0)
        finally:
            d.stop(20.0)
    assert snap.mission_current_seq == 0 and len(snap.mission_items) <= 1
    assert (snap.north_m, snap.east_m) == pytest.approx((4.0, -3.0), abs=0.5)  # y left = west


@pytest.mark.timeout(420)
def test_twenty_flights_keep_memory_and_descriptors_flat(tmp_path: Path) -> None:
    flights = 20
    with sim_with_ground_station(speedup=10.0) as (server, urls, gcs):
        helixd_url = urls[0]
        d = serve_proc(tmp_path, helixd_url, NO_SWITCH)
        d.start_pump()
        pid = d.proc.pid
        samples: list[tuple[int, int]] = []
        try:
            d.wait_line("no mission on the autopilot", 60.0)
            wall.upload(gcs, [(3.0, 0.0), (0.0, 0.0)])  # out and back: every flight the same
            d.wait_line("event=serve_state state=ready", 30.0)
            for _ in range(flights):
                mark = d.mark()
                assert wall.command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
                d.wait_line("event=serve_state state=completed", 60.0, after=mark)
                server.wait_for(secured, 10.0)
                samples.append((rss_kib(pid), open_fds(pid)))
            assert d.ended() is None
        finally:
            d.stop(20.0)
    print(f"\nRSS KiB / open fds after each of {flights} flights: {samples}")
    rss2, fds2 = samples[1]
    for rss, fds in samples[1:]:
        assert abs(rss - rss2) <= 0.10 * rss2, samples
        assert abs(fds - fds2) <= max(1, 0.10 * fds2), samples
    runs = [p for p in (tmp_path / "runs").iterdir() if p.is_dir()]
    assert len(runs) == flights
