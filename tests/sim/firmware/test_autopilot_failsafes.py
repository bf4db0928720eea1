"""The simulator's battery and fence failsafes say what ArduPilot Rover says, in its order:
the battery's text, then the mode; the fence's FENCE_STATUS (no text), then the mode; and
SYS_STATUS reports the failed battery and the breached fence afterwards."""

from __future__ import annotations

from typing import Any

from helixd.sim.faults import make_spec
from tests.support.simcore import command, make_core, of_type, run

ARM = 400
READY_S = 10.0  # booted, EKF origin and home set: every PreArm check passes
SET_MESSAGE_INTERVAL = 511
HEARTBEAT, SYS_STATUS = 0, 1
GEOFENCE, BATTERY = 0x100000, 0x2000000
HOLD = 4


def armed(**params: float) -> Any:
    core = make_core(n_links=1, params=params)
    run(core, READY_S)
    for msg_id in (HEARTBEAT, SYS_STATUS):
        assert command(core, 0, SET_MESSAGE_INTERVAL, msg_id, 100_000) == 0
    assert command(core, 0, ARM, 1) == 0  # a normal arm, every PreArm check made
    run(core, 0.3)
    return core


def order(out: list[tuple[int | None, Any]]) -> list[str]:
    """What a GCS sees, in order: texts, FENCE_STATUS and each HEARTBEAT's mode change."""
    seen: list[str] = []
    mode = None
    for _, m in out:
        kind = m.get_type()
        if kind == "STATUSTEXT":
            seen.append(f"text:{m.text}")
        elif kind == "FENCE_STATUS":
            seen.append(f"fence:{m.breach_status}")
        elif kind == "HEARTBEAT" and m.custom_mode != mode:
            mode = m.custom_mode
            seen.append(f"mode:{mode}")
    return seen


def test_battery_low_text_then_hold() -> None:
    core = armed(BATT_FS_LOW_ACT=2)
    run(core, 0.3)
    core.inject(make_spec("battery_low", {}))
    out = core.drain_outbox() + run(core, 0.5)
    seen = order(out)
    text = "text:Battery 1 is low 10.50V used 1234 mAh"
    assert seen[:2] == [text, f"mode:{HOLD}"]  # the text first, then the new mode
    assert core.ap.mode == HOLD and core.ap.armed
    sys = of_type(out, "SYS_STATUS")[-1]
    assert sys.onboard_control_sensors_present & BATTERY
    assert not sys.onboard_control_sensors_health & BATTERY
    # once per level: a second low does nothing, critical (no action by default) says so
    core.inject(make_spec("battery_low", {}))
    core.inject(make_spec("battery_low", {"critical": True, "voltage_v": 9.8}))
    texts = [m.text for m in of_type(run(core, 0.2), "STATUSTEXT")]
    assert texts == ["Battery 1 is critical 9.80V used 1234 mAh"]


def test_battery_low_without_an_action_only_reports() -> None:
    core = armed()  # BATT_FS_LOW_ACT 0, ArduPilot's default
    core.inject(make_spec("battery_low", {}))
    run(core, 0.3)
    assert core.ap.mode == 0


def test_fence_breach_status_then_hold_and_no_text() -> None:
    core = armed(FENCE_ENABLE=1, FENCE_ACTION=2)
    before = of_type(run(core, 0.3), "SYS_STATUS")[-1]
    assert before.onboard_control_sensors_health & GEOFENCE
    core.inject(make_spec("fence_breach", {}))
    out = core.drain_outbox() + run(core, 0.5)
    seen = order(out)
    assert seen[:2] == ["fence:1", f"mode:{HOLD}"]
    assert not [s for s in seen if s.startswith("text:")]
    status = of_type(out, "FENCE_STATUS")[0]
    assert (status.breach_count, status.breach_type) == (1, 3)
    after = of_type(out, "SYS_STATUS")[-1]
    assert after.onboard_control_sensors_present & GEOFENCE
    assert not after.onboard_control_sensors_health & GEOFENCE


def test_no_fence_enabled_no_breach() -> None:
    core = armed()
    core.inject(make_spec("fence_breach", {}))
    out = core.drain_outbox() + run(core, 0.3)
    assert not of_type(out, "FENCE_STATUS") and core.ap.mode == 0
    assert not of_type(out, "SYS_STATUS")[-1].onboard_control_sensors_present & GEOFENCE


def test_fence_action_terminate_disarms() -> None:
    core = armed(FENCE_ENABLE=1, FENCE_ACTION=5)
    core.inject(make_spec("fence_breach", {}))
    run(core, 0.1)
    assert not core.ap.armed
