"""``helixd serve``: a change of speed addressed to helixd (MAV_CMD_DO_CHANGE_SPEED to
247/191, as Mission Planner or a script sends it to the selected component) changes the
cruise of the flight in progress, within its limits; judged on the simulator's true speed.

One sent to the autopilot (QGroundControl's fly view) cannot reach helixd: ArduPilot keeps it
in its own navigator, forwards it nowhere and reports it in no message (docs/ardupilot.md).
QGroundControl's MAVLink Actions (config/qgc/helixd-actions.json) address a component of the
vehicle: helixd's component 191 of system 1, which the autopilot routes to helixd because
helixd beats as that component too (``link.vehicle_component``).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from helixd.config.control import ControlConfig
from helixd.mav.constants import (
    MAV_CMD_DO_CHANGE_SPEED,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
)
from tests.support.loop_gcs import booted, command, simulated_crew, upload
from tests.support.loop_mav import LoopMav
from tests.support.simulated import Steer, moving

LONG_LEG = [(60.0, 0.0)]  # one straight leg, long enough to see both speeds settle (m)
SLOW_MPS = 0.2
MISSION_MPS = float(ControlConfig.model_fields["max_speed_mps"].default)  # the plan's cruise
CONFIG = {"startup": {"start_switch_channel": None}}
ACTIONS = Path(__file__).resolve().parents[2] / "config" / "qgc" / "helixd-actions.json"


async def mavlink_action(gcs: LoopMav, action: dict[str, Any]) -> int:
    """QGroundControl's MavlinkAction::sendTo → Vehicle::sendMavCommand(compId, …): a
    COMMAND_LONG to the vehicle's system (1) and the action's component; the result of the
    COMMAND_ACK from that component (QGC matches the ACK by the component it addressed)."""
    comp = int(action.get("compId", 1))
    params = [float(action.get(f"param{i}", 0.0)) for i in range(1, 8)]
    gcs.heartbeat()
    return await gcs.command(int(action["mavCmd"]), *params, target=(1, comp))


def test_a_change_of_speed_to_helixd_changes_the_flights_cruise(tmp_path: Path) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> None:
        await st.line("no mission on the autopilot", 60.0)
        await upload(gcs, LONG_LEG)
        await st.line("event=serve_state state=ready", 30.0)
        await booted(st, gcs)
        # not flying: nothing to change (each flight starts at the mission's speed)
        assert await command(gcs, MAV_CMD_DO_CHANGE_SPEED, 1, SLOW_MPS) == MAV_RESULT_DENIED
        assert await command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        await st.until(lambda s: moving(s) and s.speed_mps > 0.4, 60.0)

        async def settled_at(target_mps: float) -> bool:
            snap = await st.until(lambda s: s.armed and abs(s.speed_mps - target_mps) < 0.05, 30.0)
            return snap.armed

        change = MAV_CMD_DO_CHANGE_SPEED
        assert await command(gcs, change, 1, SLOW_MPS, -1) == MAV_RESULT_ACCEPTED
        assert await gcs.wait_text("helixd: speed 0.20 m/s", 20.0) == "helixd: speed 0.20 m/s"
        assert await settled_at(SLOW_MPS)
        # -1 is Rover's "no change": FAILED, and the speed stays
        assert await command(gcs, change, 1, -1) == MAV_RESULT_FAILED
        slow = st.snapshot()
        assert abs(slow.speed_mps - SLOW_MPS) < 0.05, slow.speed_mps
        # faster than the mission: bounded by its speed (its stops are planned for it)
        assert await command(gcs, change, 1, 9.0) == MAV_RESULT_ACCEPTED
        # (a text longer than a STATUSTEXT goes out as lines split between words)
        said = await gcs.wait_text(f"helixd: speed {MISSION_MPS:.2f} m/s (9 asked", 20.0)
        assert said.endswith("bounded by the"), said
        assert await settled_at(MISSION_MPS)
        # QGroundControl's MAVLink Actions, as the crew's file defines them
        slow_action, back = json.loads(ACTIONS.read_text(encoding="utf-8"))["actions"]
        assert await mavlink_action(gcs, slow_action) == MAV_RESULT_ACCEPTED
        assert await settled_at(float(slow_action["param2"]))
        assert await mavlink_action(gcs, back) == MAV_RESULT_ACCEPTED
        assert await settled_at(MISSION_MPS)
        await st.line("event=serve_state state=completed", 120.0)

    served = simulated_crew(tmp_path, CONFIG, crew)
    assert served.code == 0, served.log[-3000:]
    log = served.log
    assert 'event=crew_speed by="system 255" asked_mps=0.2 speed_mps=0.2' in log, log
