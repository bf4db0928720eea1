"""``helixd serve`` as a service: it reconnects, survives its own restart with the interrupted
mission remembered, and stays flat in memory and file descriptors over many flights.

Real UDP against the in-process simulator, on the simulated clock (tests.support.simulated):
the service, the simulator and the ground station share one process, whose memory (Python's
live objects, its resident set) and open descriptors the twenty flights measure."""

from __future__ import annotations

import gc
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
from tests.support.gcs import QGC_SYSID
from tests.support.harness import secured
from tests.support.loop_gcs import command, upload
from tests.support.simulated import Steer, moving, simulated_serve

NO_SWITCH: dict[str, Any] = {"startup": {"start_switch_channel": None}}
LOITER = MAV_CMD_NAV_LOITER_UNLIM


def rss_kib() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise AssertionError("no VmRSS")


def open_fds() -> int:
    return len(os.listdir("/proc/self/fd"))


def live_objects() -> int:
    """Python objects alive after a full collection: what a leak of the service's own objects
    (a task, a queue, a flight's records) grows."""
    gc.collect()
    return len(gc.get_objects())


def test_reconnects_when_the_autopilot_comes_goes_and_comes_back(tmp_path: Path) -> None:
    """The autopilot goes silent and boots again, twice (a reboot: no HEARTBEAT for 15 s): the
    service says it is connecting once per loss, not once per attempt, and carries on."""
    fast = {"serve": {"reconnect_initial_s": 0.2, "reconnect_max_s": 1.0}, **NO_SWITCH}

    async def comes_and_goes(st: Steer) -> None:
        await st.line("event=serve_state state=connecting", 30.0)
        for _ in range(2):  # up, down, up again
            mark = st.mark()
            await st.line("no mission on the autopilot", 60.0, after=mark)
            mark = st.mark()
            st.inject("reboot", silent_s=15.0)
            await st.line("event=serve_state state=connecting", 30.0, after=mark)
        await st.line("no mission on the autopilot", 60.0, after=st.mark())
        assert not st.flight_done()
        st.signal(signal.SIGTERM)

    served = simulated_serve(tmp_path, comes_and_goes, fast)
    assert served.code == 0, served.log[-3000:]
    lines = [ln for ln in served.log.splitlines() if "event=serve_state state=connecting" in ln]
    assert len(lines) == 3  # once per change, not once per attempt


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

    async def switch(st: Steer) -> SimSnapshot:
        st.set_rc(7, 1100)
        await st.line("short.yaml checked, 2 waypoints", 60.0)
        await st.until(lambda s: s.home_ne_m is not None, 60.0)  # the autopilot ready to arm
        assert not st.snapshot().armed
        st.set_rc(7, 1900)
        await st.line("event=serve_state state=completed", 60.0)
        snap = await st.until(secured, 10.0)
        st.signal(signal.SIGTERM)
        return snap

    served = simulated_serve(tmp_path, switch, {"serve": {"mission_file": str(mission)}}, links=1)
    assert served.code == 0, served.log[-3000:]
    (snap,) = served.steered
    assert snap.mission_current_seq == 0 and len(snap.mission_items) <= 1
    assert (snap.north_m, snap.east_m) == pytest.approx((4.0, -3.0), abs=0.5)  # y left = west


HISTORY_CAP = 2000


def test_twenty_flights_keep_memory_and_descriptors_flat(tmp_path: Path) -> None:
    flights = 20

    async def day(st: Steer) -> list[tuple[int, int, int]]:
        gcs = st.ground_station(1, QGC_SYSID)
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, [(3.0, 0.0), (0.0, 0.0)])  # out and back: every flight the same
        await st.line("event=serve_state state=ready", 30.0)
        samples = []
        for _ in range(flights):
            mark = st.mark()
            assert await command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
            await st.line("event=serve_state state=completed", 60.0, after=mark)
            await st.until(secured, 10.0)
            samples.append((live_objects(), rss_kib(), open_fds()))
        assert not st.flight_done()
        st.signal(signal.SIGTERM)
        return samples

    # the simulator's record of what happened is capped below one flight's (about 3 200
    # entries), so it stops growing from the first flight on, as the service must
    served = simulated_serve(tmp_path, day, NO_SWITCH, history_max_entries=HISTORY_CAP)
    assert served.code == 0, served.log[-3000:]
    (samples,) = served.steered
    print(f"\nlive objects / RSS KiB / open fds after each of {flights} flights: {samples}")
    objects2, rss2, fds2 = samples[1]
    for objects, rss, fds in samples[1:]:
        assert abs(objects - objects2) <= 0.03 * objects2, samples
        assert abs(rss - rss2) <= 0.02 * rss2, samples
        assert abs(fds - fds2) <= 1, samples
    runs = [p for p in (tmp_path / "runs").iterdir() if p.is_dir()]
    assert len(runs) == flights
