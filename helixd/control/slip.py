"""Online slip estimate: how much of the commanded motion the ground delivers.

The thesis's own next step (ch. 6, "on-line parameter estimation of interaction forces"): on
grass, mud or sand the scrolls deliver only a fraction of the no-slip (eq. 1) body velocity.
Per motion mode, three fractions are learnt from the pose telemetry, one per body axis (the
terrains differ per axis: in mud the scrolls roll poorly but screw well):

- ``vx_frac``: measured / commanded (no-slip) velocity along the roll axis;
- ``vy_frac``: the same along the scroll axis;
- ``w_frac``: measured / commanded (no-slip) yaw rate.

Each is an exponentially weighted least-squares fit of ``measured = k · commanded`` through
the origin (a recursive least squares with a forgetting time constant, counted in the
autopilot time between samples, so the memory does not depend on the control rate), started
from the ground the operator declared (``ground_*_fraction``; by default the no-slip prior
``k = 1``). The command fed to the fit is the one actually sent (after
the feed-forward and the scrolls' joint saturation), low-passed by the scrolls' response lag,
and each axis's fit is frozen while its command is too small to learn from (so translation
is frozen while turning in place) or still changing (the response delay of scrolls, EKF and
link would read as slip), across telemetry gaps, and on any non-finite number. One sample's
measured motion counts as at least none of the command, so a late sample moving against the
command weighs no more than a stall, and as at most twice the current estimate (at least
``max_fraction``): a window symmetric about the estimate, so the clipped noise does not bias it.

The feed-forward divides the navigator's command by the fraction, bounded: never by less than
``1 / max_gain`` (the command is amplified at most ``max_gain`` times), and not at all when the
fraction is below ``stuck_fraction``: a ground that delivers (almost) nothing is a stall, not
slip, and pushing harder would only dig the pit deeper and hide it. The stall watchdog compares
the measured motion with the command sent, so the feed-forward can only make it fire sooner.

Pure: stepped with numbers, no clocks, sockets or logging.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from helixd.base.geometry import BodyVelocity
from helixd.base.plan import MotionMode
from helixd.control.kinematics import no_slip_body_velocity
from helixd.control.params import SlipParams, VehicleParams


@dataclass(frozen=True, slots=True)
class SlipEstimate:
    """Delivered fractions of the commanded translation and yaw rate (1 = no slip)."""

    vx_frac: float = 1.0
    vy_frac: float = 1.0
    w_frac: float = 1.0


@dataclass(slots=True)
class _Fit:
    """Exponentially weighted sums of u² and u·y for ``y = k · u``."""

    s_uu: float
    s_uy: float

    def k(self) -> float:
        return self.s_uy / self.s_uu

    def learn(self, u: float, y: float, dt_s: float, forget: float) -> None:
        s_uu = forget * self.s_uu + u * u * dt_s
        s_uy = forget * self.s_uy + u * y * dt_s
        if math.isfinite(s_uu) and math.isfinite(s_uy) and s_uu > 0.0:
            self.s_uu, self.s_uy = s_uu, s_uy


@dataclass(slots=True)
class _ModeState:
    vx: _Fit
    vy: _Fit
    w: _Fit
    lagged: BodyVelocity | None = None  # sent command, low-passed by the scroll response


def measured_body_velocity(
    vn_mps: float, ve_mps: float, yaw_ned_rad: float, yaw_rate_ccw_radps: float
) -> BodyVelocity:
    """NED ground velocity rotated into the body frame (x forward, y left, z up, CCW)."""
    c, s = math.cos(yaw_ned_rad), math.sin(yaw_ned_rad)
    return BodyVelocity(vn_mps * c + ve_mps * s, vn_mps * s - ve_mps * c, yaw_rate_ccw_radps)


def no_slip_body(command: BodyVelocity, vehicle: VehicleParams, mode: MotionMode) -> BodyVelocity:
    """The body velocity the scrolls would produce on ideal ground for ``command``: the mode's
    constraint and the joint saturation of :func:`helixd.control.kinematics.body_to_fractions`
    applied (per-scroll calibration is the actuators' business, not the ground's). Zero for a
    non-finite command (the kinematics sends neutral then). Plain floats
    (:func:`helixd.control.kinematics.no_slip_body_velocity`): it runs every control step."""
    return no_slip_body_velocity(command, vehicle, mode)


class SlipEstimator:
    """Per motion mode delivered-fraction estimate and its bounded feed-forward."""

    def __init__(
        self,
        cfg: SlipParams,
        priors: Mapping[MotionMode, tuple[float, float, float]] | None = None,
    ) -> None:
        """``priors``: per mode the (roll, scroll, yaw) fractions its fit starts from (the
        ground the rover learnt where it first flies in that mode); others start from the
        declared ground (``ground_*_fraction``)."""
        self.cfg = cfg
        self._priors = dict(priors or {})
        self._modes: dict[MotionMode, _ModeState] = {}
        # the estimate of each mode's fits, until they learn again (read twice per step)
        self._estimates: dict[MotionMode, SlipEstimate] = {}

    def _state(self, mode: MotionMode) -> _ModeState:
        st = self._modes.get(mode)
        if st is None:
            w_v = self.cfg.prior_weight_s * self.cfg.min_speed_mps**2
            w_w = self.cfg.prior_weight_s * self.cfg.min_yaw_rate_radps**2
            cfg = self.cfg  # the prior: learnt, or the ground the operator declared (1: no slip)
            roll, scroll, yaw = self._priors.get(
                mode,
                (cfg.ground_roll_fraction, cfg.ground_scroll_fraction, cfg.ground_yaw_fraction),
            )
            st = _ModeState(
                vx=_Fit(w_v, w_v * roll), vy=_Fit(w_v, w_v * scroll), w=_Fit(w_w, w_w * yaw)
            )
            self._modes[mode] = st
        return st

    def _bounded(self, k: float) -> float:
        if not math.isfinite(k):
            return 1.0
        return max(0.0, min(self.cfg.max_fraction, k))

    def estimate(self, mode: MotionMode) -> SlipEstimate:
        est = self._estimates.get(mode)
        if est is None:
            st = self._state(mode)
            est = SlipEstimate(
                self._bounded(st.vx.k()), self._bounded(st.vy.k()), self._bounded(st.w.k())
            )
            self._estimates[mode] = est
        return est

    def update(
        self, mode: MotionMode, sent: BodyVelocity, measured: BodyVelocity, dt_s: float
    ) -> SlipEstimate:
        """Learn from one sample: ``sent`` = the no-slip body velocity commanded over the last
        ``dt_s`` seconds (autopilot time), ``measured`` = the body velocity at its end."""
        cfg = self.cfg
        st = self._state(mode)
        if not sent.is_finite():
            return self.estimate(mode)
        if not (math.isfinite(dt_s) and 0.0 < dt_s <= cfg.max_gap_s) or st.lagged is None:
            st.lagged = sent  # a gap or the first sample: nothing to compare with yet
            return self.estimate(mode)
        alpha = 1.0 if cfg.command_lag_s == 0.0 else 1.0 - math.exp(-dt_s / cfg.command_lag_s)
        lag = st.lagged
        lag = BodyVelocity(
            lag.vx_mps + (sent.vx_mps - lag.vx_mps) * alpha,
            lag.vy_mps + (sent.vy_mps - lag.vy_mps) * alpha,
            lag.wz_radps + (sent.wz_radps - lag.wz_radps) * alpha,
        )
        st.lagged = lag
        if not measured.is_finite():
            return self.estimate(mode)
        forget = math.exp(-dt_s / cfg.time_constant_s)
        # Turning in place: the commanded translation is (nearly) nil, so frozen by the bound.
        # Only a steady command teaches: while it changes, the motion measured mostly shows
        # the response delay (scrolls, EKF, link), not the ground.
        for fit, u, now, y, least in (
            (st.vx, lag.vx_mps, sent.vx_mps, measured.vx_mps, cfg.min_speed_mps),
            (st.vy, lag.vy_mps, sent.vy_mps, measured.vy_mps, cfg.min_speed_mps),
            (st.w, lag.wz_radps, sent.wz_radps, measured.wz_radps, cfg.min_yaw_rate_radps),
        ):
            if abs(u) >= least and abs(now - u) <= cfg.steady_tolerance * abs(u):
                fit.learn(u, self._clip(y, u, self._bounded(fit.k())), dt_s, forget)
                self._estimates.pop(mode, None)
        return self.estimate(mode)

    def _clip(self, y: float, u: float, k: float) -> float:
        """One sample's measured motion bounded to [0, max(max_fraction, 2·k)] of the command,
        ``k`` the current estimate: a late or noisy sample (moving against the command) weighs
        no more than "nothing delivered", and the window is symmetric about the estimate
        (k ± k) wherever the bound allows it, so clipping the noise's tails does not bias the
        fit. A fixed [0, max_fraction] window cut the upper tail only once the fraction
        neared 1: on hard ground (yaw 0.85) the yaw fit settled at 0.75."""
        hi_frac = max(self.cfg.max_fraction, 2.0 * k)
        lo, hi = sorted((0.0, hi_frac * u))
        return max(lo, min(hi, y))

    def gains(self, mode: MotionMode) -> tuple[float, float, float]:
        """Feed-forward factors (x, y, yaw): 1 / fraction within [1/max_fraction, max_gain];
        1 when the fraction is below ``stuck_fraction`` (a stall, not slip)."""
        est = self.estimate(mode)
        cfg = self.cfg
        return (
            feed_forward_gain(est.vx_frac, cfg),
            feed_forward_gain(est.vy_frac, cfg),
            feed_forward_gain(est.w_frac, cfg),
        )

    def compensate(self, mode: MotionMode, command: BodyVelocity) -> BodyVelocity:
        """The navigator's command divided by the delivered fraction (bounded), the translation
        kept in the direction commanded (:func:`same_direction`). A non-finite command (or one
        that overflows) comes back neutral: a NaN is never amplified."""
        if not command.is_finite():
            return BodyVelocity.zero()
        g_x, g_y, g_w = self.gains(mode)
        k_x = k_y = 1.0
        if mode is MotionMode.OMNI:  # ROLL and SCROLL drive one axis (the other is dropped)
            est = self.estimate(mode)
            k_x, k_y = same_direction(
                command.vx_mps,
                command.vy_mps,
                self._delivered(est.vx_frac, g_x),
                self._delivered(est.vy_frac, g_y),
                self.cfg.skew_share,
            )
        out = BodyVelocity(
            command.vx_mps * g_x * k_x, command.vy_mps * g_y * k_y, command.wz_radps * g_w
        )
        return out if out.is_finite() else BodyVelocity.zero()  # an absurd command overflowed

    def delivered(self, mode: MotionMode) -> tuple[float, float]:
        """What each translation axis (x, y) delivers of the navigator's command with the
        feed-forward (1: all): min(1, fraction · gain), 1 for a stalled axis. On grass
        SCROLL's scroll axis gets 0.25 of its command, 0.5 with the feed-forward's 2× cap."""
        est = self.estimate(mode)
        g_x, g_y, _ = self.gains(mode)
        return self._delivered(est.vx_frac, g_x), self._delivered(est.vy_frac, g_y)

    def _delivered(self, frac: float, gain: float) -> float:
        """What an axis delivers of the navigator's command with its feed-forward (1: all);
        a stalled axis counts as delivering all: the stall watchdog, not the skew, judges it."""
        if not frac >= self.cfg.stuck_fraction:
            return 1.0
        return min(1.0, frac * gain)


def feed_forward_gain(frac: float, cfg: SlipParams) -> float:
    """The factor an axis's command is multiplied by for a delivered fraction ``frac``:
    1 / frac within [1/max_fraction, max_gain]; 1 below ``stuck_fraction`` (a stall, not
    slip) or for a non-finite fraction."""
    if not frac >= cfg.stuck_fraction:
        return 1.0
    return min(cfg.max_gain, 1.0 / frac)


def same_direction(
    vx_mps: float, vy_mps: float, delivered_x: float, delivered_y: float, skew_share: float
) -> tuple[float, float]:
    """Factors (at most 1) for the two translation axes that keep the delivered translation
    in the direction commanded when one axis cannot be made up (on mud the roll axis gets
    30 %, 60 % with the 2× feed-forward, the scroll axis all of it): the axis that delivers
    more is slowed to the other's fraction, so the rover moves along the command at the lower
    speed instead of skewed off it (up to ~15° on a hexagon side in mud), which the guidance
    would only correct after the cross-track error it makes.

    While the axis that delivers less carries under ``skew_share`` of the command (|v| of the
    axis over |vx| + |vy|) the slowing ramps in from none, so the command stays continuous as
    its direction turns onto one axis. Only OMNI drives both axes: ROLL and SCROLL drop the
    other axis's command, so :meth:`SlipEstimator.compensate` keeps theirs as it is."""
    if not (0.0 < delivered_x < math.inf and 0.0 < delivered_y < math.inf):
        return 1.0, 1.0
    ax, ay = abs(vx_mps), abs(vy_mps)
    total = ax + ay
    if not (math.isfinite(total) and total > 0.0) or delivered_x == delivered_y:
        return 1.0, 1.0
    low_is_x = delivered_x < delivered_y
    low, high = (delivered_x, delivered_y) if low_is_x else (delivered_y, delivered_x)
    share = (ax if low_is_x else ay) / total
    ramp = 1.0 if share >= skew_share else share / skew_share
    k = 1.0 - (1.0 - low / high) * ramp
    return (1.0, k) if low_is_x else (k, 1.0)


__all__ = [
    "SlipEstimate",
    "SlipEstimator",
    "feed_forward_gain",
    "measured_body_velocity",
    "no_slip_body",
    "same_direction",
]
