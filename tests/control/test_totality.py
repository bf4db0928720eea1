"""Every pure function of the control core is total.

NaN/inf in gives a raised :class:`NonFiniteError` or a finite, bounded, neutral-leaning output —
never a saturated command. These are the functions whose NaN behaviour sent 1734/1734/1566/1566
µs (0.6 m/s at the full yaw rate) to the rover before these checks:
``max(-l, min(l, nan))`` is the limit, ``min(1.0, nan)`` is 1.0, ``nan > x`` is False.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from helixd.base.angles import shortest_angular_distance, wrap_pi
from helixd.base.frames import MissionFrame, NedPose, latlon_to_ne, ne_to_latlon
from helixd.base.geometry import BodyVelocity, NonFiniteError, Pose2D
from helixd.base.plan import MissionFrameKind, MotionMode, Plan, PlanWaypoint
from helixd.config.control import ControlConfig, PidGains
from helixd.config.vehicle import VehicleConfig
from helixd.control import guidance
from helixd.control.kinematics import (
    apply_calibration,
    body_to_fractions,
    body_to_scroll_radps,
    no_slip_body_velocity,
    saturate,
    saturate4,
    scroll_fractions,
    scroll_radps_to_body,
)
from helixd.control.navigator import Navigator
from helixd.control.pid import PID

NAN, INF = math.nan, math.inf
BAD = st.sampled_from([NAN, INF, -INF])
ANY = st.floats(allow_nan=True, allow_infinity=True)
FINITE = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
MODES = st.sampled_from(list(MotionMode))
VEHICLE = VehicleConfig()
CONTROL = ControlConfig()
GAINS = PidGains(kp=8.0, ki=0.5, kd=0.05, integral_limit=0.5)


def finite(*values: float) -> bool:
    return all(math.isfinite(v) for v in values)


@st.composite
def with_one_bad(draw: st.DrawFn, n: int) -> list[float]:
    """``n`` floats, any of them, with at least one NaN or ±inf among them."""
    values = [draw(ANY) for _ in range(n)]
    values[draw(st.integers(0, n - 1))] = draw(BAD)
    return values


# -- angles ----------------------------------------------------------------------------------------


@given(BAD)
def test_wrap_pi_raises_on_non_finite(angle: float) -> None:
    # was: ValueError "math domain error" from fmod(inf) → exit 1; NaN silently passed through
    with pytest.raises(NonFiniteError):
        wrap_pi(angle)


@given(with_one_bad(2))
def test_shortest_angular_distance_raises_on_non_finite(values: list[float]) -> None:
    with pytest.raises(NonFiniteError):
        shortest_angular_distance(values[0], values[1])


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_wrap_pi_finite_in_finite_out(angle: float) -> None:
    assert -math.pi < wrap_pi(angle) <= math.pi


# -- PID ---------------------------------------------------------------------------------------


@settings(max_examples=300)
@given(with_one_bad(2), st.floats(0.0, 1.0), st.booleans(), FINITE, FINITE)
def test_pid_non_finite_input_gives_zero_and_keeps_memory(
    bad: list[float], dt_s: float, angular: bool, warm_sp: float, warm_meas: float
) -> None:
    pid = PID(GAINS, output_limit=1.0, angular=angular)
    pid.update(warm_sp, warm_meas, 0.05)
    before = (pid.integral, pid._prev_measurement)
    terms = pid.update(bad[0], bad[1], dt_s)
    assert terms.output == 0.0  # neutral, not ±limit
    assert finite(terms.p, terms.i, terms.d)
    assert (pid.integral, pid._prev_measurement) == before


@settings(max_examples=300)
@given(ANY, ANY, ANY, st.booleans())
@example(1.7976931348623157e308, -9.9792015476736e291, 0.0, True)  # the error overflows to inf
def test_pid_output_always_finite_and_bounded(
    setpoint: float, measurement: float, dt_s: float, angular: bool
) -> None:
    pid = PID(GAINS, output_limit=0.6, angular=angular)
    for _ in range(3):
        out = pid.update(setpoint, measurement, dt_s).output
        assert math.isfinite(out) and abs(out) <= 0.6
        assert not (math.isnan(setpoint) or math.isnan(measurement)) or out == 0.0


# -- guidance ---------------------------------------------------------------------------------

GOAL = PlanWaypoint(5.0, 2.0, 0.3, None)


@settings(max_examples=300)
@given(with_one_bad(3), MODES)
def test_compute_errors_raises_on_non_finite_pose(values: list[float], mode: MotionMode) -> None:
    with pytest.raises(NonFiniteError):
        guidance.compute_errors(Pose2D(*values), GOAL, mode)


@given(with_one_bad(2), MODES)
def test_compute_errors_raises_on_non_finite_goal(values: list[float], mode: MotionMode) -> None:
    with pytest.raises(NonFiniteError):
        guidance.compute_errors(Pose2D(0.0, 0.0, 0.0), PlanWaypoint(*values, 0.3, None), mode)


@settings(max_examples=300)
@given(FINITE, FINITE, st.floats(-100.0, 100.0), MODES)
def test_compute_errors_finite_pose_gives_finite_errors(
    x: float, y: float, yaw: float, mode: MotionMode
) -> None:
    e = guidance.compute_errors(Pose2D(x, y, yaw), GOAL, mode)
    assert finite(
        e.distance_error_m,
        e.bearing_rad,
        e.heading_goal_rad,
        e.heading_error_rad,
        e.direction_body_x,
        e.direction_body_y,
    )
    assert abs(e.heading_error_rad) <= math.pi
    assert math.hypot(e.direction_body_x, e.direction_body_y) <= 1.0 + 1e-9


@settings(max_examples=300)
@given(with_one_bad(2), MODES, ANY, ANY)
def test_compute_command_non_finite_is_zero(
    bad: list[float], mode: MotionMode, ux: float, uy: float
) -> None:
    errors = guidance.GuidanceResult(1.0, 0.0, 0.0, 0.0, ux, uy)
    cmd = guidance.compute_command(errors, mode, bad[0], bad[1])
    assert cmd.is_finite()
    if not math.isfinite(bad[0]):
        assert cmd.vx_mps == 0.0 and cmd.vy_mps == 0.0  # no speed from a NaN speed
    if not math.isfinite(bad[1]):
        assert cmd.wz_radps == 0.0


@settings(max_examples=500)
@given(with_one_bad(6))
def test_speed_law_non_finite_is_zero(values: list[float]) -> None:
    # was: min(1.0, nan) == 1.0 → the full cruise speed
    assert guidance.track_speed_mps(*values) == 0.0


@settings(max_examples=300)
@given(ANY, ANY, st.floats(0.05, 5.0), st.floats(0.05, 2.0), st.floats(0.0, 10.0))
def test_speed_law_bounded(
    pid: float, e_d: float, tol: float, cruise: float, slow_r: float
) -> None:
    v = guidance.track_speed_mps(pid, e_d, tol, cruise, slow_r, 0.05)
    assert math.isfinite(v) and 0.0 <= v <= cruise


@given(with_one_bad(6))
def test_cross_track_raises_on_non_finite(values: list[float]) -> None:
    with pytest.raises(NonFiniteError):
        guidance.cross_track_m(
            (values[0], values[1]), (values[2], values[3]), Pose2D(values[4], values[5], 0.0)
        )


@given(with_one_bad(2))
def test_run_out_raises_on_non_finite_start(values: list[float]) -> None:
    with pytest.raises(NonFiniteError):
        guidance.run_out_m([(values[0], values[1]), (1.0, 0.0), (2.0, 0.0)], [False, False], 0.5)


@given(with_one_bad(3))
def test_world_to_body_raises_on_non_finite(values: list[float]) -> None:
    with pytest.raises(NonFiniteError):
        guidance.world_to_body(*values)


# -- kinematics -------------------------------------------------------------------------------


# the four scroll fractions of a body velocity: numpy's and the plain floats the control
# loop runs (both: scroll 1..4, in order)
TO_FRACTIONS: dict[str, Callable[[BodyVelocity, MotionMode], list[float]]] = {
    "body_to_fractions": lambda v, mode: body_to_fractions(v, VEHICLE, mode).tolist(),
    "scroll_fractions": lambda v, mode: list(scroll_fractions(v, VEHICLE, mode)),
}


@pytest.mark.parametrize("to_fractions", TO_FRACTIONS)
@settings(max_examples=500)
@given(values=with_one_bad(3), mode=MODES)
def test_fractions_of_non_finite_are_neutral(
    to_fractions: str, values: list[float], mode: MotionMode
) -> None:
    # was (body_to_fractions): every scroll at ±clamp (apply_calibration clamped the NaN)
    fractions = TO_FRACTIONS[to_fractions](BodyVelocity(*values), mode)
    assert fractions == [0.0, 0.0, 0.0, 0.0]


@pytest.mark.parametrize("to_fractions", TO_FRACTIONS)
@settings(max_examples=300)
@given(vx=ANY, vy=ANY, wz=ANY, mode=MODES)
def test_fractions_always_finite_and_clamped(
    to_fractions: str, vx: float, vy: float, wz: float, mode: MotionMode
) -> None:
    fractions = TO_FRACTIONS[to_fractions](BodyVelocity(vx, vy, wz), mode)
    assert len(fractions) == 4
    assert all(math.isfinite(f) and abs(f) <= VEHICLE.output_clamp for f in fractions)


@given(with_one_bad(4))
def test_saturate_non_finite_is_neutral(values: list[float]) -> None:
    assert saturate(np.array(values), 0.9).tolist() == [0.0] * 4


@given(with_one_bad(4))
def test_apply_calibration_never_clamps_a_nan(values: list[float]) -> None:
    out = apply_calibration(np.array(values), VEHICLE.scrolls, VEHICLE.output_clamp)
    assert np.all(np.isfinite(out))
    for raw, cooked in zip(values, out.tolist(), strict=True):
        if not math.isfinite(raw):
            assert cooked == 0.0


@given(with_one_bad(3))
def test_matrix_kinematics_raise_on_non_finite(values: list[float]) -> None:
    with pytest.raises(NonFiniteError):
        body_to_scroll_radps(BodyVelocity(*values), VEHICLE)
    with pytest.raises(NonFiniteError):
        scroll_radps_to_body([*values, 0.0], VEHICLE)


# -- frames -----------------------------------------------------------------------------------


@settings(max_examples=300)
@given(with_one_bad(3), st.booleans())
def test_frames_raise_on_non_finite_pose(values: list[float], start_frame: bool) -> None:
    frame = MissionFrame.start_at(NedPose(1.0, 2.0, 0.3)) if start_frame else MissionFrame.enu()
    with pytest.raises(NonFiniteError):
        frame.to_mission(NedPose(*values))


@given(with_one_bad(3))
def test_start_frame_from_a_non_finite_origin_raises(values: list[float]) -> None:
    with pytest.raises(NonFiniteError):
        MissionFrame.start_at(NedPose(*values)).to_mission(NedPose(0.0, 0.0, 0.0))


@given(with_one_bad(2), st.booleans())
def test_frame_back_conversions_raise(values: list[float], start_frame: bool) -> None:
    frame = MissionFrame.start_at(NedPose(1.0, 2.0, 0.3)) if start_frame else MissionFrame.enu()
    with pytest.raises(NonFiniteError):
        frame.to_ned(values[0], values[1])
    with pytest.raises(NonFiniteError):
        frame.yaw_to_ned(values[0] if not math.isfinite(values[0]) else values[1])


@given(with_one_bad(2))
def test_latlon_conversions_raise(values: list[float]) -> None:
    with pytest.raises(NonFiniteError):
        latlon_to_ne(values[0], values[1], 47.0, 8.0)
    with pytest.raises(NonFiniteError):
        ne_to_latlon(values[0], values[1], 47.0, 8.0)


# -- navigator step ---------------------------------------------------------------------------


def make_plan(mode: MotionMode) -> Plan:
    waypoints = (PlanWaypoint(5.0, 0.0, 0.3, None), PlanWaypoint(5.0, 5.0, 0.3, 1.0))
    return Plan("totality", mode, MissionFrameKind.START, waypoints, speed_mps=0.6)


def assert_bad_step_keeps(
    nav: Navigator, warm_steps: int, values: list[float], state: Callable[[], object]
) -> None:
    """After ``warm_steps`` good steps, a step on the non-finite pose/time ``values`` raises
    and leaves ``state()`` as it was."""
    for i in range(warm_steps):
        nav.step(Pose2D(0.1 * i, 0.0, 0.0), 0.05 * i)
    before = state()
    with pytest.raises(NonFiniteError):
        nav.step(Pose2D(values[0], values[1], values[2]), values[3])
    assert state() == before


@settings(max_examples=300)
@given(with_one_bad(4), MODES, st.integers(0, 5))
def test_navigator_step_raises_and_keeps_state(
    values: list[float], mode: MotionMode, warm_steps: int
) -> None:
    nav = Navigator(make_plan(mode), CONTROL)
    assert_bad_step_keeps(
        nav, warm_steps, values, lambda: (nav.state, nav.target_index, nav.waypoints_reached,
                                          nav._last_t_s)
    )  # fmt: skip


@settings(max_examples=200)
@given(MODES, st.lists(st.tuples(FINITE, FINITE, st.floats(-10.0, 10.0)), min_size=1, max_size=8))
def test_navigator_finite_poses_give_finite_bounded_commands(
    mode: MotionMode, poses: list[tuple[float, float, float]]
) -> None:
    nav = Navigator(make_plan(mode), CONTROL)
    for i, (x, y, yaw) in enumerate(poses):
        out = nav.step(Pose2D(x, y, yaw), 0.05 * i)
        c = out.command
        assert c.is_finite()
        assert math.hypot(c.vx_mps, c.vy_mps) <= 0.6 + 1e-9
        assert abs(c.wz_radps) <= CONTROL.max_yaw_rate_radps + 1e-9
        fractions = body_to_fractions(c, VEHICLE, mode)
        assert np.all(np.abs(fractions) <= VEHICLE.output_clamp)


def test_nan_burst_mid_mission_then_recovery() -> None:
    """The hostile-telemetry scenario at the core: valid poses, NaN poses (raise, nothing changes),
    valid poses again — the commands stay finite and bounded throughout."""
    nav = Navigator(make_plan(MotionMode.ROLL), CONTROL)
    t = 0.0
    for i in range(10):
        t = 0.05 * i
        nav.step(Pose2D(0.05 * i, 0.0, 0.0), t)
    for bad in (Pose2D(NAN, NAN, 0.0), Pose2D(1.0, 0.0, NAN), Pose2D(1.0, 0.0, INF)):
        with pytest.raises(NonFiniteError):
            nav.step(bad, t + 0.05)
    out = nav.step(Pose2D(0.5, 0.0, 0.0), t + 0.1)
    assert out.command.is_finite() and abs(out.command.wz_radps) < 0.5


# -- the hostile-telemetry numbers, end to end through the pure core ----------------------------


def test_nan_pose_gives_neutral_pwm_not_1734_1566() -> None:
    """Regression: x = y = NaN gave 1734/1734/1566/1566 µs (0.6 m/s at the full yaw rate).
    Now: the navigator refuses the pose; and even a NaN body command reaching kinematics
    maps to neutral PWM on every scroll."""
    from helixd.actuators.mapping import fraction_to_pwm
    from helixd.config.vehicle import ActuationConfig

    channels = ActuationConfig().channels
    nav = Navigator(make_plan(MotionMode.ROLL), CONTROL)
    frame = MissionFrame.start_at(NedPose(0.0, 0.0, 0.0))
    nav.step(frame.to_mission(NedPose(0.0, 0.0, 0.0)), 0.0)
    with pytest.raises(NonFiniteError):
        frame.to_mission(NedPose(NAN, NAN, 0.0))
    with pytest.raises(NonFiniteError):
        nav.step(Pose2D(NAN, NAN, 0.0), 0.05)
    # the pre-fix arithmetic: PID clamp of NaN was the limit, min(1.0, nan) was 1.0
    speed = guidance.track_speed_mps(0.6, NAN, 0.3, 0.6, 1.0, 0.05)
    yaw_rate = PID(CONTROL.yaw_pid, CONTROL.max_yaw_rate_radps, angular=True).update(0.0, NAN, 0.05)
    assert speed == 0.0 and yaw_rate.output == 0.0
    for body in (BodyVelocity(speed, 0.0, yaw_rate.output), BodyVelocity(0.6, 0.0, NAN)):
        fractions = body_to_fractions(body, VEHICLE, MotionMode.ROLL)
        pwm = [fraction_to_pwm(float(f), ch) for f, ch in zip(fractions, channels, strict=True)]
        assert pwm == [ch.pwm_trim_us for ch in channels]


def test_inf_yaw_is_no_math_domain_error() -> None:
    """Regression: ATTITUDE yaw = ±inf crashed with 'math domain error' (exit 1)."""
    for yaw in (INF, -INF):
        with pytest.raises(NonFiniteError, match="not finite"):
            MissionFrame.enu().to_mission(NedPose(1.0, 2.0, yaw))


# -- line guidance (control.guidance = "line", the default) and the thesis law ---------------

GUIDANCES = st.sampled_from(["line", "thesis"])


@settings(max_examples=200)
@given(
    MODES,
    GUIDANCES,
    st.lists(
        st.tuples(FINITE, FINITE, st.floats(-10.0, 10.0), st.floats(-1.0, 2.0)),
        min_size=1,
        max_size=12,
    ),
)
def test_navigator_any_guidance_finite_bounded_under_any_clock(
    mode: MotionMode, guidance: str, steps: list[tuple[float, float, float, float]]
) -> None:
    """Finite poses with any time steps (repeated, backwards, gaps beyond max_dt_s): the
    command is finite and within the speed and yaw-rate caps, in either guidance law."""
    control = ControlConfig(guidance=guidance)
    nav = Navigator(make_plan(mode), control)
    t = 0.0
    for x, y, yaw, dt in steps:
        t += dt
        c = nav.step(Pose2D(x, y, yaw), t).command
        assert c.is_finite()
        assert math.hypot(c.vx_mps, c.vy_mps) <= 0.6 + 1e-9
        assert abs(c.wz_radps) <= control.max_yaw_rate_radps + 1e-9


@settings(max_examples=200)
@given(with_one_bad(4), MODES, st.integers(0, 5))
def test_line_navigator_step_raises_and_keeps_its_limiter_state(
    values: list[float], mode: MotionMode, warm_steps: int
) -> None:
    nav = Navigator(make_plan(mode), ControlConfig(guidance="line"))
    assert_bad_step_keeps(
        nav, warm_steps, values, lambda: (nav.state, nav.target_index, nav._last_t_s,
                                          nav._prev_command)
    )  # fmt: skip


@settings(max_examples=200)
@given(
    st.lists(st.tuples(FINITE, FINITE), min_size=2, max_size=8),
    st.lists(st.booleans(), min_size=7, max_size=7),
    st.floats(0.0, math.pi),
    st.floats(0.05, 10.0),
)
def test_line_pass_speeds_finite_and_within_cruise(
    points: list[tuple[float, float]], stop_at: list[bool], pivot: float, lookahead: float
) -> None:
    from helixd.control import line

    speeds, stops = line.waypoint_speed_limits(
        points, stop_at[: len(points) - 1], 0.6, pivot, lookahead, 0.3, 1.0
    )
    assert stops[-1] and speeds[-1] == 0.0
    assert all(math.isfinite(v) and 0.0 <= v <= 0.6 for v in speeds)
    for j in range(len(speeds)):
        v = line.profile_speed_mps(1.0, j, points, speeds, 0.3, [0.5] * len(speeds))
        assert math.isfinite(v) and v >= 0.0


# -- the plain-float kinematics the control loop runs -----------------------------------------


@settings(max_examples=300)
@given(ANY, ANY, ANY, MODES)
def test_no_slip_body_velocity_is_finite_and_zero_for_non_finite(
    vx: float, vy: float, wz: float, mode: MotionMode
) -> None:
    out = no_slip_body_velocity(BodyVelocity(vx, vy, wz), VEHICLE, mode)
    assert out.is_finite()
    if not all(math.isfinite(v) for v in (vx, vy, wz)):
        assert out == BodyVelocity(0.0, 0.0, 0.0)


@given(with_one_bad(4))
def test_saturate4_non_finite_is_neutral(values: list[float]) -> None:
    assert saturate4((values[0], values[1], values[2], values[3]), 0.9) == (0.0, 0.0, 0.0, 0.0)
