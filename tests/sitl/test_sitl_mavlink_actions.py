"""QGroundControl's MAVLink Actions reach ``helixd serve`` through real ArduPilot Rover SITL
(opt-in: ``HELIXD_SITL_BIN``); its fly view's own *Change speed* does not.

helixd beats as component 191 of the vehicle's system too (``link.vehicle_component``), so
ArduPilot learns that route (``MAVLink_routing::learn_route``) and forwards what a ground
station addresses to (1, 191). The crew's actions file (config/qgc/helixd-actions.json) is read
as QGroundControl reads it, and each action is sent as ``MavlinkAction::sendTo`` →
``Vehicle::sendMavCommand(compId, …)`` sends it: a COMMAND_LONG to (1, 191), answered by a
COMMAND_ACK from (1, 191). The mission is started as QGroundControl's Start Mission does
(GUIDED, a normal arm, MISSION_START → AUTO). The speed is judged from LOCAL_POSITION_NED.

* QGC's *Change speed* (``APMFirmwarePlugin::guidedModeChangeGroundSpeedMetersSecond``:
  DO_CHANGE_SPEED to the autopilot) is ACCEPTED by ArduPilot and changes nothing helixd does;
* *Helix: slow 0.3 m/s* → ACCEPTED from (1, 191), the rover settles at 0.3 m/s;
* *Helix: mission speed* → back to the mission's 0.6 m/s.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.sitl.conftest import (
    AUTOPILOT_SYSID,
    SitlVehicle,
)
from tests.sitl.test_sitl_qgc import CONFIG, MODE_MANUAL
from tests.sitl.test_sitl_serve import serve_proc
from tests.support import sitl_steps as crew

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(900)]

ACTIONS = Path(__file__).resolve().parents[2] / "config" / "qgc" / "helixd-actions.json"
LONG_LEG_NE_M = [(80.0, 0.0)]  # one straight leg, long enough for three speeds to settle
MISSION_MPS = 0.6  # the plan's cruise (control.max_speed_mps)
SETTLED_MPS = 0.05  # within this of the asked speed over a 2 s window
SETTLE_WAIT_S = 30.0


def test_mavlink_actions_change_helixds_speed(sitl: SitlVehicle, tmp_path: Path) -> None:
    obs = sitl.obs
    gcs = crew.ground_station(sitl)
    actions = json.loads(ACTIONS.read_text(encoding="utf-8"))
    assert (actions["fileType"], actions["version"]) == ("MavlinkActions", 1)
    slow, back = actions["actions"]

    def send_to(comp: int, command: int, params: list[float]) -> int:
        """Vehicle::sendMavCommand(comp, …): COMMAND_LONG to (1, comp); the COMMAND_ACK's
        result from (1, comp)."""
        with gcs._cond:
            seen = len(gcs.acks_from)
        padded = [*params, *([0.0] * (7 - len(params)))]
        gcs.send(gcs.mav.command_long_encode(AUTOPILOT_SYSID, comp, command, 0, *padded))

        def ack() -> int | None:
            return next(
                (r for c, cmd, r in gcs.acks_from[seen:] if (c, cmd) == (comp, command)), None
            )

        result = gcs.wait_value(ack, crew.STEP_WAIT_S, f"COMMAND_ACK from component {comp}")
        return int(result)

    def action(a: dict[str, Any]) -> int:
        params = [float(a.get(f"param{i}", 0.0)) for i in range(1, 8)]
        return send_to(int(a.get("compId", 1)), int(a["mavCmd"]), params)

    def speed_mps(window_s: float = 2.0) -> float | None:
        last = obs.position()
        if last is None:
            return None
        ps = obs.positions_since(last.t_boot_s - window_s)
        if len(ps) < 2 or ps[-1].t_boot_s - ps[0].t_boot_s < 0.5 * window_s:
            return None
        d = math.hypot(ps[-1].north_m - ps[0].north_m, ps[-1].east_m - ps[0].east_m)
        return d / (ps[-1].t_boot_s - ps[0].t_boot_s)

    def settles_at(target_mps: float, what: str) -> float:
        t0 = time.monotonic()

        def near() -> bool:
            v = speed_mps()
            return v is not None and abs(v - target_mps) <= SETTLED_MPS

        obs.wait_until(near, SETTLE_WAIT_S, what, abort=d.ended)
        return time.monotonic() - t0

    figures: list[str] = []
    d = serve_proc(tmp_path, sitl, CONFIG)
    try:
        crew.upload_when_asked(d, lambda: gcs.upload(LONG_LEG_NE_M, 30.0))  # Plan view: Upload
        result = crew.start_mission(sitl, gcs)
        assert result == mavlink2.MAV_RESULT_ACCEPTED, result
        figures.append(f"cruise reached in {settles_at(MISSION_MPS, 'the cruise'):.1f} s")

        # QGC's own Change speed: to the autopilot, which keeps it; helixd drives on
        qgc = send_to(1, mavlink2.MAV_CMD_DO_CHANGE_SPEED, [1.0, 0.3, -1.0])
        assert qgc == mavlink2.MAV_RESULT_ACCEPTED, qgc
        t_qgc = time.monotonic()
        obs.wait_until(lambda: time.monotonic() >= t_qgc + 5.0, 10.0, "5 s after")
        v = speed_mps()
        assert v is not None and abs(v - MISSION_MPS) <= SETTLED_MPS, v
        assert "event=crew_speed" not in d.log_text()

        # the crew's MAVLink Actions: to (1, 191), routed by ArduPilot to helixd
        assert action(slow) == mavlink2.MAV_RESULT_ACCEPTED
        figures.append(f"slow 0.3 settled in {settles_at(float(slow['param2']), 'slow'):.1f} s")
        assert action(back) == mavlink2.MAV_RESULT_ACCEPTED
        figures.append(f"back to 0.6 in {settles_at(MISSION_MPS, 'mission speed'):.1f} s")
        mark = d.mark()
        assert gcs.set_mode(MODE_MANUAL) == mavlink2.MAV_RESULT_ACCEPTED
        d.wait_line("event=rc_override_released", crew.STEP_WAIT_S, after=mark)
    finally:
        crew.close_serve(d, gcs, tmp_path)
    print("MAVLink Actions on SITL: " + "; ".join(figures))
    log = d.log_text()
    assert log.count("event=crew_speed") == 2, log
    assert 'event=crew_speed by="system 255" asked_mps=0.3 speed_mps=0.3' in log
