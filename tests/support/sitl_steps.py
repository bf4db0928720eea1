"""The crew's steps on real ArduPilot SITL timed from the autopilot's servo outputs: the
QGroundControl-like ground station on SERIAL2, the figures a SITL test prints, and the wall
seconds from a click to the first SERVO_OUTPUT_RAW that shows its effect (one place for the
SITL goto, QGroundControl and guided-item tests)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from tests.sitl.conftest import (
    CONNECT_TIMEOUT_S,
    NEUTRAL_US,
    PORT_STRIDE,
    SERIAL2_PORT,
    SitlVehicle,
    connect_tcp,
    outputs_near,
)
from tests.sitl.test_sitl_serve import GroundStation
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


def start_mission(sitl: SitlVehicle, gcs: GroundStation, wait_armed: bool = True) -> int:
    """QGroundControl's Start Mission on a disarmed rover (``APMFirmwarePlugin::startMission``):
    mode GUIDED, a normal arm (no force: the Helix setup passes every PreArm check; with
    ``wait_armed`` until the HEARTBEAT says armed), then MAV_CMD_MISSION_START; its result."""
    obs = sitl.obs
    assert gcs.set_mode(_MODE_GUIDED) == mavlink2.MAV_RESULT_ACCEPTED
    obs.wait_until(lambda: obs.mode() == _MODE_GUIDED, STEP_WAIT_S, "GUIDED")
    arm = gcs.command_long(mavlink2.MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
    assert arm == mavlink2.MAV_RESULT_ACCEPTED, f"a normal arm was refused ({arm})"
    if wait_armed:
        obs.wait_until(lambda: bool(obs.armed()), STEP_WAIT_S, "armed")
    return int(gcs.command_long(mavlink2.MAV_CMD_MISSION_START, (0.0, 0.0)))


def close_serve(d: DaemonProc, gcs: GroundStation, log_dir: Path) -> None:
    """Stop ``helixd serve``, close the ground station, keep serve.log in ``log_dir``."""
    d.stop(30.0)
    gcs.close()
    (log_dir / "serve.log").write_text(d.log_text(), encoding="utf-8")


def upload_when_asked(d: DaemonProc, upload: Callable[[], None]) -> None:
    """Once ``helixd serve`` finds no mission on the autopilot: QGroundControl's Plan view
    Upload (``upload``), until helixd is ready to fly it."""
    d.wait_line("no mission on the autopilot", STATE_WAIT_S)
    upload()
    d.wait_line("event=serve_state state=ready", STATE_WAIT_S)
