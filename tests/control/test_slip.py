"""The slip estimator: converges to the ground's delivered fraction, stays bounded, is frozen
when there is nothing to learn from, and never turns a NaN into a command."""

from __future__ import annotations

import dataclasses
import math
import random

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.base.geometry import BodyVelocity
from helixd.base.plan import MotionMode
from helixd.config.control import SlipConfig
from helixd.config.safety import SafetyConfig, StallConfig
from helixd.config.vehicle import VehicleConfig
from helixd.control.kinematics import body_to_fractions
from helixd.control.slip import (
    SlipEstimate,
    SlipEstimator,
    measured_body_velocity,
    no_slip_body,
    same_direction,
)
from helixd.safety.watchdogs import FaultCause, SafetyMonitor
from tests.support.safety_inputs import HEALTHY

ROLL = MotionMode.ROLL
DT_S = 0.025  # 40 Hz poses


_PLANT: dict[int, BodyVelocity] = {}  # per estimator: the plant's scroll-limited velocity


def fly(
    est: SlipEstimator,
    sent: BodyVelocity,
    v_frac: float,
    w_frac: float,
    seconds: float,
    mode: MotionMode = ROLL,
) -> SlipEstimate:
    """A plant that delivers the given fractions of the sent command (after its lag); its
    state carries over between calls on the same estimator."""
    lag_s = est.cfg.command_lag_s
    actual = _PLANT.get(id(est), BodyVelocity.zero())
    out = est.estimate(mode)
    for _ in range(round(seconds / DT_S)):
        a = 1.0 - math.exp(-DT_S / lag_s) if lag_s > 0 else 1.0
        actual = BodyVelocity(
            actual.vx_mps + (sent.vx_mps - actual.vx_mps) * a,
            actual.vy_mps + (sent.vy_mps - actual.vy_mps) * a,
            actual.wz_radps + (sent.wz_radps - actual.wz_radps) * a,
        )
        measured = BodyVelocity(
            actual.vx_mps * v_frac, actual.vy_mps * v_frac, actual.wz_radps * w_frac
        )
        out = est.update(mode, sent, measured, DT_S)
    _PLANT[id(est)] = actual
    return out


def test_starts_at_no_slip() -> None:
    est = SlipEstimator(SlipConfig())
    assert est.estimate(ROLL) == SlipEstimate()
    assert est.gains(ROLL) == (1.0, 1.0, 1.0)


@pytest.mark.parametrize(("v_frac", "w_frac"), [(0.9, 0.75), (0.6, 0.3), (0.3, 0.55)])
def test_converges_to_the_delivered_fraction(v_frac: float, w_frac: float) -> None:
    est = SlipEstimator(SlipConfig())
    # alternate driving straight and turning in place, as a square does
    for _ in range(4):
        fly(est, BodyVelocity(0.5, 0.0, 0.0), v_frac, w_frac, 6.0)
        out = fly(est, BodyVelocity(0.0, 0.0, 0.8), v_frac, w_frac, 3.0)
    assert out.vx_frac == pytest.approx(v_frac, abs=0.03)
    assert out.w_frac == pytest.approx(w_frac, abs=0.03)


def test_translation_frozen_while_turning_in_place_and_yaw_while_driving_straight() -> None:
    est = SlipEstimator(SlipConfig())
    fly(est, BodyVelocity(0.5, 0.0, 0.0), 0.6, 0.0, 10.0)
    learnt = est.estimate(ROLL)
    assert learnt.vx_frac == pytest.approx(0.6, abs=0.03)
    assert learnt.w_frac == 1.0  # never commanded a turn: the prior
    # turning in place: once the forward motion has died away (the scrolls' lag), translation
    # is frozen however the ground behaves (here: a side drift that would read as no motion)
    tail = fly(est, BodyVelocity(0.0, 0.0, 1.0), 0.6, 0.5, 1.5)
    assert tail.vx_frac == pytest.approx(0.6, abs=0.03)
    after = fly(est, BodyVelocity(0.0, 0.0, 1.0), 0.0, 0.5, 10.0)
    assert after.vx_frac == tail.vx_frac
    assert after.w_frac == pytest.approx(0.5, abs=0.03)


def test_frozen_below_the_learning_thresholds() -> None:
    cfg = SlipConfig()
    est = SlipEstimator(cfg)
    tiny = BodyVelocity(cfg.min_speed_mps * 0.5, 0.0, cfg.min_yaw_rate_radps * 0.5)
    assert fly(est, tiny, 0.0, 0.0, 20.0) == SlipEstimate()


def test_gaps_and_bad_dt_teach_nothing() -> None:
    est = SlipEstimator(SlipConfig())
    sent = BodyVelocity(0.5, 0.0, 0.0)
    est.update(ROLL, sent, sent, DT_S)
    for dt in (0.0, -1.0, 10.0, math.nan, math.inf):
        assert est.update(ROLL, sent, BodyVelocity.zero(), dt) == SlipEstimate()


def test_per_motion_mode() -> None:
    est = SlipEstimator(SlipConfig())
    fly(est, BodyVelocity(0.0, 0.5, 0.0), 0.75, 1.0, 10.0, MotionMode.SCROLL)
    assert est.estimate(MotionMode.SCROLL).vy_frac == pytest.approx(0.75, abs=0.03)
    assert est.estimate(ROLL) == SlipEstimate()


def test_each_axis_has_its_own_fraction() -> None:
    """OMNI in mud: the scrolls roll poorly (x) but screw well (y); per-axis feed-forward
    restores the commanded direction, not just the speed."""
    cfg = SlipConfig()
    est = SlipEstimator(cfg)
    omni = MotionMode.OMNI
    actual = BodyVelocity.zero()
    for i in range(round(40.0 / DT_S)):
        sent = BodyVelocity(0.4, 0.3, 0.0) if (i * DT_S) % 10 < 5 else BodyVelocity(0.3, -0.4)
        a = 1.0 - math.exp(-DT_S / cfg.command_lag_s)
        actual = BodyVelocity(
            actual.vx_mps + (sent.vx_mps - actual.vx_mps) * a,
            actual.vy_mps + (sent.vy_mps - actual.vy_mps) * a,
        )
        est.update(omni, sent, BodyVelocity(actual.vx_mps * 0.3, actual.vy_mps * 0.85), DT_S)
    out = est.estimate(omni)
    assert out.vx_frac == pytest.approx(0.3, abs=0.03)
    assert out.vy_frac == pytest.approx(0.85, abs=0.03)
    assert out.w_frac == 1.0
    cmd = est.compensate(omni, BodyVelocity(0.2, 0.2, 0.0))
    assert cmd.vx_mps == pytest.approx(0.2 * cfg.max_gain)  # 1/0.3 capped
    # the scroll axis, made up in full, is slowed to what the roll axis gets (0.3 x 2): the
    # rover moves along the command, at 60 % of its speed
    assert cmd.vy_mps == pytest.approx(0.2 / out.vy_frac * out.vx_frac * cfg.max_gain)
    delivered = (cmd.vx_mps * 0.3, cmd.vy_mps * 0.85)
    assert math.degrees(math.atan2(delivered[1], delivered[0])) == pytest.approx(45.0, abs=2.0)


def test_feed_forward_divides_by_the_fraction() -> None:
    est = SlipEstimator(SlipConfig())
    fly(est, BodyVelocity(0.5, 0.0, 0.0), 0.8, 1.0, 20.0)
    fly(est, BodyVelocity(0.0, 0.0, 0.8), 0.8, 0.8, 20.0)
    out = est.compensate(ROLL, BodyVelocity(0.4, 0.0, 0.5))
    v, w = est.estimate(ROLL).vx_frac, est.estimate(ROLL).w_frac
    assert out.vx_mps == pytest.approx(0.4 / v)
    assert out.wz_radps == pytest.approx(0.5 / w)


def test_feed_forward_is_capped() -> None:
    cfg = SlipConfig(max_gain=2.0, stuck_fraction=0.15)
    est = SlipEstimator(cfg)
    out = fly(est, BodyVelocity(0.5, 0.0, 0.8), 0.3, 0.3, 30.0)
    assert out.vx_frac == pytest.approx(0.3, abs=0.03)
    assert est.gains(ROLL) == (2.0, 1.0, 2.0)  # y never commanded


def test_no_amplification_when_the_ground_delivers_nothing() -> None:
    """A pit is a stall, not slip: the command is not pushed to the cap forever."""
    est = SlipEstimator(SlipConfig())
    out = fly(est, BodyVelocity(0.5, 0.0, 0.8), 0.0, 0.0, 30.0)
    assert out.vx_frac < 0.05 and out.w_frac < 0.05
    assert est.gains(ROLL) == (1.0, 1.0, 1.0)
    assert est.compensate(ROLL, BodyVelocity(0.5, 0.0, 0.8)) == BodyVelocity(0.5, 0.0, 0.8)


def test_stall_watchdog_still_fires_with_the_feed_forward_on() -> None:
    """Ground delivering nothing: the command sent (feed-forward included) against the
    measured motion still trips the stall watchdog after its duration (autopilot time)."""
    est = SlipEstimator(SlipConfig())
    mon = SafetyMonitor(SafetyConfig(stall=StallConfig(duration_s=4.0)))
    nav = BodyVelocity(0.5, 0.0, 0.0)
    fault = None
    t_s = 0.0
    while fault is None and t_s < 10.0:
        sent = est.compensate(ROLL, nav)
        est.update(ROLL, sent, BodyVelocity.zero(), DT_S)
        fault = mon.check(
            dataclasses.replace(
                HEALTHY,  # fresh, healthy, at the start point, not moving
                now_s=t_s,
                last_heartbeat_s=t_s,
                pose_rx_s=t_s,
                north_m=0.0,
                east_m=0.0,
                mission_elapsed_s=t_s,
                commanded_speed_mps=math.hypot(sent.vx_mps, sent.vy_mps),
                measured_speed_mps=0.0,
                vehicle_time_s=t_s,
            )
        )
        t_s += DT_S
    assert fault is not None and fault.cause is FaultCause.STALL
    assert t_s == pytest.approx(4.0, abs=0.1)


def test_body_velocity_rotation() -> None:
    # facing East (yaw 90°), moving East: forward; moving North: to the left
    fwd = measured_body_velocity(0.0, 1.0, math.pi / 2, 0.1)
    assert fwd.vx_mps == pytest.approx(1.0) and fwd.vy_mps == pytest.approx(0.0, abs=1e-12)
    left = measured_body_velocity(1.0, 0.0, math.pi / 2, 0.0)
    assert left.vx_mps == pytest.approx(0.0, abs=1e-12) and left.vy_mps == pytest.approx(1.0)
    assert fwd.wz_radps == 0.1


def test_no_slip_body_applies_constraint_and_saturation() -> None:
    vehicle = VehicleConfig()
    slow = no_slip_body(BodyVelocity(0.3, 0.2, 0.1), vehicle, ROLL)
    assert slow.vx_mps == pytest.approx(0.3) and slow.vy_mps == pytest.approx(0.0, abs=1e-12)
    assert slow.wz_radps == pytest.approx(0.1)
    fast = no_slip_body(BodyVelocity(50.0, 0.0, 0.0), vehicle, ROLL)
    assert 0.0 < fast.vx_mps < 50.0  # saturated, direction kept
    assert no_slip_body(BodyVelocity(math.nan, 0.0, 0.0), vehicle, ROLL) == BodyVelocity.zero()


finite = st.floats(min_value=-5.0, max_value=5.0, allow_nan=False)
anything = st.floats(allow_nan=True, allow_infinity=True)


@given(anything, anything, anything, anything, anything, anything, anything)
def test_hostile_numbers_never_leave_the_bounds(
    vx: float, vy: float, wz: float, mx: float, my: float, mw: float, dt: float
) -> None:
    cfg = SlipConfig()
    est = SlipEstimator(cfg)
    fly(est, BodyVelocity(0.5, 0.0, 0.8), 0.7, 0.6, 3.0)
    before = est.estimate(ROLL)
    sent_ok = all(math.isfinite(v) for v in (vx, vy, wz))
    meas_ok = all(math.isfinite(v) for v in (mx, my, mw))
    out = est.update(ROLL, BodyVelocity(vx, vy, wz), BodyVelocity(mx, my, mw), dt)
    for frac in (out.vx_frac, out.vy_frac, out.w_frac):
        assert math.isfinite(frac) and 0.0 <= frac <= cfg.max_fraction
    if not (sent_ok and meas_ok) or not (math.isfinite(dt) and 0 < dt <= cfg.max_gap_s):
        assert out == before  # a non-finite number or a gap changes nothing
    for g in est.gains(ROLL):
        assert 1.0 / cfg.max_fraction <= g <= cfg.max_gain
    cmd = est.compensate(ROLL, BodyVelocity(vx, vy, wz))
    assert cmd.is_finite()
    if not sent_ok:
        assert cmd == BodyVelocity.zero()  # never amplify a NaN
    else:
        assert abs(cmd.vx_mps) <= abs(vx) * cfg.max_gain
        assert abs(cmd.vy_mps) <= abs(vy) * cfg.max_gain
        assert abs(cmd.wz_radps) <= abs(wz) * cfg.max_gain
        # and kinematics turns the compensated command into finite, clamped fractions
        fr = body_to_fractions(cmd, VehicleConfig(), ROLL)
        assert all(math.isfinite(f) and abs(f) <= 1.0 for f in fr)


@given(v=st.floats(0.0, 1.0), w=st.floats(0.0, 1.0), seconds=st.floats(0.5, 20.0))
def test_estimate_stays_between_zero_and_the_bound_for_honest_ground(
    v: float, w: float, seconds: float
) -> None:
    est = SlipEstimator(SlipConfig())
    out = fly(est, BodyVelocity(0.5, 0.0, 0.8), v, w, seconds)
    assert 0.0 <= out.vx_frac <= 1.0 + 1e-9
    assert 0.0 <= out.w_frac <= 1.0 + 1e-9


def test_a_late_response_is_not_read_as_slip() -> None:
    """The link or the scrolls lag a reversal by a second: while the command is still
    settling nothing is learnt, and a sample moving against it weighs as 'nothing delivered'."""
    est = SlipEstimator(SlipConfig())
    for _ in range(3):
        fly(est, BodyVelocity(0.0, 0.0, 0.8), 1.0, 0.75, 3.0)
        fly(est, BodyVelocity(0.0, 0.0, -0.8), 1.0, 0.75, 3.0)
    learnt = est.estimate(ROLL).w_frac
    assert learnt == pytest.approx(0.75, abs=0.03)
    # the command reverses, the rover keeps turning the old way for 1 s (delivered "-0.75")
    out = fly(est, BodyVelocity(0.0, 0.0, 0.8), 1.0, -0.75, 1.0)
    assert out.w_frac >= 0.5
    # changing commands (a PID dithering about a mean) teach nothing
    est = SlipEstimator(SlipConfig())
    est.update(ROLL, BodyVelocity(0.4, 0.0, 0.65), BodyVelocity.zero(), DT_S)
    before = est.estimate(ROLL)
    for i in range(200):
        sent = BodyVelocity(0.6 if i % 2 else 0.2, 0.0, 1.0 if i % 2 else 0.3)
        est.update(ROLL, sent, BodyVelocity.zero(), DT_S)
    assert est.estimate(ROLL) == before


def test_starts_from_the_declared_ground() -> None:
    """A ground the operator declared is where the estimate starts (the circle on hard
    ground: the scroll axis gets 45 %, fed forward 2× from the first pose, not after seconds of
    learning), and learning still moves it to the ground actually met."""
    cfg = SlipConfig(
        ground_roll_fraction=0.95, ground_scroll_fraction=0.45, ground_yaw_fraction=0.85
    )
    est = SlipEstimator(cfg)
    for mode in MotionMode:
        got = est.estimate(mode)
        assert (got.vx_frac, got.vy_frac, got.w_frac) == pytest.approx((0.95, 0.45, 0.85))
    assert est.gains(MotionMode.SCROLL) == pytest.approx((1 / 0.95, 2.0, 1 / 0.85))
    for _ in range(4):  # the ground met gives 80 % of the roll axis, not 95 %
        fly(est, BodyVelocity(0.5, 0.0, 0.0), 0.8, 0.85, 6.0)
        out = fly(est, BodyVelocity(0.0, 0.0, 0.8), 0.8, 0.85, 3.0)
    assert out.vx_frac == pytest.approx(0.8, abs=0.03)


def test_a_declared_ground_below_the_stall_fraction_is_refused() -> None:
    with pytest.raises(ValueError, match=r"ground_scroll_fraction = 0.1 is below stuck_fraction"):
        SlipConfig(ground_scroll_fraction=0.1)
    with pytest.raises(ValueError, match=r"allowed range 0.3 .. 1"):
        SlipConfig(stuck_fraction=0.3, ground_yaw_fraction=0.2)
    with pytest.raises(ValueError, match="less than or equal to 1"):
        SlipConfig(ground_roll_fraction=1.5)


MUD = SlipConfig(ground_roll_fraction=0.3, ground_scroll_fraction=0.85, ground_yaw_fraction=0.55)


def test_omni_on_mud_moves_in_the_direction_commanded() -> None:
    """Mud gives the roll axis 30 % (60 % with the 2x cap) and the scroll axis 85 % (all of
    it): a 60-degree hexagon side would come out skewed ~15 degrees towards the scroll axis.
    The scroll axis is slowed to the roll axis's 60 %, so the motion keeps the command's
    direction at 60 % of its speed."""
    est = SlipEstimator(MUD)
    omni = MotionMode.OMNI
    side = math.radians(60.0)
    cmd = BodyVelocity(0.5 * math.cos(side), 0.5 * math.sin(side), 0.0)
    sent = est.compensate(omni, cmd)
    got = BodyVelocity(sent.vx_mps * 0.3, sent.vy_mps * 0.85, 0.0)  # what mud delivers
    assert math.atan2(got.vy_mps, got.vx_mps) == pytest.approx(side, abs=1e-9)
    assert math.hypot(got.vx_mps, got.vy_mps) == pytest.approx(0.6 * 0.5)
    assert sent.vx_mps == pytest.approx(cmd.vx_mps * 2.0)  # the roll axis still gets its 2x
    # without it the same command is skewed by ~15 degrees
    skewed = math.atan2(cmd.vy_mps / 0.85 * 0.85, cmd.vx_mps * 2.0 * 0.3)
    assert math.degrees(skewed - side) > 10.0


def test_one_axis_commands_are_not_slowed() -> None:
    """ROLL and SCROLL drive one translation axis (the navigator's other component is
    dropped by the mode's constraint): nothing to keep in line, nothing slowed, even with the
    mud declared (SCROLL never learns its roll axis: it stays at the declared 30 %); along one
    axis in OMNI the same."""
    est = SlipEstimator(MUD)
    for mode, cmd in (
        (MotionMode.ROLL, BodyVelocity(0.5, 0.3, 0.3)),
        (MotionMode.SCROLL, BodyVelocity(0.3, 0.5, 0.3)),
        (MotionMode.OMNI, BodyVelocity(0.0, 0.5, 0.0)),
    ):
        g_x, g_y, g_w = est.gains(mode)
        assert est.compensate(mode, cmd) == BodyVelocity(
            cmd.vx_mps * g_x, cmd.vy_mps * g_y, cmd.wz_radps * g_w
        )


@given(
    st.floats(-2.0, 2.0),
    st.floats(-2.0, 2.0),
    st.floats(0.01, 1.0),
    st.floats(0.01, 1.0),
    st.floats(0.01, 0.5),
)
def test_same_direction_never_amplifies_and_is_continuous(
    vx: float, vy: float, d_x: float, d_y: float, share: float
) -> None:
    """Factors in [min(d_x, d_y) / max(d_x, d_y), 1]; only the axis that delivers more is
    slowed; a small turn of the command moves the scaled command a little (no jump as a
    command turns onto one axis); full direction keeping once the slower axis carries
    ``share`` of it."""
    k_x, k_y = same_direction(vx, vy, d_x, d_y, share)
    low = min(d_x, d_y) / max(d_x, d_y)
    assert low - 1e-12 <= k_x <= 1.0 and low - 1e-12 <= k_y <= 1.0
    assert k_x == 1.0 or k_y == 1.0
    if d_x < d_y:
        assert k_x == 1.0
    eps = 1e-6  # the command it scales moves a little when the command does
    k2 = same_direction(vx + eps, vy, d_x, d_y, share)
    assert abs((vx + eps) * k2[0] - vx * k_x) < 1e-3
    assert abs(vy * k2[1] - vy * k_y) < 1e-3
    total = abs(vx) + abs(vy)
    slower = abs(vx) if d_x < d_y else abs(vy)
    if total > 0 and slower / total >= share and d_x != d_y:
        delivered = (vx * d_x * k_x, vy * d_y * k_y)
        assert delivered[0] * vy == pytest.approx(delivered[1] * vx, abs=1e-9)  # parallel


def test_same_direction_is_total() -> None:
    for bad in (math.nan, math.inf, -math.inf):
        assert same_direction(bad, 0.3, 0.6, 1.0, 0.2) == (1.0, 1.0)
        assert same_direction(0.3, 0.3, bad, 1.0, 0.2) == (1.0, 1.0)
    assert same_direction(0.0, 0.0, 0.6, 1.0, 0.2) == (1.0, 1.0)
    assert same_direction(0.3, 0.3, 0.0, 1.0, 0.2) == (1.0, 1.0)


@pytest.mark.parametrize("w_frac", [0.55, 0.85, 1.0])
def test_noisy_samples_do_not_bias_the_fit(w_frac: float) -> None:
    """Each sample is clipped to a window symmetric about the estimate, so zero-mean noise on
    the measured yaw rate (here ±0.3 rad/s at 0.5 rad/s) leaves the fit where the ground is.
    A fixed [0, 1.2] window cut the upper tail only: 0.85 was learnt as 0.77."""
    rng = random.Random(1)
    est = SlipEstimator(SlipConfig())
    sent = BodyVelocity(0.0, 0.0, 0.5)
    learnt = []
    for i in range(20000):
        measured = BodyVelocity(0.0, 0.0, w_frac * 0.5 + rng.gauss(0.0, 0.3))
        out = est.update(ROLL, sent, measured, 0.02)
        if i >= 2000:
            learnt.append(out.w_frac)
    assert sum(learnt) / len(learnt) == pytest.approx(w_frac, abs=0.015)


def test_delivered_counts_the_capped_feed_forward() -> None:
    """SCROLL on hard ground: the scroll axis gets 0.45 of its command, 0.9 with the
    feed-forward capped at 2×; the roll axis 0.95, all of it with the feed-forward."""
    est = SlipEstimator(SlipConfig())
    for _ in range(3):
        fly(est, BodyVelocity(0.5, 0.0, 0.0), 0.95, 1.0, 6.0)
    scroll = SlipEstimator(SlipConfig())
    for _ in range(3):
        fly(scroll, BodyVelocity(0.0, 0.5, 0.0), 0.45, 1.0, 6.0, MotionMode.SCROLL)
    assert est.delivered(ROLL)[0] == pytest.approx(1.0)
    assert scroll.delivered(MotionMode.SCROLL)[1] == pytest.approx(0.9, abs=0.02)
