"""How long a plan takes to fly: the navigator's own speed profile, integrated along the path.

Pure: numbers in, numbers out (no clock, no I/O). :func:`estimate_time` follows the rules
:mod:`helixd.control.navigator` flies by, on the ground the operator declared
(``control.slip.ground_*_fraction``; by default one that gives every command): the slip
feed-forward makes up what the ground takes up to ``control.slip.max_gain``, so an axis that
gets a fraction f of its command is delivered min(1, f · max_gain) of it
(:func:`delivered_fraction`), and the driving and the turns in place take that much longer
(OMNI: each leg at the lower of the two axes, :func:`along_fraction`). The rules:

* line guidance (the default): the corners as the navigator plans them
  (:func:`helixd.control.line.plan_corners`, shared with it): corners flown as arcs
  (``corner_error_m`` > 0) are driven along the arc — shorter than its two tangents — at the
  arc's speed, braked for to reach it at the arc's start, the leg ending at the arc's middle,
  with no turn in place; pivot corners, final headings, holds and the last waypoint are stops;
  without arcs gentle corners are flown at their corner speed. The speed command is the
  navigator's ``max(min_speed, min(cruise of the leg, distance PID, braking profile, corner
  being rounded))`` and changes by at most ``max_accel_mps2`` — the braking profile of
  :func:`helixd.control.line.profile_speed_mps` at ``braking_accel_mps2``, reached at an
  arc's start or ``tolerance`` before a flown-through waypoint, and held over the arc's second
  half or ``lookahead_m`` past the waypoint. The cruise of each leg is the one its
  DO_CHANGE_SPEED sets (:meth:`helixd.base.plan.Plan.leg_speeds_mps`); corners are planned
  for the plan's peak speed, as the navigator plans them;
* pivots in place (ROLL/SCROLL) where the heading error exceeds the pivot angle — at the
  start and at the stops — until it is below ``heading_threshold_rad``, with the yaw PID, the
  yaw-rate cap, the yaw-acceleration limit and the rate that can still brake; turns to a final
  heading until ``final_heading_tolerance_rad``;
* thesis guidance: the same pivots (at ``heading_threshold_rad``, no acceleration limits) and
  the thesis speed law (:func:`helixd.control.guidance.track_speed_mps` with the slow-down
  ramp and the corners' run-out, at each leg's cruise), each leg ending ``tolerance`` before
  its waypoint.

The speed profile is integrated in one dimension along the path (cross-track and the small
heading errors of TRACK are left out, as are the corners cut inside a waypoint's radius);
stretches at a constant speed are taken in one step, so a 100 000-waypoint plan costs
milliseconds. ``tests/control/test_estimate.py`` holds the estimate against the navigator
flown on an ideal plant and against flights in the built-in simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import lru_cache

from helixd.base.angles import shortest_angular_distance
from helixd.base.geometry import require_finite
from helixd.base.plan import MotionMode, Plan, PlanWaypoint
from helixd.control import guidance, line
from helixd.control.ground_cap import capped_leg_speeds_mps
from helixd.control.params import NavigatorParams, SlipParams
from helixd.control.slip import feed_forward_gain, same_direction

DT_S = 0.02  # integration step of the speed and yaw profiles (s)
TURN_QUANTUM_RAD = 1e-3  # turns are computed once per angle rounded to this (rad)
SPEED_FLOOR_MPS = 0.01  # below this nothing arrives: the estimate's own floor (m/s)
SAME_SPEED_MPS = 1e-9  # command and target equal within this: a constant-speed stretch
MAX_STEPS_PER_LEG = 1_000_000  # guard against a profile that never arrives


@dataclass(frozen=True, slots=True)
class TimeEstimate:
    """The estimate and what it is made of (seconds of autopilot time, metres)."""

    total_s: float
    driving_s: float  # translation, acceleration and braking included
    turning_s: float  # turns in place: alignment at the start, pivots, final headings
    path_length_m: float  # the polyline start → waypoint 0 → … → last waypoint
    pivots: int  # turns in place
    arrivals_s: tuple[float, ...]  # when each waypoint is reached (s from the start)


def estimate_time(
    plan: Plan,
    control: NavigatorParams,
    start_xy_m: tuple[float, float] | None = None,
    start_yaw_rad: float | None = None,
) -> TimeEstimate:
    """Time to fly ``plan`` from ``start_xy_m`` (mission frame) with the rover's yaw
    ``start_yaw_rad`` (None: its driving axis already along the first leg). ``start_xy_m``
    None: the first leg is not known yet (an ENU mission before preflight): the estimate
    begins at waypoint 0, reached, facing waypoint 1."""
    wps = plan.waypoints
    if not wps:
        return TimeEstimate(0.0, 0.0, 0.0, 0.0, 0, ())
    for w in wps:
        require_finite("plan waypoint", w.x_m, w.y_m, w.tolerance_m)
    pts = [(w.x_m, w.y_m) for w in wps]
    begin = pts[0] if start_xy_m is None else start_xy_m
    require_finite("start", *begin)
    if start_xy_m is None or start_yaw_rad is None:
        yaw0 = None
    else:
        require_finite("start yaw", start_yaw_rad)
        yaw0 = start_yaw_rad
    path = _Path([begin, *pts], [w.final_yaw_rad for w in wps], yaw0, plan.mode_at(0))
    ground = _Ground(control.slip, plan.mode_at(0))
    if control.guidance == "thesis":
        got = _Thesis(plan, control, path, ground).run()
    else:
        got = _Line(plan, control, path, ground).run()
    waits = plan.waits_s()  # a mission with commands: its holds and delays (at cruise speed)
    return got if waits <= 0.0 else replace(got, total_s=got.total_s + waits)


def delivered_fraction(ground_fraction: float, slip: SlipParams) -> float:
    """What an axis whose ground gives ``ground_fraction`` of the command delivers of the
    navigator's command: with the feed-forward min(1, f · max_gain) (none below
    ``stuck_fraction``: a stall), else f (:func:`helixd.control.slip.feed_forward_gain`)."""
    f = ground_fraction
    if not (math.isfinite(f) and f > 0.0):
        return SPEED_FLOOR_MPS  # nothing delivered: the estimate's own floor, never a 1/0
    gain = feed_forward_gain(f, slip) if slip.enabled else 1.0
    return min(1.0, f * gain)


def along_fraction(body_angle_rad: float, roll: float, scroll: float, skew_share: float) -> float:
    """The speed along a course ``body_angle_rad`` from body +x that a command of unit speed
    yields when the roll axis delivers ``roll`` and the scroll axis ``scroll`` of it, with the
    feed-forward keeping the command's direction (:func:`helixd.control.slip.same_direction`):
    ROLL (θ = 0) gets ``roll``, SCROLL (θ = 90°) ``scroll``, OMNI between the two axes the
    lower one (the delivered velocity projected on the course)."""
    c, s = math.cos(body_angle_rad), math.sin(body_angle_rad)
    k_x, k_y = same_direction(c, s, roll, scroll, skew_share)
    return c * c * roll * k_x + s * s * scroll * k_y


def delivered_fractions(mode: MotionMode, slip: SlipParams) -> tuple[float, float]:
    """(translation along the mode's driving axis, yaw rate) delivered on the declared ground
    with the feed-forward."""
    ground = _Ground(slip, mode)
    return ground.move(guidance.driving_axis_rad(mode), 0.0), ground.turn


class _Ground:
    """What the declared ground delivers of the navigator's command (1: all of it)."""

    def __init__(
        self,
        slip: SlipParams,
        mode: MotionMode,
        fractions: tuple[float, float, float] | None = None,
    ) -> None:
        self.mode = mode
        self.skew_share = slip.skew_share if slip.enabled else 0.0
        roll, scroll, yaw = fractions or (
            slip.ground_roll_fraction,
            slip.ground_scroll_fraction,
            slip.ground_yaw_fraction,
        )
        self.roll = delivered_fraction(roll, slip)
        self.scroll = delivered_fraction(scroll, slip)
        self.turn = delivered_fraction(yaw, slip)

    def move(self, course_rad: float, heading_rad: float) -> float:
        """Along a leg of course ``course_rad`` with the body's +x at ``heading_rad``."""
        if self.mode is not MotionMode.OMNI:  # one axis: the one it drives along
            return self.scroll if self.mode is MotionMode.SCROLL else self.roll
        if self.roll == self.scroll:
            return self.roll
        if self.skew_share <= 0.0:  # no feed-forward: the guidance steers against the skew
            theta = course_rad - heading_rad
            return 1.0 / math.hypot(math.cos(theta) / self.roll, math.sin(theta) / self.scroll)
        return along_fraction(course_rad - heading_rad, self.roll, self.scroll, self.skew_share)


def _ground_for(first: _Ground, mode: MotionMode, slip: SlipParams) -> _Ground:
    """The declared ground as a leg in ``mode`` meets it (the first leg's, when the same)."""
    return first if mode is first.mode else _Ground(slip, mode)


def _leg_ground(first: _Ground, wp: PlanWaypoint, mode: MotionMode, slip: SlipParams) -> _Ground:
    """The ground of the leg to ``wp``: what the rover learnt of it (``wp.ground``), else the
    declared ground."""
    if wp.ground is None:
        return _ground_for(first, mode, slip)
    return _Ground(slip, mode, wp.ground)


# -- the path ----------------------------------------------------------------------------------


class _Path:
    """Start + waypoints: leg lengths, arc length at each point, leg courses, headings."""

    def __init__(
        self,
        points: list[tuple[float, float]],
        final_yaw_rad: list[float | None],
        start_yaw_rad: float | None,
        mode: MotionMode,
    ) -> None:
        self.points = points
        self.final_yaw_rad = final_yaw_rad
        self.mode = mode
        self.axis_rad = guidance.driving_axis_rad(mode)
        n = len(points) - 1
        self.lengths = [math.dist(points[j], points[j + 1]) for j in range(n)]
        self.s = [0.0]
        for length in self.lengths:
            self.s.append(self.s[-1] + length)
        # course of each leg; a degenerate leg keeps the course of the one before (or after)
        courses: list[float | None] = [
            math.atan2(points[j + 1][1] - points[j][1], points[j + 1][0] - points[j][0])
            if self.lengths[j] >= line.MIN_LEG_M
            else None
            for j in range(n)
        ]
        known = next((c for c in courses if c is not None), 0.0)
        filled: list[float] = []
        for c in courses:
            known = known if c is None else c
            filled.append(known)
        self.courses = filled
        # the heading the rover starts with (None: aligned with its first real leg)
        self.start_yaw_rad = (
            start_yaw_rad if start_yaw_rad is not None else self.courses[0] - self.axis_rad
        )

    @property
    def length_m(self) -> float:
        return self.s[-1]


@lru_cache(maxsize=4096)
def _turn_s(
    angle_rad: float,
    until_rad: float,
    kp: float,
    kd: float,
    max_rate_radps: float,
    max_accel_radps2: float | None,
) -> float:
    """Turning in place from rest through ``angle_rad`` until the error is below
    ``until_rad``: the yaw PID (derivative on the measurement), the rate cap and — with
    ``max_accel_radps2`` (line guidance) — the rate that can still brake and the acceleration
    limit, stepped as the navigator steps them."""
    e, w, t = angle_rad, 0.0, 0.0
    for _ in range(MAX_STEPS_PER_LEG):
        if e <= until_rad:
            break
        out = max(-max_rate_radps, min(max_rate_radps, kp * e - kd * w))
        if max_accel_radps2 is None:
            w = out
        else:
            out = line.stoppable_yaw_rate_radps(out, e, max_accel_radps2)
            w = line.step_toward(w, out, max_accel_radps2 * DT_S)
        if w <= 0.0 and kp * e <= 0.0:
            return math.inf  # nothing turns the rover
        e -= w * DT_S
        t += DT_S
    return t


def _turn_time_s(
    angle_rad: float, until_rad: float, control: NavigatorParams, limited: bool
) -> float:
    quantised = math.ceil(abs(angle_rad) / TURN_QUANTUM_RAD) * TURN_QUANTUM_RAD
    pid = control.yaw_pid
    return _turn_s(
        quantised,
        until_rad,
        pid.kp,
        pid.kd,
        control.max_yaw_rate_radps,
        control.max_yaw_accel_radps2 if limited else None,
    )


@dataclass(slots=True)
class _Tally:
    """What an estimate adds up, waypoint by waypoint (seconds of autopilot time): turns in
    place with the yaw-acceleration limit (line guidance) or without it (thesis guidance)."""

    control: NavigatorParams
    limited: bool
    driving_s: float = 0.0
    turning_s: float = 0.0
    pivots: int = 0
    arrivals_s: list[float] = field(default_factory=list)

    def pivot(self, angle_rad: float, until_rad: float, turn_fraction: float) -> None:
        """A turn in place through ``angle_rad`` until ``until_rad`` off, on ground that
        delivers ``turn_fraction`` of the yaw command."""
        dt = _turn_time_s(angle_rad, until_rad, self.control, self.limited)
        self.turning_s += dt / turn_fraction
        self.pivots += 1

    def final_heading(self, heading_rad: float, final_rad: float, turn_fraction: float) -> bool:
        """The turn to a waypoint's final heading, if it is off by more than its tolerance;
        whether there was one."""
        e = abs(shortest_angular_distance(heading_rad, final_rad))
        until_rad = self.control.final_heading_tolerance_rad
        if e > until_rad:
            self.pivot(e, until_rad, turn_fraction)
            return True
        return False

    def arrived(self) -> None:
        self.arrivals_s.append(self.driving_s + self.turning_s)

    def estimate(self, path_length_m: float) -> TimeEstimate:
        return TimeEstimate(
            self.driving_s + self.turning_s,
            self.driving_s,
            self.turning_s,
            path_length_m,
            self.pivots,
            tuple(self.arrivals_s),
        )


# -- line guidance -----------------------------------------------------------------------------


class _Line:
    """The line guidance's profile (see the module docstring)."""

    def __init__(self, plan: Plan, control: NavigatorParams, path: _Path, ground: _Ground) -> None:
        self.plan, self.control, self.path, self.ground = plan, control, path, ground
        # per leg: DO_CHANGE_SPEED sets it, the ground's cap bounds it (control.ground_cap)
        self.cruise = capped_leg_speeds_mps(plan)
        self.floor = max(control.min_speed_mps, SPEED_FLOOR_MPS)
        self.brake = control.braking_accel_mps2
        wps = plan.waypoints
        corners = line.waypoint_corners(path.points, wps, plan.peak_speed_mps, control)
        self.speeds, self.stops, self.arcs = corners.speeds_mps, corners.stops, corners.arcs
        n = len(wps)
        tangent = [0.0 if a is None else a.tangent_m for a in self.arcs]
        self.half_arc_m = [
            0.0 if a is None else a.radius_m * abs(a.turn_rad) / 2 for a in self.arcs
        ]
        # Arc length along the path flown of each path point: a corner rounded on an arc is
        # at the arc's middle (where its leg ends), the arc being shorter than its tangents.
        self.at = [0.0]
        for j in range(n):
            arc_out_m, tangent_out_m = (self.half_arc_m[j - 1], tangent[j - 1]) if j else (0, 0)
            straight_m = max(0.0, path.lengths[j] - tangent_out_m - tangent[j])
            self.at.append(self.at[j] + arc_out_m + straight_m + self.half_arc_m[j])
        self.leg_end = [
            self.at[j + 1]
            - (0.0 if self.stops[j] or self.arcs[j] is not None else wps[j].tolerance_m)
            for j in range(n)
        ]
        # where each waypoint's pass speed must be reached: its arc's start, else its leg's end
        self.arc_in = [
            self.at[j + 1] - self.half_arc_m[j] if self.arcs[j] is not None else math.inf
            for j in range(n)
        ]
        reach = [min(self.arc_in[j], self.leg_end[j]) for j in range(n)]
        # Braking: the profile at arc length s on leg j is √(M_j − 2·b·s), M_j the smallest
        # u_k² + 2·b·reach_k over the waypoints k ≥ j up to the next stop (``after``: k > j, on
        # the arc ending leg j, where its own speed is held).
        self.brake_m = [0.0] * n
        self.after_m = [math.inf] * n
        self.stop_s = [0.0] * n  # arc length of the next stop (the distance PID's goal)
        for j in range(n - 1, -1, -1):
            own = self.speeds[j] ** 2 + 2.0 * self.brake * reach[j]
            last = self.stops[j] or j == n - 1
            self.after_m[j] = math.inf if last else self.brake_m[j + 1]
            self.brake_m[j] = min(own, self.after_m[j])
            self.stop_s[j] = self.at[j + 1] if last else self.stop_s[j + 1]

    def run(self) -> TimeEstimate:
        path, control = self.path, self.control
        enter = max(control.pivot_angle_rad, control.heading_threshold_rad)
        tally = _Tally(control, limited=True)
        heading = path.start_yaw_rad
        v = 0.0
        s = 0.0
        for j in range(len(self.plan.waypoints)):
            # each leg in its own mode (the mode follows the medium): its axis and its ground
            mode = self.plan.mode_at(j)
            ground = _leg_ground(self.ground, self.plan.waypoints[j], mode, control.slip)
            axis_rad = guidance.driving_axis_rad(mode)
            course = path.courses[j]
            rounded = j > 0 and self.arcs[j - 1] is not None  # the arc turned the rover
            if path.lengths[j] >= line.MIN_LEG_M and mode is not MotionMode.OMNI:
                e = abs(shortest_angular_distance(heading, course - axis_rad))
                if e > enter and not rounded:  # ALIGN: the translation decays while it pivots
                    tally.pivot(e, control.heading_threshold_rad, ground.turn)
                    v = 0.0
                heading = course - axis_rad
            elif j > 0 and self.stops[j - 1]:  # OMNI leaving a stop: keep what points ahead
                v *= max(0.0, math.cos(course - path.courses[j - 1]))
            s, v, dt = self._drive(j, s, v)
            tally.driving_s += dt / ground.move(course, heading)
            tally.arrived()
            final = path.final_yaw_rad[j]
            if final is not None and mode is not MotionMode.OMNI:
                if tally.final_heading(heading, final, ground.turn):
                    v = 0.0
                heading = final
        return tally.estimate(path.length_m)

    def _target(self, j: int, s: float, v: float, m: float, cap: float) -> tuple[float, float, str]:
        """The speed command the navigator aims at, at arc length ``s`` on leg ``j`` (braking
        profile √(m − 2·b·s), at most ``cap``); the arc length up to which
        that target stays the same; and what sets it: ``"cap"`` (cruise, the corner being
        rounded, or the floor: constant), ``"profile"`` (braking) or ``"pid"`` (the distance
        PID close to a stop)."""
        control = self.control
        kp, kd = control.distance_pid.kp, control.distance_pid.kd
        profile = math.sqrt(max(0.0, m - 2.0 * self.brake * s))
        pid = kp * max(0.0, self.stop_s[j] - s) - kd * v
        until = math.inf
        if j > 0:  # still rounding the corner just passed: its arc, else about L past it
            rounding_m = control.lookahead_m if self.arcs[j - 1] is None else self.half_arc_m[j - 1]
            corner_end = self.at[j] + rounding_m
            if 0.0 < self.speeds[j - 1] < cap and s < corner_end:
                cap, until = self.speeds[j - 1], corner_end
        if min(profile, pid) < self.floor:
            return self.floor, math.inf, "cap"  # both only fall: the floor holds to the end
        if cap < self.floor:
            return self.floor, until, "cap"
        if profile < cap and profile <= pid:
            return profile, s, "profile"
        if pid < cap:
            return pid, s, "pid"
        # constant until the profile or the PID falls below the cap
        if self.brake > 0.0:
            until = min(until, (m - cap * cap) / (2.0 * self.brake))
        if kp > 0.0:
            until = min(until, self.stop_s[j] - cap * (1.0 + kd) / kp)
        return cap, until, "cap"

    def _pid_ok(self, j: int, s: float, v: float) -> bool:
        """The distance PID still allows ``v`` at ``s`` (it only falls as s and v grow)."""
        pid = self.control.distance_pid
        return pid.kp * (self.stop_s[j] - s) - pid.kd * v >= v

    def _accelerate(
        self, j: int, s: float, v: float, target: float, until: float, end: float, m: float
    ) -> tuple[float, float, float] | None:
        """At ``max_accel`` from ``v`` until the command meets the cap or the braking profile
        √(m − 2·b·s): (s, v, time), or None when the PID would bite first (stepped instead)."""
        a, b = self.control.max_accel_mps2, self.brake
        x = (target * target - v * v) / (2.0 * a)
        x = min(x, (m - 2.0 * b * s - v * v) / (2.0 * (a + b)), until - s, end - s)
        if x <= 0.0:
            return None
        v1 = math.sqrt(v * v + 2.0 * a * x)
        if not self._pid_ok(j, s + x, v1):
            return None
        return s + x, v1, (v1 - v) / a

    def _follow_profile(
        self, j: int, s: float, v: float, end: float, m: float
    ) -> tuple[float, float, float] | None:
        """Braking along √(m − 2·b·s) until the PID or the floor takes over or ``end``."""
        b, stop = self.brake, self.stop_s[j]
        pid = self.control.distance_pid
        c = 1.0 + pid.kd
        c0 = m - 2.0 * b * stop
        s_next = min(end, (m - self.floor**2) / (2.0 * b))
        if pid.kp > 0.0:
            # kp·(S − s) = (1 + kd)·√(M − 2·b·s): with y = S − s, kp²y² − 2b·c²·y − c²·c0 = 0
            disc = (b * c * c) ** 2 + pid.kp**2 * c * c * c0
            if disc >= 0.0:
                y = (b * c * c + math.sqrt(disc)) / pid.kp**2
                s_next = min(s_next, stop - y)
        if s_next <= s:
            return None
        v1 = math.sqrt(max(0.0, m - 2.0 * b * s_next))
        return s_next, v1, (v - v1) / b

    def _drive(self, j: int, s: float, v: float) -> tuple[float, float, float]:
        """Drive leg ``j`` from arc length ``s`` at speed ``v`` to its end: (s, v, time).

        A leg ending in a corner arc is driven in two stretches: up to the arc, braking for
        the arc's speed, then on the arc's first half at that speed."""
        t = 0.0
        cruise = self.cruise[j]
        arc_in = self.arc_in[j]
        if s < min(arc_in, self.leg_end[j]):
            s, v, t = self._stretch(j, s, v, min(arc_in, self.leg_end[j]), self.brake_m[j], cruise)
        if s < self.leg_end[j]:
            on_arc = min(cruise, self.speeds[j])
            s, v, dt = self._stretch(j, s, v, self.leg_end[j], self.after_m[j], on_arc)
            t += dt
        return s, v, t

    def _stretch(
        self,
        j: int,
        s: float,
        v: float,
        end: float,
        m: float,
        cap: float,
    ) -> tuple[float, float, float]:
        """Drive from arc length ``s`` at speed ``v`` to ``end`` on leg ``j`` under the
        braking profile √(m − 2·b·s) and at most ``cap``: (s, v, time).

        Constant speed, acceleration to a cap and braking along the profile are taken in
        closed form; the rest (the PID's last metres, changes of the binding limit) in
        ``DT_S`` steps of the navigator's acceleration-limited command."""
        t = 0.0
        step = self.control.max_accel_mps2 * DT_S
        for _ in range(MAX_STEPS_PER_LEG):
            if s >= end:
                break
            target, until, kind = self._target(j, s, v, m, cap)
            if abs(v - target) <= SAME_SPEED_MPS and until > s and v > 0.0:
                reach = min(until, end)
                t += (reach - s) / v
                s = reach
                continue
            jump = None
            if v < target and kind == "cap":
                jump = self._accelerate(j, s, v, target, until, end, m)
            elif v < target and kind == "profile":
                jump = self._accelerate(j, s, v, math.inf, until, end, m)
            elif kind == "profile" and abs(v - target) <= SAME_SPEED_MPS and self.brake > 0.0:
                jump = self._follow_profile(j, s, v, end, m)
            if jump is not None:
                s, v, dt = jump
                t += dt
                continue
            v = line.step_toward(v, target, step)
            ds = v * DT_S
            if s + ds >= end:
                t += (end - s) / v if v > 0.0 else DT_S
                s = end
                break
            s += ds
            t += DT_S
        else:
            return end, v, math.inf
        return max(s, end), v, t


# -- thesis guidance ---------------------------------------------------------------------------


class _Thesis:
    """The thesis law: turn to the waypoint, drive at it, reached ``tolerance`` before it."""

    def __init__(self, plan: Plan, control: NavigatorParams, path: _Path, ground: _Ground) -> None:
        self.plan, self.control, self.path, self.ground = plan, control, path, ground

    def run(self) -> TimeEstimate:
        plan, control, path = self.plan, self.control, self.path
        wps = plan.waypoints
        run_out = guidance.run_out_m(
            path.points,
            [w.final_yaw_rad is not None or w.stop for w in wps],
            control.corner_slowdown_rad,
        )
        cruise = capped_leg_speeds_mps(plan)  # per leg: DO_CHANGE_SPEED, the ground's cap
        here = path.points[0]
        heading = path.start_yaw_rad
        tally = _Tally(control, limited=False)
        for j, wp in enumerate(wps):
            mode = plan.mode_at(j)  # each leg in its own mode
            ground = _leg_ground(self.ground, wp, mode, control.slip)
            axis_rad = guidance.driving_axis_rad(mode)
            goal = (wp.x_m, wp.y_m)
            distance = math.dist(here, goal)
            if distance >= wp.tolerance_m:
                course = math.atan2(goal[1] - here[1], goal[0] - here[0])
                if mode is not MotionMode.OMNI:
                    e = abs(shortest_angular_distance(heading, course - axis_rad))
                    if e > control.heading_threshold_rad:
                        tally.pivot(e, control.heading_threshold_rad, ground.turn)
                    heading = course - axis_rad
                leg_s = self._leg_s(distance, wp.tolerance_m, run_out[j], cruise[j])
                tally.driving_s += leg_s / ground.move(course, heading)
                k = (distance - wp.tolerance_m) / distance
                here = (here[0] + (goal[0] - here[0]) * k, here[1] + (goal[1] - here[1]) * k)
            tally.arrived()
            final = path.final_yaw_rad[j]
            if final is not None and mode is not MotionMode.OMNI:
                tally.final_heading(heading, final, ground.turn)
                heading = final
        return tally.estimate(path.length_m)

    def _leg_s(
        self, distance_m: float, tolerance_m: float, run_out_m: float, cruise: float
    ) -> float:
        """From ``distance_m`` to ``tolerance_m`` off the waypoint at the thesis speed law,
        cruising at ``cruise`` (m/s)."""
        control = self.control
        kp = control.distance_pid.kp
        full = max(control.slowdown_radius_m, cruise / kp if kp > 0.0 else math.inf)
        e, t = distance_m, 0.0
        free = e + run_out_m - full  # distance at cruise before the ramp or the PID bites
        if free > 0.0:
            cruise_m = min(free, e - tolerance_m)
            t += cruise_m / cruise
            e -= cruise_m
        ds = cruise * DT_S
        for _ in range(MAX_STEPS_PER_LEG):
            if e <= tolerance_m:
                break
            e_go = e + run_out_m
            v = guidance.track_speed_mps(
                min(cruise, kp * e_go),
                e_go,
                tolerance_m,
                cruise,
                control.slowdown_radius_m,
                control.min_speed_mps,
            )
            v = max(v, SPEED_FLOOR_MPS)
            step = min(ds, e - tolerance_m)
            t += step / v
            e -= step
        return t


__all__ = [
    "TimeEstimate",
    "along_fraction",
    "delivered_fraction",
    "delivered_fractions",
    "estimate_time",
]
