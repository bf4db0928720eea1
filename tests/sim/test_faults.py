"""Hostile-telemetry fault injection: the simulator emits NaN/inf/absurd pose values and
backwards time on the wire, for a duration, mid-run or from the moment of arming."""

from __future__ import annotations

import math
from typing import Any

import pytest

from helixd.sim.faults import (
    DURATION_FAULTS,
    HOSTILE_TELEMETRY_FAULTS,
    FaultError,
    make_spec,
    parse_fault,
)
from tests.support.simcore import command, make_core, of_type, run

ARM, FORCE = 400, 21196
SET_MESSAGE_INTERVAL = 511
STREAMED = (30, 32, 65)  # ATTITUDE, LOCAL_POSITION_NED, RC_CHANNELS


def wire(msg: Any) -> Any:
    """The message as the daemon decodes it (NaN/inf survive packing)."""
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    return mav.decode(bytearray(msg.pack(mav)))


def booted() -> Any:
    core = make_core(n_links=1)
    run(core, 2.0)  # booted, EKF origin set: positions flow
    for msg_id in STREAMED:  # at 40 Hz, as helixd asks
        assert command(core, 0, SET_MESSAGE_INTERVAL, msg_id, 25_000) == 0
    run(core, 0.1)
    return core


def test_hostile_faults_are_durational_and_known() -> None:
    assert HOSTILE_TELEMETRY_FAULTS <= DURATION_FAULTS
    for name in HOSTILE_TELEMETRY_FAULTS:
        assert make_spec(name, {"duration_s": 1.0}).kwargs["armed_only"] is False


def test_nan_position_for_a_duration() -> None:
    core = booted()
    core.inject(make_spec("nan_position", {"duration_s": 1.0}))
    out = run(core, 0.9)
    lpn = [wire(m) for m in of_type(out, "LOCAL_POSITION_NED")]
    assert lpn and all(math.isnan(m.x) and math.isnan(m.y) for m in lpn)
    atts = [wire(m) for m in of_type(out, "ATTITUDE")]
    assert atts and all(math.isfinite(m.yaw) for m in atts)  # only the position is hostile
    assert math.isfinite(core.phys.north_m)  # the physics are untouched
    out = run(core, 0.5)  # expired
    assert "nan_position" not in core.faults.active
    assert math.isfinite(wire(of_type(out, "LOCAL_POSITION_NED")[-1]).x)


@pytest.mark.parametrize(
    ("name", "kwargs", "expect"),
    [
        ("nan_yaw", {}, math.isnan),
        ("inf_yaw", {}, lambda y: y == math.inf),
        ("inf_yaw", {"sign": -1.0}, lambda y: y == -math.inf),
    ],
)
def test_hostile_yaw(name: str, kwargs: dict[str, object], expect: Any) -> None:
    core = booted()
    core.inject(make_spec(name, kwargs))
    out = run(core, 0.5)
    atts = [wire(m) for m in of_type(out, "ATTITUDE")]
    assert atts and all(expect(m.yaw) for m in atts)
    lpn = [wire(m) for m in of_type(out, "LOCAL_POSITION_NED")]
    assert lpn and all(math.isfinite(m.x) for m in lpn)
    core.clear_fault(name)
    assert math.isfinite(wire(of_type(run(core, 0.3), "ATTITUDE")[-1]).yaw)


def test_absurd_position() -> None:
    core = booted()
    core.inject(make_spec("absurd_position", {}))
    lpn = [wire(m) for m in of_type(run(core, 0.5), "LOCAL_POSITION_NED")]
    assert lpn and all(m.x == pytest.approx(1e9) and m.y == pytest.approx(1e9) for m in lpn)


def test_time_backwards_steps_every_time_boot_ms_back() -> None:
    core = booted()
    before = [int(m.time_boot_ms) for m in of_type(run(core, 0.3), "ATTITUDE")]
    core.inject(make_spec("time_backwards", {"step_s": 0.5, "duration_s": 1.0}))
    out = run(core, 0.3)
    during = [int(m.time_boot_ms) for m in of_type(out, "ATTITUDE")]
    assert during[0] < before[-1]  # the first one after the fault went back
    assert during[0] == pytest.approx(core.ap.time_boot_ms(core.now_s) - 300 - 500, abs=60)
    for kind in ("LOCAL_POSITION_NED", "RC_CHANNELS"):
        assert all(int(m.time_boot_ms) < before[-1] + 300 for m in of_type(out, kind))
    run(core, 0.8)
    after = [int(m.time_boot_ms) for m in of_type(run(core, 0.2), "ATTITUDE")]
    assert after[-1] == pytest.approx(core.ap.time_boot_ms(core.now_s), abs=60)


def test_armed_only_starts_at_arming() -> None:
    core = booted()
    core.inject(make_spec("nan_position", {"armed_only": True}))
    lpn = [wire(m) for m in of_type(run(core, 0.5), "LOCAL_POSITION_NED")]
    assert lpn and all(math.isfinite(m.x) for m in lpn)  # disarmed: still valid
    assert command(core, 0, ARM, 1, FORCE) == 0
    assert core.ap.armed
    lpn = [wire(m) for m in of_type(run(core, 0.5), "LOCAL_POSITION_NED")]
    assert lpn and all(math.isnan(m.x) for m in lpn)  # from the moment of arming


def test_hostile_fault_specs_parse() -> None:
    spec, at_s = parse_fault("inf_yaw@3:sign=-1,duration_s=2,armed_only=true")
    assert at_s == 3.0 and spec.kwargs["sign"] == -1.0 and spec.kwargs["armed_only"] is True
    spec, _ = parse_fault("time_backwards@1:step_s=0.4")
    assert spec.kwargs["step_s"] == 0.4
    for bad in ("time_backwards@1:step_s=0", "inf_yaw@1:sign=0", "nan_yaw@1:distance_m=3"):
        with pytest.raises(FaultError):
            parse_fault(bad)
