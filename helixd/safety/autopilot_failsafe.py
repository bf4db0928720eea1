"""Who changed the mode: ArduPilot's own failsafe or a person (pure: no clock, socket or log).

When the autopilot leaves the mode helixd set, either the pilot (mode switch, ground station)
or one of ArduPilot Rover's failsafes did it. ArduPilot never says which in the HEARTBEAT; it
says so beside it, and only in these ways (docs/ardupilot.md, "Failsafes"):

- battery: ``AP_BattMonitor::check_failsafes`` sends "Battery 1 is low 10.50V used 1234 mAh"
  (or "critical"), severity WARNING, then ``Rover::handle_battery_failsafe`` sets the mode
  (``BATT_FS_LOW_ACT`` / ``BATT_FS_CRT_ACT``) in the same call; SYS_STATUS then reports the
  battery sensor unhealthy.
- radio and GCS: ``Rover::failsafe_trigger`` sends "Radio Failsafe" or "GCS Failsafe",
  severity WARNING, clears the overrides and sets ``FS_ACTION``'s mode in the same call; the
  HEARTBEAT's system_status is CRITICAL while it lasts.
- EKF: ``Rover::ekf_check`` sends "EKF variance" and ``failsafe_ekf_event`` "EKF failsafe",
  severity CRITICAL, and sets HOLD (only in modes that need a position, never in MANUAL);
  system_status CRITICAL.
- fence: Rover's ``fence_check`` sends no text: ``AC_Fence::record_breach`` pushes a
  FENCE_STATUS (breach_status 1) and SYS_STATUS reports the geofence unhealthy; the mode
  (``FENCE_ACTION``) is set in the same loop. (Copter and Plane also send "Polygon fence
  breached"; that text is understood too.)

Each of these comes in the same scheduler loop as the mode change, so it is looked for among
what arrived within ``window_s`` before the mode change was seen. A mode change with none of
them is a person's: ``pilot_takeover``.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

from helixd.link.vehicle import StatusText
from helixd.mav.constants import MAV_STATE_CRITICAL, MAV_STATE_EMERGENCY
from helixd.safety.watchdogs import Fault, FaultCause

# ArduPilot's texts, as its source writes them (whole text, so "… Cleared" never matches)
_TEXT_CAUSES: tuple[tuple[re.Pattern[str], FaultCause, str], ...] = (
    (re.compile(r"Battery \d+ is (low|critical)\b.*"), FaultCause.AUTOPILOT_BATTERY, "battery"),
    (re.compile(r"Radio Failsafe"), FaultCause.AUTOPILOT_RADIO, "radio"),
    (re.compile(r"GCS Failsafe"), FaultCause.AUTOPILOT_GCS, "GCS"),
    # "EKF variance" comes first and also in MANUAL, where nothing changes mode: not a cause
    (re.compile(r"EKF failsafe"), FaultCause.AUTOPILOT_EKF, "EKF"),
    (re.compile(r".*\bfences? breached"), FaultCause.AUTOPILOT_FENCE, "fence"),
)

# every cause this module names (for the README's table and the exit code)
AUTOPILOT_CAUSES = frozenset(
    {
        FaultCause.AUTOPILOT_BATTERY,
        FaultCause.AUTOPILOT_FENCE,
        FaultCause.AUTOPILOT_RADIO,
        FaultCause.AUTOPILOT_GCS,
        FaultCause.AUTOPILOT_EKF,
        FaultCause.AUTOPILOT_FAILSAFE,
    }
)


@dataclass(frozen=True, slots=True)
class FailsafeEvidence:
    """What the vehicle state held when the mode change was seen (monotonic seconds)."""

    texts: Sequence[StatusText]  # oldest first, as VehicleState keeps them
    system_status: int  # HEARTBEAT MAV_STATE
    fence_breached: bool | None  # SYS_STATUS geofence bit / FENCE_STATUS; None: no fence
    battery_failsafe: bool | None  # SYS_STATUS battery bit; None: no battery monitor


def classify_mode_change(
    mode: str,
    expected_mode: str,
    evidence: FailsafeEvidence,
    now_s: float,
    window_s: float,
    until_s: float | None = None,
) -> Fault | None:
    """The autopilot failsafe that set ``mode`` (a :class:`Fault` naming it), or None when
    nothing the autopilot reported points at one: then a person changed the mode.

    A failsafe's text counts when it arrived within ``window_s`` before ``now_s``, or after
    it up to ``until_s`` (asked again once more has arrived; None: no bound); the newest such
    text wins. Without a
    text, a breached fence, a failed battery or a CRITICAL/EMERGENCY system status still
    names an autopilot failsafe.
    """
    since_s = now_s - window_s
    for st in reversed(evidence.texts):
        if not st.rx_monotonic_s >= since_s:  # NaN is never recent
            break
        if until_s is not None and st.rx_monotonic_s > until_s:
            continue
        for pattern, cause, what in _TEXT_CAUSES:
            if pattern.fullmatch(st.text):
                return Fault(cause, f'ArduPilot\'s {what} failsafe set {mode} ("{st.text}")')
    if evidence.fence_breached:
        return Fault(
            FaultCause.AUTOPILOT_FENCE,
            f"ArduPilot's fence failsafe set {mode} (its fence reports a breach)",
        )
    if evidence.battery_failsafe:
        return Fault(
            FaultCause.AUTOPILOT_BATTERY,
            f"ArduPilot's battery failsafe set {mode} (SYS_STATUS: battery failsafe)",
        )
    if evidence.system_status in (MAV_STATE_CRITICAL, MAV_STATE_EMERGENCY):
        state = "CRITICAL" if evidence.system_status == MAV_STATE_CRITICAL else "EMERGENCY"
        return Fault(
            FaultCause.AUTOPILOT_FAILSAFE,
            f"ArduPilot's failsafe set {mode} (HEARTBEAT system_status {state}; "
            f"helixd set {expected_mode})",
        )
    return None
