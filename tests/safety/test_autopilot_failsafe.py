"""A mode change names what made it: ArduPilot's own failsafe, from what the autopilot sent
around it (its real texts, SYS_STATUS bits, FENCE_STATUS, HEARTBEAT system_status), or a
person (pilot_takeover). Pure: the vehicle state is fed decoded messages.

Before: every failsafe of ArduPilot that set HOLD ended the run as
``stopped pilot_takeover: mode changed to HOLD`` (exit 5, an operator's stop)."""

from __future__ import annotations

from typing import Any

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.base.frames import NedPose
from helixd.config.safety import SafetyConfig
from helixd.link.vehicle import SENSOR_BATTERY, SENSOR_GEOFENCE, StatusText, VehicleState
from helixd.runtime.ending import ending_of_flight
from helixd.runtime.flight import FlightResult
from helixd.safety.autopilot_failsafe import (
    AUTOPILOT_CAUSES,
    FailsafeEvidence,
    classify_mode_change,
)
from helixd.safety.supervisor import Motion, Supervisor, failsafe_evidence, late_failsafe
from helixd.safety.watchdogs import OPERATOR_CAUSES, Fault, FaultCause
from tests.support.mavmsgs import AP, att, decoded, hb, lpn

HOLD, MANUAL = 4, 0
WARNING, CRITICAL, NOTICE = 4, 2, 5
MOTION = Motion(0.5, 0.0, 0.0, 10.0)
BASE_SENSORS = 0x1 | 0x2 | 0x4


def evidence(
    *texts: tuple[float, int, str],
    system_status: int = 4,
    fence: bool | None = None,
    battery: bool | None = None,
) -> FailsafeEvidence:
    return FailsafeEvidence(
        texts=[StatusText(sev, text, rx) for rx, sev, text in texts],
        system_status=system_status,
        fence_breached=fence,
        battery_failsafe=battery,
    )


# ArduPilot's texts as its source formats them (AP_BattMonitor::check_failsafes,
# Rover::failsafe_trigger, Rover::ekf_check / failsafe_ekf_event, AC_Fence::print_fence_message)
@pytest.mark.parametrize(
    ("severity", "text", "cause"),
    [
        (WARNING, "Battery 1 is low 10.50V used 1234 mAh", FaultCause.AUTOPILOT_BATTERY),
        (WARNING, "Battery 2 is critical 9.80V used 2200 mAh", FaultCause.AUTOPILOT_BATTERY),
        (WARNING, "Radio Failsafe", FaultCause.AUTOPILOT_RADIO),
        (WARNING, "GCS Failsafe", FaultCause.AUTOPILOT_GCS),
        (CRITICAL, "EKF failsafe", FaultCause.AUTOPILOT_EKF),
        (NOTICE, "Polygon fence breached", FaultCause.AUTOPILOT_FENCE),
        (NOTICE, "Circle and Polygon fences breached", FaultCause.AUTOPILOT_FENCE),
    ],
)
def test_each_failsafe_text_names_its_cause(severity: int, text: str, cause: FaultCause) -> None:
    fault = classify_mode_change("HOLD", "MANUAL", evidence((9.9, severity, text)), 10.0, 2.0)
    assert fault is not None and fault.cause is cause
    assert fault.detail.endswith(f'set HOLD ("{text}")') and "ArduPilot's" in fault.detail


def test_battery_line_reads_as_the_operator_sees_it() -> None:
    fault = classify_mode_change(
        "HOLD",
        "MANUAL",
        evidence((9.9, WARNING, "Battery 1 is low 10.50V used 1234 mAh")),
        10.0,
        2.0,
    )
    assert fault is not None
    assert f"{fault.cause.value}: {fault.detail}" == (
        "autopilot_battery: ArduPilot's battery failsafe set HOLD "
        '("Battery 1 is low 10.50V used 1234 mAh")'
    )


@pytest.mark.parametrize(
    "text",
    [
        "Radio Failsafe Cleared",  # a failsafe that ended is no reason for a new mode
        "GCS Failsafe Cleared",
        "EKF failsafe cleared",
        "EKF variance",  # sent in MANUAL too, where the EKF failsafe changes no mode
        "Failsafe - Continuing Auto Mode",
        "PreArm: Battery 1 low voltage failsafe",
        "helixd: Radio Failsafe",  # not ArduPilot's whole text
    ],
)
def test_other_texts_are_no_failsafe(text: str) -> None:
    assert classify_mode_change("HOLD", "MANUAL", evidence((9.9, WARNING, text)), 10.0, 2.0) is None


def test_a_text_older_than_the_window_is_a_person_s_mode_change() -> None:
    old = evidence((7.9, WARNING, "Battery 1 is low 10.50V used 1234 mAh"))
    assert classify_mode_change("HOLD", "MANUAL", old, 10.0, 2.0) is None
    assert classify_mode_change("HOLD", "MANUAL", old, 9.8, 2.0) is not None


def test_the_newest_failsafe_text_wins() -> None:
    ev = evidence(
        (9.0, WARNING, "Battery 1 is low 10.50V used 1234 mAh"), (9.5, WARNING, "GCS Failsafe")
    )
    fault = classify_mode_change("HOLD", "MANUAL", ev, 10.0, 2.0)
    assert fault is not None and fault.cause is FaultCause.AUTOPILOT_GCS


def test_without_a_text_the_fence_bit_names_the_fence() -> None:
    """Rover's fence_check sends no text: the breach shows in FENCE_STATUS and SYS_STATUS."""
    fault = classify_mode_change("HOLD", "MANUAL", evidence(fence=True), 10.0, 2.0)
    assert fault is not None and fault.cause is FaultCause.AUTOPILOT_FENCE
    assert "fence" in fault.detail and "HOLD" in fault.detail
    assert classify_mode_change("HOLD", "MANUAL", evidence(fence=False), 10.0, 2.0) is None


def test_without_a_text_the_battery_bit_and_critical_state_name_a_failsafe() -> None:
    fault = classify_mode_change("HOLD", "MANUAL", evidence(battery=True), 10.0, 2.0)
    assert fault is not None and fault.cause is FaultCause.AUTOPILOT_BATTERY
    fault = classify_mode_change("HOLD", "MANUAL", evidence(system_status=5), 10.0, 2.0)
    assert fault is not None and fault.cause is FaultCause.AUTOPILOT_FAILSAFE
    assert "CRITICAL" in fault.detail
    assert classify_mode_change("HOLD", "MANUAL", evidence(system_status=3), 10.0, 2.0) is None


def test_every_autopilot_cause_is_a_fault_not_an_operator_stop() -> None:
    assert not AUTOPILOT_CAUSES & OPERATOR_CAUSES
    for cause in AUTOPILOT_CAUSES:
        ending = ending_of_flight(FlightResult(Fault(cause, "x"), 10.0, None, None))
        assert ending.code is ExitCode.FAULT, cause


# -- through the vehicle state and the supervisor ---------------------------------------------


def sys_status(sensors: int, unhealthy: int = 0) -> Any:
    return decoded(
        AP.sys_status_encode(
            sensors, sensors, sensors & ~unhealthy, 100, 12000, -1, -1, 0, 0, 0, 0, 0, 0
        ),
        AP,
    )


def statustext(severity: int, text: str) -> Any:
    return decoded(AP.statustext_encode(severity, text.encode()), AP)


def flying() -> VehicleState:
    st = VehicleState()
    st.apply(hb(MANUAL, armed=True), 1.0)
    st.apply(decoded(AP.ekf_status_report_encode(0x3F, 0.1, 0.1, 0.1, 0.05, 0.0), AP), 1.0)
    st.apply(decoded(AP.gps_raw_int_encode(0, 3, 0, 0, 0, 100, 100, 0, 0, 10), AP), 1.0)
    st.apply(att(1000, 0.3), 1.0)
    st.apply(lpn(1000, 3.0, 4.0), 1.0)
    return st


def check(st: VehicleState, now_s: float, cfg: SafetyConfig | None = None) -> Any:
    sup = Supervisor(cfg or SafetyConfig(geofence_radius_m=None), NedPose(3.0, 4.0, 0.0), "MANUAL")
    return sup.check(now_s, st, st.pose, MOTION)


def test_battery_failsafe_through_the_supervisor() -> None:
    st = flying()
    st.apply(statustext(WARNING, "Battery 1 is low 10.50V used 1234 mAh"), 1.05)
    st.apply(hb(HOLD, armed=True), 1.1)
    fault = check(st, 1.12)
    assert fault.cause is FaultCause.AUTOPILOT_BATTERY and "Battery 1 is low" in fault.detail


def test_a_person_s_hold_is_still_a_takeover() -> None:
    st = flying()
    st.apply(hb(HOLD, armed=True), 1.1)
    fault = check(st, 1.12)
    assert fault.cause is FaultCause.PILOT_TAKEOVER and "mode changed to HOLD" in fault.detail


def test_fence_breach_from_sys_status_and_fence_status() -> None:
    st = flying()
    st.apply(sys_status(BASE_SENSORS | SENSOR_GEOFENCE), 1.02)
    assert st.fence_breached is False and failsafe_evidence(st).fence_breached is False
    st.apply(decoded(AP.fence_status_encode(1, 1, 3, 1100), AP), 1.05)  # pushed on the breach
    assert st.fence_breached is True and st.fence_breach_rx_s == 1.05
    st.apply(hb(HOLD, armed=True), 1.1)
    assert check(st, 1.12).cause is FaultCause.AUTOPILOT_FENCE
    st.apply(sys_status(BASE_SENSORS | SENSOR_GEOFENCE, unhealthy=SENSOR_GEOFENCE), 1.2)
    assert st.fence_breached is True
    st.apply(sys_status(BASE_SENSORS), 1.3)  # no fence enabled
    assert st.fence_breached is None


def test_battery_bit_of_sys_status() -> None:
    st = flying()
    st.apply(sys_status(BASE_SENSORS | SENSOR_BATTERY), 1.0)
    assert st.battery_failsafe is False
    st.apply(sys_status(BASE_SENSORS | SENSOR_BATTERY, unhealthy=SENSOR_BATTERY), 1.05)
    assert st.battery_failsafe is True


def test_a_failsafe_ends_the_flight_even_without_mode_change_takeover() -> None:
    cfg = SafetyConfig.model_validate(
        {"geofence_radius_m": None, "takeover": {"on_mode_change": False}}
    )
    st = flying()
    st.apply(hb(HOLD, armed=True), 1.1)
    assert check(st, 1.12, cfg) is None  # a person's mode change: the config says go on
    st.apply(statustext(WARNING, "GCS Failsafe"), 1.15)
    assert check(st, 1.16, cfg).cause is FaultCause.AUTOPILOT_GCS


def test_a_text_after_the_mode_change_renames_the_takeover_after_the_fall_back() -> None:
    """The HEARTBEAT with HOLD came first, the text 80 ms later: detection said takeover
    (the fall-back does not wait), asking again afterwards names the failsafe."""
    st = flying()
    st.apply(hb(HOLD, armed=True), 1.1)
    takeover = check(st, 1.12)
    assert takeover.cause is FaultCause.PILOT_TAKEOVER and takeover.changed_mode == "HOLD"
    assert takeover.mode_change == ("HOLD", "MANUAL")
    assert late_failsafe(takeover, 1.12, st, 2.0) is None  # nothing more arrived
    st.apply(statustext(WARNING, "Radio Failsafe"), 1.2)
    named = late_failsafe(takeover, 1.12, st, 2.0)
    assert named is not None and named.cause is FaultCause.AUTOPILOT_RADIO
    assert named.detail == 'ArduPilot\'s radio failsafe set HOLD ("Radio Failsafe")'


def test_a_text_long_after_the_fall_back_does_not_rename() -> None:
    st = flying()
    st.apply(hb(HOLD, armed=True), 1.1)
    takeover = check(st, 1.12)
    st.apply(statustext(WARNING, "GCS Failsafe"), 1.12 + 2.5)  # the pilot's HOLD, then later
    assert late_failsafe(takeover, 1.12, st, 2.0) is None


def test_only_a_takeover_by_mode_change_is_renamed() -> None:
    st = flying()
    st.apply(statustext(WARNING, "GCS Failsafe"), 1.05)
    switch = Fault(FaultCause.PILOT_TAKEOVER, "takeover switch RC7 at 1900 µs (>= 1700 µs)")
    assert switch.changed_mode is None and late_failsafe(switch, 1.1, st, 2.0) is None
    assert late_failsafe(Fault(FaultCause.STALL, "x"), 1.1, st, 2.0) is None
    assert late_failsafe(None, 1.1, st, 2.0) is None
