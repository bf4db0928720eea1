"""The crew's steps on real ArduPilot SITL timed from the autopilot's servo outputs: the
QGroundControl-like ground station on SERIAL2, the figures a SITL test prints, and the wall
seconds from a click to the first SERVO_OUTPUT_RAW that shows its effect (one place for the
SITL goto, QGroundControl and guided-item tests)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from helixd.base.frames import ne_to_latlon
from tests.sitl.conftest import (
    AUTOPILOT_COMPID,
    AUTOPILOT_SYSID,
    CONNECT_TIMEOUT_S,
    NEUTRAL_US,
    PORT_STRIDE,
    SERIAL2_PORT,
    SitlVehicle,
    connect_tcp,
    outputs_near,
)
from tests.sitl.test_sitl_serve import HOME_LATLON, GroundStation, serve_proc
from tests.support.daemon import DaemonProc

Pwm = tuple[int, int, int, int]
# wall-clock bounds of the crew's steps at SITL speed-up 1
STATE_WAIT_S = 120.0  # helixd serve reaching a state (connected, no mission, ready)
STEP_WAIT_S = 20.0  # one step's effect: an ACK, a mode, the first driven output
LEG_WAIT_S = 120.0  # a flight to a place
_MODE_GUIDED = 15


def ground_station(sitl: SitlVehicle) -> GroundStation:
    """The QGroundControl-like ground station on this vehicle's SERIAL2 (system 255)."""
    return GroundStation(
        connect_tcp(SERIAL2_PORT + PORT_STRIDE * sitl.instance, CONNECT_TIMEOUT_S, sitl.dead),
        "gcs",
    )


def driven(pwm: Pwm) -> bool:
    """Outputs 1 or 3 off trim: helixd commands the scrolls."""
    return not outputs_near(pwm, NEUTRAL_US)


def at_trim(pwm: Pwm) -> bool:
    return outputs_near(pwm, NEUTRAL_US)


class ServoSteps:
    """Figures noted (and printed as they come, prefixed ``label``) and the time from a step
    to its effect on the servo outputs; ``abort`` says why waiting is no use (the daemon
    ended), as :meth:`DaemonProc.ended`."""

    def __init__(
        self, sitl: SitlVehicle, label: str, wait_s: float, abort: Callable[[], str | None]
    ) -> None:
        self.obs = sitl.obs
        self.label = label
        self.wait_s = wait_s
        self.abort = abort
        self.figures: list[str] = []

    def note(self, what: str, value: float, unit: str = "s") -> None:
        self.figures.append(f"{what}: {value:.2f} {unit}")
        print(f"{self.label}: {what}: {value:.2f} {unit}")

    def after(self, t0: float, ok: Callable[[Pwm], bool], what: str) -> float:
        """Wall seconds from t0 to the first SERVO_OUTPUT_RAW satisfying ``ok``."""
        obs = self.obs

        def found() -> float | None:
            return next((s.wall_s for s in obs.servo if s.wall_s >= t0 and ok(s.pwm_us)), None)

        obs.wait_until(lambda: found() is not None, self.wait_s, what, abort=self.abort)
        at = found()
        assert at is not None
        return at - t0


def set_mode(gcs: GroundStation, mode: int) -> float:
    """Vehicle::setFlightMode → MAV_CMD_DO_SET_MODE to the autopilot, accepted; the monotonic
    time it was sent."""
    sent = time.monotonic()
    assert gcs.set_mode(mode) == mavlink2.MAV_RESULT_ACCEPTED, mode
    return sent


def armed_in_guided(sitl: SitlVehicle, gcs: GroundStation, wait_armed: bool = True) -> None:
    """The first half of QGroundControl's Start Mission on a disarmed rover
    (``APMFirmwarePlugin::startMission``): mode GUIDED, then a normal arm (no force: the Helix
    setup passes every PreArm check; with ``wait_armed`` until the HEARTBEAT says armed)."""
    obs = sitl.obs
    set_mode(gcs, _MODE_GUIDED)
    obs.wait_until(lambda: obs.mode() == _MODE_GUIDED, STEP_WAIT_S, "GUIDED")
    arm = gcs.command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
    assert arm == mavlink2.MAV_RESULT_ACCEPTED, f"a normal arm was refused ({arm})"
    if wait_armed:
        obs.wait_until(lambda: bool(obs.armed()), STEP_WAIT_S, "armed")


def start_mission(sitl: SitlVehicle, gcs: GroundStation, wait_armed: bool = True) -> int:
    """QGroundControl's Start Mission on a disarmed rover: :func:`armed_in_guided`, then
    MAV_CMD_MISSION_START; its result."""
    armed_in_guided(sitl, gcs, wait_armed)
    return int(gcs.command_long(mavlink2.MAV_CMD_MISSION_START, (0.0, 0.0)))


def start_to_driven(sitl: SitlVehicle, gcs: GroundStation, steps: ServoSteps) -> float:
    """QGroundControl's Start Mission (:func:`armed_in_guided`, then MAV_CMD_MISSION_START,
    accepted): wall seconds from MISSION_START to the scrolls driven."""
    armed_in_guided(sitl, gcs)
    t_start = time.monotonic()
    result = gcs.command_long(mavlink2.MAV_CMD_MISSION_START, (0.0, 0.0))
    assert result == mavlink2.MAV_RESULT_ACCEPTED, result
    return steps.after(t_start, driven, "scrolls driven after Start Mission")


def mode_to_outputs(
    gcs: GroundStation, steps: ServoSteps, mode: int, ok: Callable[[Pwm], bool], what: str
) -> float:
    """The mode menu's ``mode`` (:func:`set_mode`): wall seconds to the first servo outputs
    satisfying ``ok`` (``what`` names them)."""
    return steps.after(set_mode(gcs, mode), ok, what)


def go_to_location(gcs: GroundStation, north_m: float, east_m: float) -> float:
    """APMFirmwarePlugin::guidedModeGotoLocation: COMMAND_INT DO_REPOSITION to the autopilot,
    MAV_FRAME_GLOBAL, param1 -1, param2 the change-mode flag, param4 NaN; accepted. The
    monotonic time it was sent."""
    lat, lon = ne_to_latlon(north_m, east_m, *HOME_LATLON)
    with gcs._cond:
        seen = len(gcs.acks)
    flag = float(mavlink2.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE)
    msg = gcs.mav.command_int_encode(
        AUTOPILOT_SYSID, AUTOPILOT_COMPID, mavlink2.MAV_FRAME_GLOBAL,
        mavlink2.MAV_CMD_DO_REPOSITION, 0, 0, -1.0, flag, 0.0, math.nan,
        round(lat * 1e7), round(lon * 1e7), 584.0,
    )  # fmt: skip
    sent = time.monotonic()
    gcs.send(msg)

    def ack() -> int | None:
        return next((r for c, r in gcs.acks[seen:] if c == mavlink2.MAV_CMD_DO_REPOSITION), None)

    result = gcs.wait_value(ack, STEP_WAIT_S, "DO_REPOSITION's COMMAND_ACK")
    assert result == mavlink2.MAV_RESULT_ACCEPTED, result
    return sent


def close_serve(d: DaemonProc, gcs: GroundStation, log_dir: Path) -> None:
    """Stop ``helixd serve``, close the ground station, keep serve.log in ``log_dir``."""
    d.stop(30.0)
    gcs.close()
    (log_dir / "serve.log").write_text(d.log_text(), encoding="utf-8")


@contextmanager
def serving_crew(
    sitl: SitlVehicle, tmp_path: Path, config: dict[str, Any], label: str
) -> Iterator[tuple[GroundStation, ServoSteps, DaemonProc]]:
    """The ground station (:func:`ground_station`), then ``helixd serve`` with ``config``
    (tests.sitl.test_sitl_serve's ``serve_proc``) and the crew's steps (``label``) timed until
    it ends; yields (gcs, steps, d), then :func:`close_serve` with the log in ``tmp_path``."""
    gcs = ground_station(sitl)
    d = serve_proc(tmp_path, sitl, config)
    try:
        yield gcs, ServoSteps(sitl, label, STEP_WAIT_S, d.ended), d
    finally:
        close_serve(d, gcs, tmp_path)


def upload_when_asked(d: DaemonProc, upload: Callable[[], None]) -> None:
    """Once ``helixd serve`` finds no mission on the autopilot: QGroundControl's Plan view
    Upload (``upload``), until helixd is ready to fly it."""
    d.wait_line("no mission on the autopilot", STATE_WAIT_S)
    upload()
    d.wait_line("event=serve_state state=ready", STATE_WAIT_S)
