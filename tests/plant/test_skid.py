"""The ``sitl_skid`` plant: ArduPilot SITL's rover-skid model (libraries/SITL/SIM_Rover.cpp).

Expected numbers are derived by hand from SIM_Rover.cpp's equations:
motor = 2·((pwm − 1000)/1000 − 0.5); steering = m1 − m2 (m1 = output 1 = left, m2 = output 3 =
right); throttle = ½(m1 + m2); yaw rate = steering · 140 °/s (clockwise positive);
target speed = throttle · 4 m/s; accel = 14 · (target − speed)/4 (time constant 4/14 s).
"""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st
from pydantic import ValidationError

from helixd.plant import skid
from helixd.plant.plant_config import Plant, PlantConfig
from helixd.plant.state import PhysicsState
from tests.support import simcore
from tests.support.cli import main_exit
from tests.support.simcore import EmbeddedStart, capture_embedded_start

MODEL = PlantConfig().skid
DT_S = 0.02  # the simulator's 50 Hz loop (SCHED_LOOP_RATE)
TAU_S = 4.0 / 14.0  # max_speed / max_accel


def run(
    state: PhysicsState, left_us: int, right_us: int, seconds: float, stalled: bool = False
) -> PhysicsState:
    for _ in range(round(seconds / DT_S)):
        state = skid.step(
            state,
            DT_S,
            left_us,
            right_us,
            max_speed_mps=MODEL.max_speed_mps,
            max_accel_mss=MODEL.max_accel_mss,
            turn_rate_dps=MODEL.turn_rate_dps,
            max_yaw_rate_dps=MODEL.max_yaw_rate_dps,
            physics_rate_hz=MODEL.physics_rate_hz,
            stalled=stalled,
        )
    return state


def test_defaults_are_sim_rover_skid_constants() -> None:
    assert (MODEL.max_speed_mps, MODEL.max_accel_mss, MODEL.turn_rate_dps) == (4.0, 14.0, 140.0)
    assert MODEL.max_yaw_rate_dps == 360.0 and MODEL.physics_rate_hz == 1200.0
    assert PlantConfig().plant is Plant.HELIX  # the Helix stays the default plant


@pytest.mark.parametrize(
    ("pwm_us", "motor"), [(1000, -1.0), (1250, -0.5), (1500, 0.0), (1750, 0.5), (2000, 1.0)]
)
def test_motor_command_is_linear_1000_to_2000(pwm_us: int, motor: float) -> None:
    assert skid.motor_command(pwm_us) == pytest.approx(motor)


def test_no_pulses_is_a_stopped_motor() -> None:
    assert skid.motor_command(0) == 0.0
    state = run(PhysicsState(), 0, 0, 2.0)
    assert state.north_m == state.east_m == state.yaw_ned_rad == 0.0


@pytest.mark.parametrize(
    ("left_us", "right_us", "speed_mps", "yaw_rate_dps"),
    [
        (1750, 1750, 2.0, 0.0),  # m = 0.5, 0.5: throttle 0.5 → 2 m/s, steering 0
        (2000, 2000, 4.0, 0.0),  # full forward: max_speed
        (1600, 1400, 0.0, 56.0),  # m = 0.2, −0.2: steering 0.4 → 56 °/s, throttle 0
        (1700, 1500, 0.8, 56.0),  # m = 0.4, 0: throttle 0.2 → 0.8 m/s, steering 0.4
        (1500, 1700, 0.8, -56.0),  # right motor faster: counter-clockwise
        (1250, 1250, -2.0, 0.0),  # reverse
    ],
)
def test_steady_state_speed_and_turn_rate(
    left_us: int, right_us: int, speed_mps: float, yaw_rate_dps: float
) -> None:
    state = run(PhysicsState(), left_us, right_us, 10 * TAU_S)
    assert state.vx_body_mps == pytest.approx(speed_mps, abs=1e-3)
    assert state.yaw_rate_ned_radps == pytest.approx(math.radians(yaw_rate_dps), abs=1e-9)
    assert state.speed_mps == pytest.approx(abs(speed_mps), abs=1e-3)  # no side slip


def test_speed_lags_with_time_constant_max_speed_over_max_accel() -> None:
    state = run(PhysicsState(), 2000, 2000, 0.3)  # ≈ 1.05 τ: 4·(1 − e^(−0.3/τ))
    assert state.vx_body_mps == pytest.approx(4.0 * (1.0 - math.exp(-0.3 / TAU_S)), rel=2e-3)


def test_equal_outputs_drive_a_straight_line_along_the_heading() -> None:
    start = PhysicsState(yaw_ned_rad=math.radians(30.0))
    state = run(start, 1800, 1800, 5.0)
    assert state.yaw_ned_rad == pytest.approx(math.radians(30.0), abs=1e-12)
    assert math.atan2(state.east_m, state.north_m) == pytest.approx(math.radians(30.0), abs=1e-9)
    # 2.4 m/s target, lag τ: distance = v·(t − τ(1 − e^(−t/τ)))
    expected_m = 2.4 * (5.0 - TAU_S * (1.0 - math.exp(-5.0 / TAU_S)))
    assert math.hypot(state.north_m, state.east_m) == pytest.approx(expected_m, rel=2e-3)
    assert state.odometer_m == pytest.approx(expected_m, rel=2e-3)


def test_left_motor_faster_turns_clockwise_in_ned() -> None:
    """Facing North, left motor faster: the yaw grows (clockwise) and the rover veers East."""
    state = run(PhysicsState(), 1700, 1500, 1.0)
    assert state.yaw_ned_rad == pytest.approx(math.radians(56.0), abs=1e-9)
    assert state.wz_body_radps < 0.0  # PhysicsState's body rate is counter-clockwise positive
    assert state.east_m > 0.05 and state.north_m > 0.0


def test_turn_in_place_and_a_circle_of_radius_v_over_omega() -> None:
    spin = run(PhysicsState(), 1600, 1400, 2.0)
    assert math.hypot(spin.north_m, spin.east_m) < 1e-9
    assert spin.yaw_ned_rad == pytest.approx(math.radians(112.0), abs=1e-9)
    # 0.8 m/s at 56 °/s: radius 0.8 / 0.977 = 0.819 m; once settled, points lie on the circle
    # whose centre is one radius to the right of a point, perpendicular to its heading
    state = run(PhysicsState(), 1700, 1500, 3.0)
    radius = 0.8 / math.radians(56.0)
    cn = state.north_m + radius * math.cos(state.yaw_ned_rad + math.pi / 2)
    ce = state.east_m + radius * math.sin(state.yaw_ned_rad + math.pi / 2)
    later = run(state, 1700, 1500, 2.0)
    assert math.hypot(later.north_m - cn, later.east_m - ce) == pytest.approx(radius, rel=1e-2)


def test_stops_at_1500_1500() -> None:
    moving = run(PhysicsState(), 1900, 1800, 3.0)
    assert moving.speed_mps > 2.0
    stopped = run(moving, 1500, 1500, 10 * TAU_S)
    assert stopped.speed_mps < 1e-3 * moving.speed_mps
    assert stopped.yaw_rate_ned_radps == 0.0
    still = run(PhysicsState(), 1500, 1500, 5.0)
    assert (still.north_m, still.east_m, still.yaw_ned_rad, still.speed_mps) == (0, 0, 0, 0)


def test_stall_holds_the_rover() -> None:
    moving = run(PhysicsState(), 1900, 1900, 2.0)
    held = run(moving, 1900, 1900, 1.0, stalled=True)
    assert (held.north_m, held.east_m) == (moving.north_m, moving.east_m)
    assert held.speed_mps == 0.0


def test_result_does_not_depend_on_the_call_step() -> None:
    """Frames of 1/1200 s whatever the caller's dt: 50 Hz and 200 Hz callers agree."""
    a = run(PhysicsState(), 1800, 1550, 3.0)
    b = PhysicsState()
    for _ in range(600):
        b = skid.step(
            b, 0.005, 1800, 1550, max_speed_mps=4.0, max_accel_mss=14.0, turn_rate_dps=140.0,
            max_yaw_rate_dps=360.0, physics_rate_hz=1200.0,
        )  # fmt: skip
    assert (b.north_m, b.east_m) == pytest.approx((a.north_m, a.east_m), abs=1e-6)


@given(
    dt=st.floats(allow_nan=True, allow_infinity=True),
    left=st.integers(0, 2200),
    right=st.integers(0, 2200),
)
def test_total_for_any_dt_and_outputs(dt: float, left: int, right: int) -> None:
    state = skid.step(
        PhysicsState(), dt if abs(dt) < 1.0 else math.copysign(math.inf, dt), left, right,
        max_speed_mps=4.0, max_accel_mss=14.0, turn_rate_dps=140.0, max_yaw_rate_dps=360.0,
        physics_rate_hz=1200.0,
    )  # fmt: skip
    values = (state.north_m, state.east_m, state.yaw_ned_rad, state.vx_body_mps)
    assert all(math.isfinite(v) for v in values)
    assert -math.pi <= state.yaw_ned_rad < math.pi


def test_config_rejects_unknown_plant_and_bad_constants() -> None:
    with pytest.raises(ValidationError):
        PlantConfig.model_validate({"plant": "tank"})
    with pytest.raises(ValidationError):
        PlantConfig.model_validate({"skid": {"max_speed_mps": 0.0}})
    with pytest.raises(ValidationError):
        PlantConfig.model_validate({"skid": {"turn_rate_dps": math.nan}})
    with pytest.raises(ValidationError):
        PlantConfig.model_validate({"skid": {"wheelbase_m": 0.3}})


# -- through the simulator's wire semantics: pilot radio → RCIN passthrough → outputs 1/3 --


def test_core_drives_the_skid_model_from_outputs_1_and_3() -> None:
    core = simcore.make_core(1, plant="sitl_skid")
    simcore.run(core, 2.0)
    core.set_rc(1, 1700)  # passthrough RCIN1 → output 1 (left motor)
    core.set_rc(3, 1500)
    core.set_rc(2, 2000)  # outputs 2 and 4 are not read by SIM_Rover
    core.set_rc(4, 1000)
    simcore.run(core, 2.0)
    assert core.outputs_us[0] == 1700 and core.outputs_us[2] == 1500
    assert core.phys.yaw_rate_ned_radps == pytest.approx(math.radians(56.0))
    assert core.phys.speed_mps == pytest.approx(0.8, rel=0.02)
    assert core.view.truth is core.phys


def test_core_helix_plant_unchanged_by_the_option() -> None:
    """Same radio on the default plant: the Helix reads all four outputs (eq. 1), not skid."""
    core = simcore.make_core(1)
    simcore.run(core, 2.0)
    core.set_rc(1, 1700)
    core.set_rc(3, 1500)
    simcore.run(core, 2.0)
    assert core.phys.yaw_rate_ned_radps != pytest.approx(math.radians(56.0))
    assert core.phys.scroll_radps[0] > 0.0


# -- command line: helixd sim --plant, helixd run --sim --sim-plant ------------------------


def test_sim_command_plant_option(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import helixd.cli.sim_command as command

    seen: list[PlantConfig] = []
    monkeypatch.setattr(command, "run_sim", lambda links, cfg, faults, dur: seen.append(cfg))
    assert main_exit(["sim", "--plant", "sitl_skid", "--duration", "1"]) == 0
    assert main_exit(["sim", "--duration", "1"]) == 0
    assert [c.plant for c in seen] == [Plant.SITL_SKID, Plant.HELIX]
    capsys.readouterr()
    assert main_exit(["sim", "--plant", "tank"]) == 2
    assert "--plant" in capsys.readouterr().err


def test_run_sim_plant_option_reaches_the_embedded_simulator(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    seen = capture_embedded_start(monkeypatch)
    from helixd.cli.app import main

    with pytest.raises(EmbeddedStart):
        main(["run", "--sim", "--sim-plant", "sitl_skid", "--mission", "square"])
    with pytest.raises(EmbeddedStart):
        main(["run", "--sim", "--mission", "square"])
    assert [c.plant for c in seen] == [Plant.SITL_SKID, Plant.HELIX]
    capsys.readouterr()
    assert main_exit(["run", "--sim", "--sim-plant", "tank", "--mission", "square"]) == 2
