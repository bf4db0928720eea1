"""Action.set_mission_current (MAV_CMD_DO_SET_MISSION_CURRENT) against the running simulator
over real UDP, and the MISSION_CURRENT the vehicle state keeps from it."""

from __future__ import annotations

import time

import pytest

from helixd.config.link import LinkConfig
from helixd.config.safety import SafetyConfig
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandRejected
from helixd.link.vehicle import Change, VehicleState
from helixd.mav.constants import (
    MAV_CMD_DO_SET_SERVO,
    MAV_CMD_NAV_WAYPOINT,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MISSION_STATE_NO_MISSION,
    MISSION_STATE_NOT_STARTED,
)
from helixd.mav.mission_item import MissionItem
from tests.support.harness import running_sim

WAIT_S = 5.0


def row(seq: int, command: int) -> MissionItem:
    return MissionItem(seq=seq, frame=3, command=command, x=(535_000_000 + seq) / 1e7, y=-113.5)


# 0: home, 1: WP, 2: DO_SET_SERVO, 3: WP, 4: DO_SET_SERVO (no NAV item after it)
MISSION = tuple(
    row(i, c)
    for i, c in enumerate(
        (MAV_CMD_NAV_WAYPOINT, MAV_CMD_NAV_WAYPOINT, MAV_CMD_DO_SET_SERVO, MAV_CMD_NAV_WAYPOINT,
         MAV_CMD_DO_SET_SERVO)
    )
)  # fmt: skip


async def current_after(ap: Autopilot, since_s: float, seq: int) -> VehicleState:
    """Wait for a MISSION_CURRENT read after ``since_s`` that names ``seq``."""

    def holds(state: VehicleState) -> bool:
        mc = state.mission_current
        return mc is not None and mc.rx_monotonic_s > since_s and mc.seq == seq

    assert await ap.telemetry.wait_for(holds, Change.MISSION_CURRENT, WAIT_S), (
        f"no MISSION_CURRENT with seq {seq}: {ap.state.mission_current}"
    )
    return ap.state


async def test_set_mission_current_against_the_simulator() -> None:
    with running_sim(speedup=1.0) as (sim, url):
        ap = await Autopilot.connect(LinkConfig(url=url, command_timeout_s=0.5), SafetyConfig())
        try:
            await ap.wait_heartbeat(10.0)
            granted = await ap.request_streams()
            assert granted["MISSION_CURRENT"] > 0.0  # the simulator grants it, as ArduPilot
            st = await current_after(ap, 0.0, 0)
            assert st.mission_current is not None
            assert (st.mission_current.total, st.mission_current.mission_state) == (
                0,
                MISSION_STATE_NO_MISSION,
            )

            await ap.mission.upload(MISSION, None)
            t0 = time.monotonic()
            await ap.action.set_mission_current(1)
            st = await current_after(ap, t0, 1)
            assert st.mission_current is not None
            assert (st.mission_current.total, st.mission_current.mission_state) == (
                4,
                MISSION_STATE_NOT_STARTED,
            )

            # a DO item: ArduPilot makes the next NAV item current
            t0 = time.monotonic()
            await ap.action.set_mission_current(2)
            await current_after(ap, t0, 3)
            assert sim.snapshot().mission_current_seq == 3

            with pytest.raises(CommandRejected) as denied:
                await ap.action.set_mission_current(5)  # past the end
            assert denied.value.result == MAV_RESULT_DENIED
            with pytest.raises(CommandRejected) as failed:
                await ap.action.set_mission_current(4)  # no NAV item at or after 4
            assert failed.value.result == MAV_RESULT_FAILED
            assert sim.snapshot().mission_current_seq == 0  # ArduPilot is left without one

            t0 = time.monotonic()
            await ap.action.set_mission_current(0)  # 0 means the first item
            await current_after(ap, t0, 1)
            for bad in (-1, 65536, 1.0, True):
                with pytest.raises(ValueError, match=r"0\.\.65535"):
                    await ap.action.set_mission_current(bad)  # type: ignore[arg-type]
        finally:
            await ap.close()
