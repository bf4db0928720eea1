"""Waypoint navigator: the state machine of thesis Algorithm 2, with the limit cycle fixed.

    IDLE → ALIGN ⇄ TRACK → REACHED → [FINAL_HEADING] → next waypoint … → DONE

* ALIGN (ROLL/SCROLL only): turn in place, ω = PID_yaw(e_ψ), while |e_ψ| > threshold.
* TRACK: v = PID_dist(e_d) limited by the plan speed and a slow-down ramp (floor v_min
  outside tolerance); ω = PID_yaw(e_ψ) capped. If |e_ψ| grows past the threshold (a goal
  close beside the rover, inside its turning circle) the rover re-aligns in place instead
  of orbiting the goal — the limit cycle the thesis warns about.
* REACHED: e_d < tolerance. Reported for that one step, whose output describes the arrival
  (target_index = reached_index, distance_error_m = arrival error); the PIDs are reset and
  the step's command already serves what comes next (no stop-and-go at every waypoint).
* FINAL_HEADING: turn in place to the waypoint's final yaw, if it has one (not in OMNI,
  whose mode constraint forbids turning).
* DONE: zero command forever.

Two guidance laws, chosen by ``control.guidance``:

* ``"thesis"`` — exactly the behaviour above: steer the driving axis at the waypoint.
* ``"line"`` (default) — the same states, but the rover follows the leg (previous waypoint,
  or the start pose, → waypoint) with the lookahead law of :mod:`helixd.control.line`;
  ROLL/SCROLL steer their driving axis onto it, OMNI holds its heading and adds a lateral
  velocity. A leg ends inside the waypoint's pass-through radius or on crossing the line
  through the waypoint perpendicular to the leg. Stops — the final waypoint, waypoints with
  a final heading and corners sharper than ``pivot_angle_rad`` — end on that line within
  ``stop_tolerance_m`` (pivot corners: within the waypoint tolerance), approached along a
  braking profile at ``min_speed_mps`` at the last; a stop passed farther beside is flown to
  as a point. TRACK re-aligns in place (ALIGN) when |e_ψ| exceeds the pivot angle and leaves
  ALIGN below ``heading_threshold_rad``. Gentle corners are flown at the turn-geometry speed,
  collinear ones at cruise. Translation and yaw-rate commands are acceleration limited.

  With a corner error budget (``corner_error_m`` > 0, the default) every corner that is not a
  stop is flown as an arc tangent to both legs (:func:`line.corner_arc`: the largest radius
  within the budget and the waypoint's tolerance that fits on half of each leg), at the speed
  ``max_lateral_accel`` and the yaw-rate limit allow on it, planned by
  :func:`line.plan_corners` (shared with the time estimate); the arc's yaw rate v/R is fed
  forward, ramped at the yaw acceleration limit (:func:`line.arc_blend`), and its leg ends on
  the corner's bisector. A corner whose arc would be flown below ``min_speed_mps`` is a pivot
  stop. Without a budget corners sharper than ``pivot_angle_rad`` are pivots.

A mission with commands (:class:`~helixd.base.plan.Program`) adds three things, set by the
flight loop from :mod:`helixd.control.sequencer`: waypoints flagged ``stop`` (a hold, a delay
or a return follows) are stops like the final one; :meth:`Navigator.set_speed` changes the
cruise speed from the next step on (DO_CHANGE_SPEED: the corner and braking speeds are planned
for the highest speed the program may set and capped by the current one, so a slower stretch
brakes with the acceleration limits); :meth:`Navigator.set_reverse` drives the mode's axis
backwards (DO_SET_REVERSE; OMNI has no axis and ignores it). Without a program all three stay
at the plan's values and nothing changes.

A plan with a mode per waypoint (:attr:`PlanWaypoint.mode`, the mode follows the medium:
:mod:`helixd.planning.media_modes`) flies each leg in its own mode (:attr:`Navigator.mode`);
where the mode changes the waypoint is a stop, the change waits (scrolls stopped, at most
``mode_change_wait_s``) until the measured speed (:meth:`Navigator.set_measured_speed`) is at
most ``mode_change_speed_mps``, and the next leg starts with a turn in place (ALIGN).

Stepped with (pose, t_s); derives dt from successive t_s. Never touches a clock or a socket,
and never decides to stop the vehicle: the supervisor owns that.

Total: a non-finite pose or time raises :class:`NonFiniteError` before any state changes (the
flight loop sends neutral and reports ``pose_invalid``); a non-finite command is never output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import StrEnum

from helixd.base.angles import shortest_angular_distance, wrap_pi
from helixd.base.geometry import BodyVelocity, NonFiniteError, Pose2D, require_finite
from helixd.base.plan import MotionMode, Plan, PlanWaypoint
from helixd.control import guidance, line
from helixd.control.ground_cap import leg_cruise_mps
from helixd.control.kinematics import constrain
from helixd.control.params import NavigatorParams
from helixd.control.pid import PID, PidTerms


class NavState(StrEnum):
    IDLE = "idle"
    ALIGN = "align"
    TRACK = "track"
    REACHED = "reached"
    FINAL_HEADING = "final_heading"
    DONE = "done"


@dataclass(frozen=True, slots=True)
class NavOutput:
    """What one navigator step produced (for the actuators and the flight recorder)."""

    command: BodyVelocity
    state: NavState
    target_index: int  # waypoint the errors refer to: being flown to, just reached, or last
    waypoints_reached: int
    reached_index: int | None  # waypoint reached on this very step, else None
    distance_error_m: float  # e_d to target_index (on the REACHED step: the arrival error)
    heading_error_rad: float  # e_ψ in (−π, π]; 0 in OMNI; to the final yaw in FINAL_HEADING
    cross_track_m: float  # signed distance from the current leg, + left of it
    distance_pid: PidTerms
    yaw_pid: PidTerms
    done: bool


@dataclass(frozen=True)
class _HeadingGoal:
    """Where line guidance points the driving axis: the heading (rad), how far the rover's
    heading is off it (rad) and the curvature whose yaw rate is fed forward (1/m)."""

    goal_rad: float
    e_psi_rad: float
    curvature_per_m: float


class Navigator:
    """Flies ``plan`` waypoint by waypoint. One instance per mission run."""

    def __init__(self, plan: Plan, control: NavigatorParams) -> None:
        if not plan.waypoints:
            raise ValueError(f"plan '{plan.name}' has no waypoints")
        if plan.leg_start_xy_m is not None:
            require_finite("plan leg start", *plan.leg_start_xy_m)
        self.plan = plan
        self.control = control
        # corner speeds and the distance PID allow the highest speed the program may set; the
        # current cruise speed caps every step (DO_CHANGE_SPEED changes it)
        self._peak_speed_mps = plan.peak_speed_mps
        self._cruise_mps = plan.speed_mps
        self._reverse = False
        self._mode_override: MotionMode | None = None  # override_mode
        # the fraction of the commanded speed the ground delivers (set_delivered_fraction)
        self._delivered_fraction = 1.0
        # the measured ground speed (set_measured_speed; None: unknown) and the stop where a
        # change of mode waits for it: (target index, seconds waited)
        self._measured_speed_mps: float | None = None
        self._settle: tuple[int, float] | None = None
        self._released = False
        self._distance_pid = PID(control.distance_pid, output_limit=self._peak_speed_mps)
        self._yaw_pid = PID(control.yaw_pid, output_limit=control.max_yaw_rate_radps, angular=True)
        self._state = NavState.IDLE
        self._target_index = 0
        self._waypoints_reached = 0
        self._final_heading_pending = False
        self._leg_start_xy_m: tuple[float, float] | None = plan.leg_start_xy_m
        self._last_t_s: float | None = None
        self._run_out_m: list[float] | None = None  # filled at the first step (needs the start)
        # Line guidance: path points (start pose first), per-waypoint pass speeds and stops,
        # and the previous command for the acceleration limits.
        self._line = control.guidance == "line"
        self._points_xy_m: list[tuple[float, float]] = []
        self._pass_speed_mps: list[float] = []
        self._stops: list[bool] = []
        self._early_m: list[float] = []  # per waypoint: its speed limit holds this early (m)
        self._arcs: list[line.CornerArc | None] = []  # per waypoint: the arc of its corner
        self._horizon_m = math.inf  # how far ahead the speed profile looks (m)
        self._prev_command = BodyVelocity.zero()
        # The yaw rate the rover delivers of the commands sent (line guidance): the yaw-rate
        # command low-passed by the scrolls' response lag (control.slip.command_lag_s)
        self._yaw_rate_model_radps = 0.0
        # the crew's pause just ended (:meth:`resume`): the next step may take a change of
        # mode the rover passed while it was held where it stands
        self._resumed = False
        # (pose, leg start, goal, errors) of the last leg_errors: the arrival test and the
        # guidance of one step read the same leg (all immutable: identity is the key)
        self._leg_memo: (
            tuple[Pose2D, tuple[float, float] | None, PlanWaypoint, line.LegErrors] | None
        ) = None

    # -- public state ------------------------------------------------------------------------

    @property
    def state(self) -> NavState:
        return self._state

    @property
    def target_index(self) -> int:
        return min(self._target_index, len(self.plan.waypoints) - 1)

    @property
    def waypoints_reached(self) -> int:
        return self._waypoints_reached

    @property
    def done(self) -> bool:
        return self._state is NavState.DONE

    @property
    def mode(self) -> MotionMode:
        """The motion mode of the leg being flown (the plan's one mode, or the current
        stretch's where the plan has a mode per waypoint: it changes at a stop)."""
        if self._mode_override is not None:
            return self._mode_override
        return self.plan.mode_at(self.target_index)

    def override_mode(self, mode: MotionMode | None) -> None:
        """Fly ``mode`` instead of the plan's from the next step until the current target is
        reached (None: the plan's again). The ground is not what the map says
        (:mod:`helixd.control.ground_check`): a change of axis starts with a turn in place."""
        self._mode_override = mode

    @property
    def cruise_speed_mps(self) -> float:
        return self._cruise_mps

    @property
    def reverse(self) -> bool:
        return self._reverse

    def set_speed(self, speed_mps: float) -> None:
        """Cruise at ``speed_mps`` from the next step on (0 < speed ≤ the plan's peak speed)."""
        if not (math.isfinite(speed_mps) and 0.0 < speed_mps <= self._peak_speed_mps):
            raise ValueError(
                f"cruise speed {speed_mps} m/s outside (0, {self._peak_speed_mps}] m/s"
            )
        self._cruise_mps = speed_mps

    def _leg_cruise_mps(self) -> float:
        """The cruise, at most the cap of the leg's ground in its planned mode (not when the
        ground check flies another: :mod:`helixd.control.ground_cap`)."""
        if self._mode_override is not None:
            return self._cruise_mps
        return leg_cruise_mps(self._cruise_mps, self.plan.waypoints[self.target_index])

    def set_reverse(self, reverse: bool) -> None:
        """Drive the mode's axis backwards (ROLL −x, SCROLL −y) from the next step on."""
        self._reverse = reverse and self.mode is not MotionMode.OMNI

    def set_delivered_fraction(self, fraction: float) -> None:
        """The fraction of the commanded speed the ground delivers (after the slip
        feed-forward; 1: all, the default), from the next step on. An arc's yaw rate v/R is
        fed forward at the delivered v: at the commanded one, a rover delivering 0.9 of it
        (SCROLL on hard ground, the feed-forward capped) turns on a 0.9·R circle and cuts
        inside the arc. Anything outside (0, 1] counts as 1."""
        ok = math.isfinite(fraction) and 0.0 < fraction <= 1.0
        self._delivered_fraction = fraction if ok else 1.0

    def standing(self, pose: Pose2D) -> NavOutput:
        """What a step spent standing (a hold of the mission) reports: nothing commanded,
        the errors to the current target, the state unchanged."""
        require_finite("navigator pose", pose.x_m, pose.y_m, pose.yaw_rad)
        goal = self.plan.waypoints[self.target_index]
        return NavOutput(
            command=BodyVelocity.zero(),
            state=self._state,
            target_index=self.target_index,
            waypoints_reached=self._waypoints_reached,
            reached_index=None,
            distance_error_m=line.distance_to_m(pose, goal),
            heading_error_rad=0.0,
            cross_track_m=0.0,
            distance_pid=PidTerms.zero(),
            yaw_pid=PidTerms.zero(),
            done=self.done,
        )

    def resume(self) -> None:
        """The flight goes on after a pause (the crew's HOLD, the scrolls held at neutral): the
        rover stood, so the next step starts from rest, and it re-enters the plan where it
        stands. Before a stop where the mode changes it drives on to the stop and turns
        there, as planned; if it rolled past the stop while held (its line crossed, within
        the waypoint's tolerance of it: a media map puts the stop
        ``media.transition_margin_m``, 1 m, before the new medium, so the ground under it
        is still the ground the turn was planned on) the stop is reached where it stands and
        the turn is made there, instead of flying back to the point (a turn about, and the
        old mode driven on the ground it was leaving)."""
        self._reset_pids()
        self._prev_command = BodyVelocity.zero()
        self._yaw_rate_model_radps = 0.0
        self._resumed = True

    # -- the step ----------------------------------------------------------------------------

    def step(self, pose: Pose2D, t_s: float) -> NavOutput:
        """Advance the state machine with a new pose at autopilot time ``t_s`` (seconds).

        Raises :class:`NonFiniteError` (state untouched) on a non-finite pose or time."""
        require_finite("navigator pose/time", pose.x_m, pose.y_m, pose.yaw_rad, t_s)
        dt_s = self._dt(t_s)
        if self._leg_start_xy_m is None:
            self._leg_start_xy_m = (pose.x_m, pose.y_m)
        if self._run_out_m is None:
            wps = self.plan.waypoints
            self._run_out_m = guidance.run_out_m(
                [self._leg_start(pose)] + [(w.x_m, w.y_m) for w in wps],
                [w.final_yaw_rad is not None or w.stop for w in wps],
                self.control.corner_slowdown_rad,
            )
            if self._line:
                self._plan_line(pose)

        arrival: NavOutput | None = None
        resumed, self._resumed = self._resumed, False
        if not self._final_heading_pending and self._target_index < len(self.plan.waypoints):
            goal = self._goal()
            waiting = self._wait_at_change(pose, goal, dt_s)
            if waiting is not None:
                return waiting
            reached = self._released or self._is_reached(pose, goal)  # waited, done waiting
            if reached or (resumed and self._passed_change(pose, goal)):
                arrival = self._arrival(pose, goal)
                self._waypoints_reached += 1
                self._reset_pids()
                self._final_heading_pending = (
                    goal.final_yaw_rad is not None and self.mode is not MotionMode.OMNI
                )
        if self._final_heading_pending:
            waypoint_finished = self._final_heading_done(pose)
        else:
            waypoint_finished = arrival is not None
        if waypoint_finished:
            self._next_waypoint()

        output = self._act(pose, dt_s)
        if arrival is None:
            return output
        # The REACHED row describes the arrival; its command already serves what comes next.
        self._state = NavState.REACHED
        return replace(
            arrival,
            command=output.command,
            waypoints_reached=self._waypoints_reached,
            distance_pid=output.distance_pid,
            yaw_pid=output.yaw_pid,
        )

    # -- behaviours --------------------------------------------------------------------------

    def _act(self, pose: Pose2D, dt_s: float) -> NavOutput:
        if self._target_index >= len(self.plan.waypoints):
            self._state = NavState.DONE
            final_error_m = line.distance_to_m(pose, self.plan.waypoints[-1])
            return self._output(pose, BodyVelocity.zero(), final_error_m, 0.0)
        final_yaw_rad = self._goal().final_yaw_rad
        if self._final_heading_pending and final_yaw_rad is not None:
            return self._turn_to_final_heading(pose, dt_s, final_yaw_rad)
        if self._line:
            return self._follow_line(pose, dt_s)
        return self._go_to_goal(pose, dt_s)

    def _go_to_goal(self, pose: Pose2D, dt_s: float) -> NavOutput:
        goal = self._goal()
        mode = self.mode
        errors = guidance.compute_errors(pose, goal, mode, self._reverse)
        e_d, e_psi = errors.distance_error_m, errors.heading_error_rad

        must_align = mode is not MotionMode.OMNI and abs(e_psi) > self.control.heading_threshold_rad
        if must_align:
            if self._state is not NavState.ALIGN:
                self._distance_pid.reset()  # its memory is stale after a turn in place
            self._state = NavState.ALIGN
            yaw_terms = self._yaw_pid.update(errors.heading_goal_rad, pose.yaw_rad, dt_s)
            command = guidance.compute_command(errors, mode, 0.0, yaw_terms.output)
            return self._output(pose, command, e_d, e_psi, yaw_pid=yaw_terms)

        self._state = NavState.TRACK
        # The distance loop drives the progress −e_d to 0: error = e_d, D on the measurement.
        # Distance to go before the rover must actually slow down (flown-through corners).
        e_go = e_d + (self._run_out_m[self._target_index] if self._run_out_m else 0.0)
        distance_terms = self._distance_pid.update(0.0, -e_go, dt_s)
        speed_mps = guidance.track_speed_mps(
            distance_terms.output,
            e_go,
            goal.tolerance_m,
            self._leg_cruise_mps(),
            self.control.slowdown_radius_m,
            self.control.min_speed_mps,
        )
        if self._reverse:
            speed_mps = -speed_mps
        yaw_terms = PidTerms.zero()
        if mode is not MotionMode.OMNI:
            yaw_terms = self._yaw_pid.update(errors.heading_goal_rad, pose.yaw_rad, dt_s)
        command = guidance.compute_command(errors, mode, speed_mps, yaw_terms.output)
        return self._output(
            pose, command, e_d, e_psi, distance_pid=distance_terms, yaw_pid=yaw_terms
        )

    # -- line guidance -----------------------------------------------------------------------

    def _plan_line(self, pose: Pose2D) -> None:
        wps = self.plan.waypoints
        cfg = self.control
        self._points_xy_m = [self._leg_start(pose)] + [(w.x_m, w.y_m) for w in wps]
        corners = line.waypoint_corners(self._points_xy_m, wps, self._peak_speed_mps, cfg)
        self._arcs = corners.arcs
        self._pass_speed_mps, self._stops = corners.speeds_mps, corners.stops
        self._early_m = corners.early_m
        # Beyond this distance along the path no waypoint limits the speed profile, and the
        # distance loop's output is past the cruise speed (see _horizon_m).
        self._horizon_m = line.lookahead_horizon_m(
            self._peak_speed_mps, self._early_m, self.control
        )

    def _is_precise(self, index: int) -> bool:
        """The final waypoint, waypoints with a final heading and flagged stops (a hold or a
        delay follows): stopped at precisely."""
        wp = self.plan.waypoints[index]
        return index == len(self.plan.waypoints) - 1 or wp.final_yaw_rad is not None or wp.stop

    def _is_reached(self, pose: Pose2D, goal: PlanWaypoint) -> bool:
        distance_m = line.distance_to_m(pose, goal)
        if not self._line:
            return distance_m < goal.tolerance_m
        i = self._target_index
        stop_m = min(goal.tolerance_m, self.control.stop_tolerance_m)
        leg = self._leg(pose, goal)
        if leg.length_m <= 0.0:
            return distance_m < stop_m
        # Crossing the line through the waypoint, perpendicular to the leg, ends the leg: no
        # orbiting a point that noise put behind the rover.
        crossed = leg.along_to_go_m <= 0.0
        arc = self._arcs[i]
        if arc is not None:  # rounded on its arc: passed at the arc's middle
            return line.past_corner(arc, pose)
        if not self._stops[i]:
            return distance_m < goal.tolerance_m or crossed  # flown through
        # A stop is driven onto that line at min_speed (never creeping), so it ends on the
        # line: precise. A pivot corner crossed beside it still ends (no orbit); a final /
        # final-heading waypoint crossed farther than stop_m is flown to as a point.
        return crossed and distance_m < (stop_m if self._is_precise(i) else goal.tolerance_m)

    def set_measured_speed(self, speed_mps: float | None) -> None:
        """The ground speed the autopilot measured (m/s) for the next step; None, or a value
        that is not finite, leaves it unknown (no waiting at a change of mode)."""
        ok = speed_mps is not None and math.isfinite(speed_mps) and speed_mps >= 0.0
        self._measured_speed_mps = speed_mps if ok else None

    def _wait_at_change(self, pose: Pose2D, goal: PlanWaypoint, dt_s: float) -> NavOutput | None:
        """At a reached stop where the mode changes, scrolls stopped while the measured speed
        is above ``mode_change_speed_mps`` (for at most ``mode_change_wait_s``; reached stays
        reached while it waits); None: go on."""
        i, wps, cfg = self._target_index, self.plan.waypoints, self.control
        waited_s = self._settle[1] + dt_s if self._settle and self._settle[0] == i else None
        self._settle, self._released = None, waited_s is not None
        if i + 1 >= len(wps) or self.plan.mode_at(i) is self.plan.mode_at(i + 1):
            return None
        speed_mps = self._measured_speed_mps
        if self._mode_override is not None or speed_mps is None:
            return None
        if speed_mps <= cfg.mode_change_speed_mps or (waited_s or 0.0) > cfg.mode_change_wait_s:
            return None
        if waited_s is None and not self._is_reached(pose, goal):
            return None
        self._settle, self._released = (i, waited_s or 0.0), False
        self._prev_command = BodyVelocity.zero()  # the next leg accelerates from rest
        self._state = NavState.REACHED
        return self._output(pose, BodyVelocity.zero(), line.distance_to_m(pose, goal), 0.0)

    def _passed_change(self, pose: Pose2D, goal: PlanWaypoint) -> bool:
        """``goal`` (the current target) is a stop where the mode changes and the rover stands
        past its line, within its tolerance of it (:meth:`resume`)."""
        i, wps = self._target_index, self.plan.waypoints
        if i + 1 >= len(wps) or self.plan.mode_at(i) is self.plan.mode_at(i + 1):
            return False
        leg = self._leg(pose, goal)
        if leg.length_m <= 0.0 or leg.along_to_go_m > 0.0:
            return False
        return line.distance_to_m(pose, goal) <= goal.tolerance_m

    def _leg_start(self, pose: Pose2D) -> tuple[float, float]:
        return self._leg_start_xy_m or (pose.x_m, pose.y_m)

    def _leg(self, pose: Pose2D, goal: PlanWaypoint) -> line.LegErrors:
        """``pose`` on the leg (leg start → ``goal``), computed once per step and leg."""
        memo, start = self._leg_memo, self._leg_start_xy_m
        if memo is not None and memo[0] is pose and memo[1] is start and memo[2] is goal:
            return memo[3]
        leg = line.leg_errors(self._leg_start(pose), (goal.x_m, goal.y_m), pose)
        self._leg_memo = (pose, start, goal, leg)
        return leg

    def _follow_line(self, pose: Pose2D, dt_s: float) -> NavOutput:
        """Line guidance: the course along the leg (or its corner's arc), the heading that
        course asks of the driving axis (turned to in place first where it is far off), the
        speed the next stop allows, and the body velocity that drives them."""
        goal = self._goal()
        e_d = line.distance_to_m(pose, goal)
        leg, course_rad = self._line_course(pose, goal)
        heading = self._heading_goal(pose, leg, course_rad)
        if self.mode is not MotionMode.OMNI:
            aligning = self._align(pose, heading, e_d, dt_s)
            if aligning is not None:
                return aligning
        self._state = NavState.TRACK
        speed_mps, distance_terms = self._track_speed(leg, heading.e_psi_rad, dt_s)
        yaw_terms = PidTerms.zero()
        if self.mode is MotionMode.OMNI:
            target = self._omni_target(pose, leg, course_rad, speed_mps)
            e_now = heading.e_psi_rad
        else:
            target, e_now, yaw_terms = self._steered_target(
                pose, e_d, course_rad, heading, speed_mps, dt_s
            )
        command = self._smooth(target, e_now, dt_s, heading.curvature_per_m)
        return self._output(
            pose, command, e_d, heading.e_psi_rad, distance_pid=distance_terms, yaw_pid=yaw_terms
        )

    def _line_course(self, pose: Pose2D, goal: PlanWaypoint) -> tuple[line.LegErrors, float]:
        """The leg's errors and the course the lookahead law asks: on the leg's line, on the
        corner's arc (its tangent and radial error), or past a stop it did not reach (far
        beside it) straight to the point itself."""
        leg = self._leg(pose, goal)
        arc = self._active_arc(leg)
        lookahead_m = self.control.lookahead_m
        if arc is not None:
            tangent_rad, arc_cross_m = line.arc_errors(arc, pose)
            return leg, line.line_course_rad(tangent_rad, arc_cross_m, lookahead_m)
        if leg.along_to_go_m < 0.0:
            leg = line.leg_errors((goal.x_m, goal.y_m), (goal.x_m, goal.y_m), pose)
            return leg, leg.course_rad
        return leg, line.line_course_rad(leg.course_rad, leg.cross_track_m, lookahead_m)

    def _heading_goal(self, pose: Pose2D, leg: line.LegErrors, course_rad: float) -> _HeadingGoal:
        """The heading that puts the driving axis (backwards when reversing) on the course,
        with the arc's heading offset and curvature; OMNI keeps its heading."""
        if self.mode is MotionMode.OMNI:
            return _HeadingGoal(pose.yaw_rad, 0.0, 0.0)
        curvature, heading_offset_rad = self._arc_turning(leg)
        axis = guidance.driving_axis_rad(self.mode) + (math.pi if self._reverse else 0.0)
        goal_rad = wrap_pi(course_rad + heading_offset_rad - axis)
        return _HeadingGoal(goal_rad, shortest_angular_distance(pose.yaw_rad, goal_rad), curvature)

    def _align(
        self, pose: Pose2D, heading: _HeadingGoal, e_d: float, dt_s: float
    ) -> NavOutput | None:
        """Turn in place while the heading is off by more than the pivot angle (until it is
        within the heading threshold: hysteresis); None when the rover may drive on."""
        cfg = self.control
        enter = max(cfg.pivot_angle_rad, cfg.heading_threshold_rad)
        leave = cfg.heading_threshold_rad
        self._step_yaw_rate_model(dt_s)
        if not abs(heading.e_psi_rad) > (leave if self._state is NavState.ALIGN else enter):
            return None
        if self._state is not NavState.ALIGN:
            self._distance_pid.reset()
        self._state = NavState.ALIGN
        yaw_now = self._predicted_yaw_rad(pose, 0.0)
        yaw_terms = self._yaw_pid.update(heading.goal_rad, yaw_now, dt_s)
        e_now = shortest_angular_distance(yaw_now, heading.goal_rad)
        command = self._smooth(BodyVelocity(0.0, 0.0, yaw_terms.output), e_now, dt_s)
        return self._output(pose, command, e_d, heading.e_psi_rad, yaw_pid=yaw_terms)

    def _track_speed(
        self, leg: line.LegErrors, e_psi: float, dt_s: float
    ) -> tuple[float, PidTerms]:
        """The speed along the leg (m/s, negative reversing): the distance PID on the way to
        the next stop, the braking profile, the corner just passed, the cruise speed; at least
        min_speed (never creeping), scaled by the heading error's cosine."""
        cfg = self.control
        i = self._target_index
        e_go = max(0.0, leg.along_to_go_m)
        for j in range(i, len(self._stops) - 1):  # distance to the next stop, for the PID
            if self._stops[j] or e_go > self._horizon_m:
                break  # (beyond the horizon the PID's output is past cruise anyway)
            a, b = self._points_xy_m[j + 1], self._points_xy_m[j + 2]
            e_go += math.hypot(b[0] - a[0], b[1] - a[1])
        distance_terms = self._distance_pid.update(0.0, -e_go, dt_s)
        profile = line.profile_speed_mps(
            leg.along_to_go_m,
            i,
            self._points_xy_m,
            self._pass_speed_mps,
            cfg.braking_accel_mps2,
            self._early_m,
            self._horizon_m,
        )
        if i > 0:
            prev_arc = self._arcs[i - 1]
            rounding_m = cfg.lookahead_m if prev_arc is None else prev_arc.tangent_m
            if leg.length_m - leg.along_to_go_m < rounding_m:
                # Still rounding the corner just passed: its arc (or, without one, the
                # lookahead law's rounding, about L) spans this far past the vertex.
                profile = min(profile, self._pass_speed_mps[i - 1] or profile)
        speed_mps = min(distance_terms.output, profile, self._leg_cruise_mps())
        speed_mps = max(speed_mps, cfg.min_speed_mps)  # not reached yet: never creep
        speed_mps = max(0.0, speed_mps) * max(0.0, math.cos(e_psi))
        return (-speed_mps if self._reverse else speed_mps), distance_terms

    def _omni_target(
        self, pose: Pose2D, leg: line.LegErrors, course_rad: float, speed_mps: float
    ) -> BodyVelocity:
        """OMNI: the course in the body frame, led by the scrolls' lag on an arc."""
        # On an arc the commanded direction turns at v/R; the scrolls deliver it through
        # their response lag τ (control.slip.command_lag_s), so the motion trails the
        # command by ≈ (v/R)·τ and the rover would drift out until the lookahead term
        # cancels that (e = L·(v/R)·τ, ~0.1 m on the hexagon): lead the course by it.
        turning, _ = self._arc_turning(leg)
        course_rad += turning * speed_mps * self.control.slip.command_lag_s
        vx, vy = guidance.world_to_body(
            speed_mps * math.cos(course_rad), speed_mps * math.sin(course_rad), pose.yaw_rad
        )
        return BodyVelocity(vx, vy, 0.0)

    def _steered_target(
        self,
        pose: Pose2D,
        e_d: float,
        course_rad: float,
        heading: _HeadingGoal,
        speed_mps: float,
        dt_s: float,
    ) -> tuple[BodyVelocity, float, PidTerms]:
        """ROLL/SCROLL: the yaw loop on the predicted heading (the arc's rate fed forward)
        and the mode's command; with the heading error now and the yaw PID's terms."""
        speed_prev = math.hypot(self._prev_command.vx_mps, self._prev_command.vy_mps)
        goal_rate = heading.curvature_per_m * speed_prev * self._delivered_fraction
        yaw_now = self._predicted_yaw_rad(pose, goal_rate)
        yaw_terms = self._yaw_pid.update(heading.goal_rad, yaw_now, dt_s)
        e_now = shortest_angular_distance(yaw_now, heading.goal_rad)
        errors = guidance.GuidanceResult(
            e_d, course_rad, heading.goal_rad, heading.e_psi_rad, 0.0, 0.0
        )
        target = guidance.compute_command(errors, self.mode, speed_mps, yaw_terms.output)
        return target, e_now, yaw_terms

    def _step_yaw_rate_model(self, dt_s: float) -> None:
        """Advance the model of the delivered yaw rate by ``dt_s`` under the last command."""
        lag_s = self.control.slip.command_lag_s
        commanded = self._prev_command.wz_radps
        if lag_s <= 0.0:  # no lag: the rover turns as commanded
            self._yaw_rate_model_radps = commanded
        elif math.isfinite(dt_s) and dt_s > 0.0:  # else (a restart, dt 0) the model holds
            rate = self._yaw_rate_model_radps
            self._yaw_rate_model_radps = rate + (commanded - rate) * (1.0 - math.exp(-dt_s / lag_s))

    def _predicted_yaw_rad(self, pose: Pose2D, goal_rate_radps: float) -> float:
        """The heading the yaw loop acts on: the measured one, ahead by what the scrolls'
        response lag τ (control.slip.command_lag_s) still has in store. A first-order lag
        delivering ω turns the rover by τ·ω more after its command stops, and a heading
        reference turning at ω_ref (an arc's v/R) moves τ·ω_ref meanwhile, so the loop sees
        ψ + τ·(ω − ω_ref): kp = 8 /s on a τ = 0.3 s plant would otherwise limit-cycle
        (±0.2–0.6 rad at the 1 rad/s cap on the hexagon in SCROLL), and with it the damping
        is ζ = (1 + kp·τ)/(2·√(kp·τ)) ≈ 1.1."""
        lag_s = self.control.slip.command_lag_s
        ahead = lag_s * (self._yaw_rate_model_radps - goal_rate_radps)
        return wrap_pi(pose.yaw_rad + ahead) if math.isfinite(ahead) else pose.yaw_rad

    def _active_arc(self, leg: line.LegErrors) -> line.CornerArc | None:
        """The corner arc the rover is on: the one ending this leg once within its tangent
        length of the vertex, or the one that began this leg until its tangent length past
        the vertex; None on the straight part of the leg."""
        i = self._target_index
        arc = self._arcs[i]
        if arc is not None and leg.along_to_go_m < arc.tangent_m:
            return arc
        prev = self._arcs[i - 1] if i > 0 else None
        if prev is not None and leg.length_m - leg.along_to_go_m < prev.tangent_m:
            return prev
        return None

    def _arc_turning(self, leg: line.LegErrors) -> tuple[float, float]:
        """(curvature whose yaw rate is fed forward, heading offset) from the arc the rover
        is on or about to enter or leave, with the yaw-acceleration ramps at its ends
        (:func:`line.arc_blend`); (0, 0) on the straight part of a leg."""
        i = self._target_index
        alpha = self.control.max_yaw_accel_radps2
        arc = self._arcs[i]
        if arc is not None:
            ramp = line.arc_ramp_m(arc, alpha)
            into = arc.tangent_m - leg.along_to_go_m
            if into > -ramp / 2.0:
                share, offset = line.arc_blend(arc, into, line.arc_length_m(arc) - into, ramp)
                return arc.curvature_per_m * share, offset
        prev = self._arcs[i - 1] if i > 0 else None
        if prev is not None:
            ramp = line.arc_ramp_m(prev, alpha)
            left = prev.tangent_m - (leg.length_m - leg.along_to_go_m)
            if left > -ramp / 2.0:
                share, offset = line.arc_blend(prev, line.arc_length_m(prev) - left, left, ramp)
                return prev.curvature_per_m * share, offset
        return 0.0, 0.0

    def _smooth(
        self, target: BodyVelocity, e_psi: float, dt_s: float, curvature_per_m: float = 0.0
    ) -> BodyVelocity:
        """Acceleration limits (line guidance): translation by ``max_accel`` (along and across
        the commanded direction, :func:`line.step_toward_2d`), yaw rate by
        ``max_yaw_accel``, and a yaw rate that can still brake within the heading error.

        On an arc (``curvature_per_m`` ≠ 0) the yaw rate the arc needs at the delivered
        speed (:meth:`set_delivered_fraction`), v/R, is fed forward and added to the heading
        loop's correction (which alone is limited by the heading error); the sum stays within
        ``max_yaw_rate``."""
        cfg = self.control
        prev = self._prev_command
        vx, vy = line.step_toward_2d(
            (prev.vx_mps, prev.vy_mps), (target.vx_mps, target.vy_mps), cfg.max_accel_mps2 * dt_s
        )
        wz = line.stoppable_yaw_rate_radps(target.wz_radps, e_psi, cfg.max_yaw_accel_radps2)
        if curvature_per_m != 0.0:
            limit = cfg.max_yaw_rate_radps
            arc_rate = curvature_per_m * math.hypot(vx, vy) * self._delivered_fraction
            wz = max(-limit, min(limit, wz + arc_rate))
        wz = line.step_toward(prev.wz_radps, wz, cfg.max_yaw_accel_radps2 * dt_s)
        command = BodyVelocity(vx, vy, wz)
        self._prev_command = command
        return command

    # -- final heading -----------------------------------------------------------------------

    def _turn_to_final_heading(self, pose: Pose2D, dt_s: float, final_yaw_rad: float) -> NavOutput:
        self._state = NavState.FINAL_HEADING
        e_d = line.distance_to_m(pose, self._goal())
        e_psi = shortest_angular_distance(pose.yaw_rad, final_yaw_rad)
        yaw_terms = self._yaw_pid.update(final_yaw_rad, pose.yaw_rad, dt_s)
        command = BodyVelocity(0.0, 0.0, yaw_terms.output)
        if self._line:
            self._step_yaw_rate_model(dt_s)
            command = self._smooth(command, e_psi, dt_s)
        return self._output(pose, command, e_d, e_psi, yaw_pid=yaw_terms)

    def _arrival(self, pose: Pose2D, goal: PlanWaypoint) -> NavOutput:
        """The errors at the moment ``goal`` (the current target) is reached."""
        errors = guidance.compute_errors(pose, goal, self.mode, self._reverse)
        return NavOutput(
            command=BodyVelocity.zero(),
            state=NavState.REACHED,
            target_index=self._target_index,
            waypoints_reached=self._waypoints_reached,
            reached_index=self._target_index,
            distance_error_m=errors.distance_error_m,
            heading_error_rad=errors.heading_error_rad,
            cross_track_m=self._cross_track_m(pose, goal),
            distance_pid=PidTerms.zero(),
            yaw_pid=PidTerms.zero(),
            done=False,
        )

    def _final_heading_done(self, pose: Pose2D) -> bool:
        final_yaw = self._goal().final_yaw_rad
        if final_yaw is None:
            return True
        e_psi = shortest_angular_distance(pose.yaw_rad, final_yaw)
        return abs(e_psi) <= self.control.final_heading_tolerance_rad

    # -- bookkeeping -------------------------------------------------------------------------

    def _goal(self) -> PlanWaypoint:
        return self.plan.waypoints[self._target_index]

    def _next_waypoint(self) -> None:
        goal = self._goal()
        self._leg_start_xy_m = (goal.x_m, goal.y_m)
        self._target_index += 1
        self._mode_override = None
        self._final_heading_pending = False
        self._reset_pids()

    def _cross_track_m(self, pose: Pose2D, leg_end: PlanWaypoint) -> float:
        """Signed distance from the leg (previous waypoint, or the start pose) → leg_end."""
        start = self._leg_start_xy_m or (pose.x_m, pose.y_m)
        return guidance.cross_track_m(start, (leg_end.x_m, leg_end.y_m), pose)

    def _reset_pids(self) -> None:
        self._distance_pid.reset()
        self._yaw_pid.reset()

    def _dt(self, t_s: float) -> float:
        """Step length; 0 (with PID memory reset) on the first step, a time jump or a gap."""
        last, self._last_t_s = self._last_t_s, t_s
        if last is None:
            return 0.0
        dt_s = t_s - last
        if not (0.0 < dt_s <= self.control.max_dt_s):
            self._reset_pids()
            if dt_s != 0.0:  # a gap or a time jump: restart the acceleration limits from rest
                self._prev_command = BodyVelocity.zero()
                self._yaw_rate_model_radps = 0.0
            return 0.0
        return dt_s

    def _output(
        self,
        pose: Pose2D,
        command: BodyVelocity,
        distance_error_m: float,
        heading_error_rad: float,
        *,
        distance_pid: PidTerms | None = None,
        yaw_pid: PidTerms | None = None,
    ) -> NavOutput:
        done = self._state is NavState.DONE
        leg_end = self.plan.waypoints[self.target_index]
        if not command.is_finite():  # unreachable with finite inputs; never output it
            raise NonFiniteError(f"navigator produced a non-finite command {command}")
        return NavOutput(
            command=constrain(command, self.mode),
            state=self._state,
            target_index=self.target_index,
            waypoints_reached=self._waypoints_reached,
            reached_index=None,
            distance_error_m=distance_error_m,
            heading_error_rad=heading_error_rad,
            cross_track_m=0.0 if done else self._cross_track_m(pose, leg_end),
            distance_pid=distance_pid or PidTerms.zero(),
            yaw_pid=yaw_pid or PidTerms.zero(),
            done=done,
        )

