"""ArduPilot Rover's own failsafes mid-mission on real SITL, named by helixd (opt-in:
``HELIXD_SITL_BIN``).

Injected as ArduPilot's autotest injects them, from the observer's link:

* battery: ``BATT_FS_LOW_ACT 2`` (Rover: Hold), ``BATT_LOW_VOLT`` above what the simulated
  battery then reads (``SIM_BATT_VOLTAGE``), ``BATT_LOW_TIMER 1`` (the firmware default is
  10 s: the voltage must stay low that long). Rover says "Battery 1 is low …" and sets HOLD.
* fence: a circle fence round home (``FENCE_TYPE 2``, ``FENCE_RADIUS``) with ``FENCE_ACTION
  2`` (Rover: Hold), enabled (``FENCE_ENABLE 1``) once the rover is beyond its radius on the
  square's first leg. Rover's fence check (10 Hz) sees the breach and sets HOLD.

helixd sees a mode it did not set; what the autopilot reported around it names the cause
(``autopilot_battery`` / ``autopilot_fence``, exit 4). helixd then releases its overrides:
the scroll outputs (RC passthrough) go to trim. The battery's text can reach helixd after the
HEARTBEAT that shows HOLD: the fall-back then starts as ``pilot_takeover`` and the run's
result is renamed once the text is in (``fault_renamed``); the result's cause is checked.
Printed: the time from injection to HOLD, from injection and from HOLD to neutral outputs, the
distance driven after injection, and the cause helixd reported.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.exitcodes import ExitCode
from tests.sitl import test_sitl_gps as gps  # the same bounds and checks as the GPS fault

if TYPE_CHECKING:
    from tests.sitl.conftest import DaemonRun, SitlVehicle

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(900)]

STATUS_STREAM_HZ = 5.0  # SYS_STATUS (battery) and FENCE_STATUS to the observer
ROVER_ACTION_HOLD = 2  # BATT_FS_LOW_ACT / FENCE_ACTION on Rover: 2 = Hold
BATT_LOW_VOLT_V = 11.0
SIM_BATT_LOW_V = 10.5  # below BATT_LOW_VOLT (SITL's battery reads 12.6 V)
BATT_LOW_TIMER_S = 1.0
FENCE_TYPE_CIRCLE = 2
FENCE_RADIUS_M = 6.0  # the square's first leg is 10 m long, from home
OUTSIDE_FENCE_M = FENCE_RADIUS_M + 1.0
BATTERY_FAILSAFE = {  # the autopilot's battery failsafe: Hold after 1 s below 11 V
    "BATT_FS_LOW_ACT": float(ROVER_ACTION_HOLD),
    "BATT_LOW_TIMER": BATT_LOW_TIMER_S,
    "BATT_LOW_VOLT": BATT_LOW_VOLT_V,
}
FENCE_FAILSAFE = {  # the autopilot's circular fence round home: Hold on a breach
    "FENCE_TYPE": float(FENCE_TYPE_CIRCLE),
    "FENCE_RADIUS": FENCE_RADIUS_M,
    "FENCE_ACTION": float(ROVER_ACTION_HOLD),
}
AUTOPILOT_ACTION_S = 5.0  # injection → ArduPilot's HOLD (the battery's 1 s timer included)


@dataclass(frozen=True, slots=True)
class Stopped:
    hold_s: float  # injection → HOLD (ArduPilot's failsafe)
    neutral_s: float  # injection → outputs 1 and 3 at trim (helixd's release)
    after_m: float  # driven after injection (EKF)
    cause: str  # the run's result (after a late failsafe text renamed the fall-back's)
    detected: str  # the fall-back's cause at detection
    code: int | None
    log: str


def stopped_after(sitl: SitlVehicle, daemon: DaemonRun, inject: Callable[[], None]) -> Stopped:
    """Inject, then time ArduPilot's HOLD and helixd's neutral outputs, and read its cause."""
    obs = sitl.obs
    before = obs.position()
    assert before is not None
    inject()  # confirmed by its PARAM_VALUE echo
    t0 = time.monotonic()
    obs.wait_until(lambda: obs.mode() == gps.MODE_HOLD, AUTOPILOT_ACTION_S + 10.0, "HOLD")
    hold_s = next(t for t, m in obs.mode_changes if t >= t0 and m == gps.MODE_HOLD) - t0
    obs.wait_until(
        lambda: any(s.wall_s >= t0 + hold_s and gps.neutral(s.pwm_us) for s in obs.servo[-50:]),
        gps.STOP_WITHIN_S + gps.LINK_SLACK_S + 5.0,
        "outputs 1 and 3 at trim after HOLD",
    )
    neutral_s = (
        next(s.wall_s for s in obs.servo if s.wall_s >= t0 + hold_s and gps.neutral(s.pwm_us)) - t0
    )
    code = daemon.wait_exit(gps.EXIT_S)
    log = daemon.log_text()
    time.sleep(gps.SETTLE_S)  # the rover coasts; the distance is taken after it stopped
    track = [p for p in obs.positions if p.t_boot_s >= before.t_boot_s]
    last = track[-1] if track else before
    after_m = math.hypot(last.north_m - before.north_m, last.east_m - before.east_m)
    detected = next(
        (w.split("=", 1)[1] for w in log.split() if w.startswith("cause=")), "none reported"
    )
    result = next((line for line in log.splitlines() if "event=result " in line), "")
    cause = result.partition(' fault="')[2].partition(":")[0] or "none reported"
    return Stopped(hold_s, neutral_s, after_m, cause, detected, code, log)


def stopped_by(what: str, sitl: SitlVehicle, r: Stopped, cause: str) -> None:
    """Print the figures of ``what``; helixd ended in a fault named ``cause`` and its outputs
    were neutral within the GPS test's bound of the autopilot's HOLD."""
    print(
        f"{what}: HOLD {r.hold_s:.2f} s, neutral outputs {r.neutral_s:.2f} s after injection "
        f"({r.neutral_s - r.hold_s:.2f} s after HOLD; wall, speedup {sitl.speedup}); "
        f"{r.after_m:.2f} m driven after it (EKF); cause {r.cause} (at detection {r.detected})"
    )
    assert r.code == ExitCode.FAULT, r.log[-4000:]
    assert r.cause == cause, r.log[-4000:]
    assert r.neutral_s - r.hold_s <= gps.STOP_WITHIN_S + gps.LINK_SLACK_S


def driving_with(
    sitl: SitlVehicle,
    launch_helixd: Callable[..., DaemonRun],
    failsafe: dict[str, float],
    status_msg_id: int,
    min_distance_m: float,
) -> DaemonRun:
    """The autopilot's failsafe set by the parameters ``failsafe``, its status message
    (``status_msg_id``) streamed at STATUS_STREAM_HZ; then helixd (rc_override) launched,
    until it has driven ``min_distance_m``."""
    obs = sitl.obs
    for name, value in failsafe.items():
        obs.set_param(name, value)
    obs.set_message_interval(int(status_msg_id), STATUS_STREAM_HZ)
    daemon = launch_helixd("rc_override")
    sitl.wait_driving(daemon, min_distance_m=min_distance_m, timeout_s=gps.DRIVING_TIMEOUT_S)
    return daemon


def test_battery_failsafe_is_named(
    sitl: SitlVehicle, launch_helixd: Callable[..., DaemonRun]
) -> None:
    obs = sitl.obs
    status = mavlink.MAVLINK_MSG_ID_SYS_STATUS
    daemon = driving_with(sitl, launch_helixd, BATTERY_FAILSAFE, status, 2.0)

    r = stopped_after(sitl, daemon, lambda: obs.set_param("SIM_BATT_VOLTAGE", SIM_BATT_LOW_V))
    texts = [t for t in obs.statustexts if "attery" in t]
    what = (
        f"battery failsafe (SIM_BATT_VOLTAGE {SIM_BATT_LOW_V} < BATT_LOW_VOLT {BATT_LOW_VOLT_V}, "
        f"BATT_LOW_TIMER {BATT_LOW_TIMER_S:g} s, BATT_FS_LOW_ACT Hold; {texts[-1:]})"
    )
    stopped_by(what, sitl, r, "autopilot_battery")


def test_fence_failsafe_is_named(
    sitl: SitlVehicle, launch_helixd: Callable[..., DaemonRun]
) -> None:
    obs = sitl.obs
    status = mavlink.MAVLINK_MSG_ID_FENCE_STATUS
    daemon = driving_with(sitl, launch_helixd, FENCE_FAILSAFE, status, OUTSIDE_FENCE_M)

    r = stopped_after(sitl, daemon, lambda: obs.set_param("FENCE_ENABLE", 1.0))
    fence = obs.latest.get("FENCE_STATUS")
    breach = "none" if fence is None else f"breach_status {fence.breach_status}"
    what = (
        f"fence failsafe (circle {FENCE_RADIUS_M:g} m round home enabled {OUTSIDE_FENCE_M:g} m "
        f"out, FENCE_ACTION Hold; FENCE_STATUS {breach})"
    )
    stopped_by(what, sitl, r, "autopilot_fence")
