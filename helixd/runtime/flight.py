"""The control loop: fresh pose in → navigator → kinematics → actuator command out.

Steps on every fresh pose (at whatever rate the autopilot granted) under a configured ceiling,
with dt from the autopilot's ``time_boot_ms``, in the link's reader as the pose is read (the
command leaves in the wake-up that read the pose: no task switch, future or timer per step).
The ceiling counts autopilot time too, so the control rate *in vehicle terms* (steps per
second of the rover's motion) does not depend on a simulator speed-up. Between poses it still
ticks (wall clock) so the watchdogs run even when poses stop: the tick and the reception
watchdogs (link, stale/invalid pose) stay on the monotonic wall clock, the stall duration
counts autopilot time (see :mod:`helixd.safety.watchdogs`). It never stops the rover itself:
it returns the fault and the daemon's supervisor does the fall-back.

The step itself (:meth:`FlightLoop._step`) is pure: pose in, :class:`StepOutput` (the four
scroll fractions and the navigator's output) out, no send and no callback. The command leaves
first; what the recorder and the display need (:class:`StepReport`) is handed over after the
send, so building the flight.csv row and the progress line costs nothing on the latency path
(:mod:`helixd.runtime.flight_report` builds them). The safety supervisor
(:class:`helixd.safety.supervisor.Supervisor`) owns the watchdogs: the loop asks it once per
tick, before any command.

A mission with commands (the plan's :class:`~helixd.base.plan.Program`) is stepped beside the
navigator by :class:`~helixd.control.sequencer.Sequencer`, pure too: at every step the loop
gives it the waypoint just reached and the distance to go, and does what it returns before
the command leaves — while it holds (a waypoint's hold, NAV_LOITER_TIME, NAV_DELAY) the
scrolls get neutral instead of the navigator's command and the navigator is not stepped (the
stall watchdog sees nothing commanded, so a planned stop is never a stall); a speed change or
DO_SET_REVERSE is set on the navigator; payload commands are handed to ``on_action`` (queued,
sent off the loop by :mod:`helixd.runtime.mission_commands`); its events go to
``on_mission_event``. The flight is done when the sequencer is.

Hostile telemetry: while the vehicle state reports rejected pose telemetry (an invalid-pose
burst), the loop commands neutral at its next tick and steps nothing; the ``pose_invalid``
watchdog ends the mission if no valid pose returns within the stale-pose limit. A non-finite
value that still reached the control core (it raises :class:`NonFiniteError`) or a non-finite
result is never sent: neutral, and a ``pose_invalid`` fault at once.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import structlog

from helixd.actuators.base import ActuatorError, ActuatorSink
from helixd.base.clock import now_s
from helixd.base.frames import MissionFrame, NedPose
from helixd.base.geometry import BodyVelocity, NonFiniteError, Pose2D
from helixd.base.plan import ActionKind, MissionAction, MotionMode, Plan
from helixd.config.root import HelixdConfig
from helixd.control.kinematics import scroll_fractions
from helixd.control.navigator import Navigator, NavOutput
from helixd.control.sequencer import Sequencer, SequencerEvent, SequencerOutput
from helixd.control.slip import (
    SlipEstimate,
    SlipEstimator,
    measured_body_velocity,
    no_slip_body,
)
from helixd.link.connection import Autopilot
from helixd.link.vehicle import PoseSample, VehicleState
from helixd.mission.commands import bound_speed, speed_floor_mps
from helixd.runtime.ground_watch import GroundChange, GroundWatch
from helixd.runtime.loop_state import CrewState, StepCeiling, YawRateMeter
from helixd.runtime.mode_gate import (
    AUTO_MODE,
    DRIVE_MANUAL,
    GOTO_MODES,
    LEFT_AUTO,
    Driving,
    Gate,
    autopilot_step,
    crew_mode_of,
    current_target_of,
    gate_of,
    goto_gate,
    item_set_by_crew,
)
from helixd.runtime.signals import StopRequest
from helixd.safety.autopilot_failsafe import classify_mode_change
from helixd.safety.mission_clock import MissionClock, MissionTime
from helixd.safety.supervisor import Motion, Supervisor, failsafe_evidence
from helixd.safety.watchdogs import Fault, FaultCause

log = structlog.get_logger(__name__)

NEUTRAL_FRACTIONS = (0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True, slots=True)
class StepOutput:
    """What one control step decided (pure: nothing sent yet)."""

    fractions: tuple[float, float, float, float]  # calibrated scroll fractions, sent as is
    nav: NavOutput  # the navigator's output (its command before the slip feed-forward)
    command: BodyVelocity  # the body velocity sent (slip feed-forward included)
    mpose: Pose2D  # the pose in the mission frame
    slip: SlipEstimate  # the slip fit after this step's measurement
    motion_mode: str = ""  # the motion mode flown (roll, scroll, omni)


@dataclass(frozen=True, slots=True)
class StepReport:
    """One control step, handed to the recorder and the display after the command left."""

    sample: PoseSample
    step: StepOutput
    pwm_us: tuple[int, int, int, int]
    now_s: float  # monotonic time of the step
    elapsed_s: float  # wall time since the loop started
    pose_fresh: bool
    mode: str
    armed: bool
    link_ok: bool


@dataclass(frozen=True, slots=True)
class PoseRejectedReport:
    """A tick spent neutral while the pose telemetry is being rejected (for the display)."""

    last_target_index: int  # the waypoint being flown to before the burst (0: none yet)
    elapsed_s: float
    link_ok: bool


@dataclass
class FlightResult:
    fault: Fault | None
    detected_s: float | None  # monotonic time the fault was detected
    last_output: NavOutput | None
    last_pose: NedPose | None


def bounded_cruise(asked_mps: float, lo_mps: float, peak_mps: float) -> tuple[float, str]:
    """An operator's cruise speed within the flight's limits: at least ``lo_mps``
    (control.min_speed_mps, and Rover's 0.05 m/s), at most ``peak_mps`` (the plan's peak
    speed: its corner arcs and stopping distances are planned for it). Non-finite: the low
    limit. The speed, and the limit that bounded it ("" when none)."""
    speed_mps, side = bound_speed(asked_mps, lo_mps, peak_mps)
    limits = {"low": "control.min_speed_mps", "high": "the mission's top speed"}
    return speed_mps, limits.get(side, "")


@dataclass(frozen=True, slots=True)
class FlightHooks:
    """Who hears of the flight (a run's :class:`helixd.runtime.in_flight.InFlight`). Each is
    called on the loop, after the command left, and must be cheap: it runs at the control
    rate."""

    on_step: Callable[[StepReport], None]  # every step: the recorder and the display
    on_pose_rejected: Callable[[PoseRejectedReport], None]  # a tick neutral, pose rejected
    on_arrival: Callable[[int, float, float], None]  # (plan index, t_boot_s, error_m)
    on_tick: Callable[[], None]  # after every wake-up: batches, flushes, watchdog feeds
    on_action: Callable[[MissionAction], None] | None = None  # a payload command due
    on_mission_event: Callable[[SequencerEvent], None] | None = None  # the sequencer's
    on_gate: Callable[[Gate, str], None] | None = None  # the autopilot's mode: (gate, mode)
    on_ground: Callable[[GroundChange], None] | None = None  # the ground is not the map's


class FlightLoop:
    """One mission's control loop. Construct, then ``await run()``."""

    def __init__(
        self,
        *,
        cfg: HelixdConfig,
        plan: Plan,
        frame: MissionFrame,
        autopilot: Autopilot,
        sink: ActuatorSink,
        stop: StopRequest,
        start_ned: NedPose,
        hooks: FlightHooks,
        driving: Driving = DRIVE_MANUAL,
    ) -> None:
        # what it flies, on what, and who hears of it
        self.cfg, self.plan, self.frame = cfg, plan, frame
        self.ap, self.sink, self.stop = autopilot, sink, stop
        self.hooks, self.driving = hooks, driving
        # the pure parts it steps: the supervisor owns the watchdogs; a flight that follows
        # the autopilot's mode takes a mode change for the crew's command, not a takeover
        self.navigator = Navigator(plan, cfg.control)
        # the mode follows the medium: where the ground is not what the map says, it changes
        follows = any(w.mode is not None for w in plan.waypoints)
        self.ground = GroundWatch(cfg.media, self.navigator, follows, hooks.on_ground)
        self.sequencer = Sequencer(plan.program) if plan.program is not None else None
        self.supervisor = Supervisor(cfg.safety, start_ned, driving.mode)
        self.slip = SlipEstimator(cfg.control.slip, dict(plan.slip_priors))
        self._slip_enabled = cfg.control.slip.enabled
        self._seq_holding = False
        steps = () if plan.program is None else plan.program.steps
        self._crew = CrewState(walk_items=tuple(st.item for st in steps))
        # when it steps: on a pose the ceiling lets through; a tick at least this often
        # without poses, so the watchdogs always run (s)
        self._ceiling = StepCeiling(1.0 / cfg.control.control_rate_max_hz)
        self._tick_s = min(0.05, cfg.safety.pose_stale_s / 4)
        self._pose_stale_s = cfg.safety.pose_stale_s
        # what was sent (for the stall watchdog), and its no-slip body velocity with that
        # step's autopilot clock (s, for the slip fit); what was measured
        self._cmd_speed_mps = 0.0
        self._cmd_yaw_rate_radps = 0.0
        self._sent: tuple[float, BodyVelocity] | None = None
        self._yaw_rate = YawRateMeter()
        self._last_out: NavOutput | None = None  # the navigator's latest output
        self._pose: PoseSample | None = None  # the latest pose
        self._invalid_burst_s: float | None = None  # the rejected-pose burst already handled
        # its clocks: the time limit's (driving time only), the autopilot's at the first
        # pose flown on, the monotonic start of run() and of the last wake-up
        self._mission_clock = MissionClock()
        self._t_boot_start_s: float | None = None
        self._t_start_s = 0.0
        self._last_wake_s = 0.0
        self._result: asyncio.Future[FlightResult] | None = None  # while run() runs

    async def run(self) -> FlightResult:
        """Fly until the mission is done or a fault (or stop) ends it.

        Each new pose is stepped on by the link's reader as it is read
        (:meth:`helixd.link.telemetry.Telemetry.on_pose`): the command leaves in the wake-up
        that read the pose. This task only ticks: whenever ``_tick_s`` passes without a
        wake-up it runs the watchdogs with no pose, so a silent link is still caught. What a
        wake-up raises (a bug) is raised here, as the flight's own exception.
        """
        self._t_start_s = self._last_wake_s = now_s()
        result: asyncio.Future[FlightResult] = asyncio.get_running_loop().create_future()
        self._result = result
        unsubscribe = self.ap.telemetry.on_pose(self._on_pose)
        try:
            while not result.done():
                wait_s = self._last_wake_s + self._tick_s - now_s()
                if wait_s > 0:
                    await asyncio.wait((result,), timeout=wait_s)
                else:
                    self._wake(None)
            return result.result()
        finally:
            unsubscribe()
            self._result = None

    def _on_pose(self, sample: PoseSample) -> None:
        """The reader read a new pose: step on it now (nothing more once the flight ended)."""
        if self._result is not None and not self._result.done():
            self._wake(sample)

    def _wake(self, sample: PoseSample | None) -> None:
        """One wake-up (a pose, or a tick without one); its end or its exception goes to
        :meth:`run`, never into the reader that called it."""
        result = self._result
        assert result is not None
        now = now_s()
        self._last_wake_s = now
        try:
            ended = self._iteration(sample, now)
            # after the command left: batches, flushes and watchdog feeds never delay a
            # step (run before it, a 0.25 s row batch sat in front of every 12th pose)
            self.hooks.on_tick()
        except Exception as exc:
            result.set_exception(exc)
            return
        if ended is not None:
            result.set_result(ended)

    def _iteration(self, sample: PoseSample | None, now: float) -> FlightResult | None:
        """One wake-up: the watchdogs, then (on a fresh pose due a step) the step and its
        command. The result when the flight ends here, else None."""
        out = self._last_out
        if sample is not None:
            self._pose = sample
            if self._t_boot_start_s is None:
                self._t_boot_start_s = sample.time_boot_ms / 1000.0
            self._yaw_rate.update(sample.time_boot_ms / 1000.0, sample.ned.yaw_ned_rad)
        pose = self._pose
        if self.stop.requested:
            return FlightResult(self.stop.fault(), now, out, pose.ned if pose else None)
        if self.driving.follows_mode:
            released = self._follow_mode(now, out, pose)
            if released is not None:
                return released
        t_start = self._t_start_s
        fault = self.supervisor.check(now, self.ap.state, pose, self._motion(now, t_start, pose))
        if fault is not None:
            return FlightResult(fault, now, out, pose.ned if pose else None)
        try:
            if self._pose_rejected(now, t_start, out):
                return None  # neutral until a valid pose (or the pose_invalid watchdog)
            t_boot_s = None if sample is None else self._step_due(sample)
            if sample is None or t_boot_s is None:
                return None  # no fresh pose, or thinned out by the control-rate ceiling
            crew = self._crew
            if crew.gate is Gate.HOLD or crew.arrived:  # paused, or at the place: neutral
                self._neutral()
                step = self._held(sample, None)
                self._last_out = step.nav
                self._report(sample, step, now, t_start)
                return None
            seq = self.sequencer
            if seq is not None and seq.step_index < 0:
                self._apply(seq.start(t_boot_s))
            try:
                if seq is not None and (seq.done or self._holding):
                    step = self._held(sample, None)
                    self._neutral()
                    seq_out = seq.update(t_boot_s, None, 0.0)
                else:
                    step = self._step(sample, t_boot_s)
                    seq_out = None
                    if seq is not None:  # pure: decided before the command leaves
                        nav = step.nav
                        seq_out = seq.update(t_boot_s, nav.reached_index, nav.distance_error_m)
                    if seq_out is not None and seq_out.holding:
                        self._neutral()
                        step = self._held(sample, step.nav)
                    else:
                        self.sink.command(step.fractions)  # the command leaves first
                        self._sent_step(step, t_boot_s)
            except NonFiniteError as exc:
                self._neutral()
                fault = Fault(FaultCause.POSE_INVALID, f"non-finite value in control: {exc}")
                return FlightResult(fault, now, out, sample.ned)
            out = self._last_out = step.nav
            self._report(sample, step, now, t_start)  # arrivals before what follows
            if seq_out is not None:
                self._apply(seq_out)
        except ActuatorError as exc:  # e.g. a DO_SET_SERVO refused mid-mission: a fault
            fault = Fault(FaultCause.ACTUATOR, str(exc))
            return FlightResult(fault, now, out, pose.ned if pose else None)
        done = out.done if self.sequencer is None else self.sequencer.done
        if done and self.driving.goto is not None:
            self._arrive(out)
            return None
        if done:
            return FlightResult(None, None, out, sample.ned)
        return None

    def _step_due(self, sample: PoseSample) -> float | None:
        """The pose's boot time when a step is due on it (and the step counted as taken),
        None when the control-rate ceiling thins it out."""
        t_boot_s = sample.time_boot_ms / 1000.0
        return t_boot_s if self._ceiling.take(t_boot_s) else None

    def _arrive(self, out: NavOutput) -> None:
        """At the autopilot's place: neutral, the overrides kept, until the crew gives another
        place or mode (the flight never completes by itself)."""
        self._crew.arrived = True
        self._neutral()
        log.info("goto_arrived", distance_error_m=round(out.distance_error_m, 3))

    def _follow_mode(
        self, now: float, out: NavOutput | None, pose: PoseSample | None
    ) -> FlightResult | None:
        """The autopilot's mode is the crew's command (:mod:`helixd.runtime.mode_gate`): a
        mode change is a pause or a release, never a takeover. Neutral goes out at once on a
        pause (this wake-up, a tick at most after the HEARTBEAT); a release ends the flight."""
        st = self.ap.state
        mc = st.mission_current
        mode = crew_mode_of(st)
        driving, crew = self.driving, self._crew
        assert driving.places is not None  # Driving checks it
        target = current_target_of(st, now, driving.places.stale_s)
        failsafe = self._autopilot_failsafe(now, st)
        if failsafe is not None:  # ArduPilot's mode, not the crew's: the fall-back, named
            return FlightResult(failsafe, now, out, pose.ned if pose else None)
        if driving.goto is not None:
            gate = goto_gate(mode, driving.goto, target, driving.places.same_m)
        else:
            gate = gate_of(mode, driving.mode, place_to_go=target is not None)
        self.supervisor.expected_mode = st.mode  # the takeover rule judges sticks and switch only
        if gate is not crew.gate:
            was, crew.gate = crew.gate, gate
            log.info("mode_gate", gate=gate.value, mode=mode)
            if gate is Gate.HOLD:
                self._neutral()
            elif gate is Gate.DRIVE and was is Gate.HOLD:  # continued: on from where it stands
                self.navigator.resume()
            if self.hooks.on_gate is not None:
                self.hooks.on_gate(gate, mode)
        if gate is Gate.RELEASE:
            fault = Fault(FaultCause.RELEASED, f"mode {mode}: the pilot drives")
            return FlightResult(fault, now, out, pose.ned if pose else None)
        if gate is Gate.HANDOVER:
            where = "" if target is None else f" to {target.lat_deg:.7f} {target.lon_deg:.7f}"
            fault = Fault(FaultCause.HANDOVER, f"mode {mode}{where}: the next flight drives")
            return FlightResult(fault, now, out, pose.ned if pose else None)
        # an item set while paused is taken when AUTO comes back (the overrides stay meanwhile)
        if mc is not None and gate is Gate.DRIVE and self._item_set(mc.seq):
            fault = Fault(FaultCause.ITEM_SET, f"item {mc.seq} set: flying there")
            return FlightResult(fault, now, out, pose.ned if pose else None)
        return None

    def _autopilot_failsafe(self, now: float, st: VehicleState) -> Fault | None:
        """A mode the autopilot's own failsafe set (its text, fence, battery or status within
        ``safety.autopilot_failsafe_window_s``, :func:`classify_mode_change`) when it leaves
        the flight's last mode for one helixd does not drive in, else None: in a flight that
        follows the crew's mode, a failsafe's HOLD is no Pause."""
        before = self.supervisor.expected_mode
        if st.mode in (before, AUTO_MODE, LEFT_AUTO) or st.mode in GOTO_MODES:
            return None
        evidence = failsafe_evidence(st)
        return classify_mode_change(
            st.mode, before, evidence, now, self.supervisor.failsafe_window_s
        )

    def _item_set(self, seq: int) -> bool:
        """Whether the autopilot's current item ``seq`` moved as only the crew's *set current
        waypoint* moves it. A mission with commands: followed along the flight's walk
        (:func:`autopilot_step`; its DO_JUMPs move the item back), and where the autopilot was
        in it is logged (``autopilot_item_set``) for the next flight's jump counters."""
        crew = self._crew
        if self.plan.program is None:
            previous, crew.item = crew.item, seq
            return item_set_by_crew(previous, seq)
        at = crew.step
        if at is not None and seq == crew.item:
            return False  # not moved since its last report (a do item it started at, too)
        crew.item = seq
        step = autopilot_step(crew.walk_items, at, seq)
        if step is None:
            log.info("autopilot_item_set", item=seq, autopilot_step=(at or 0) + 1)
            return True
        if step != at:
            log.info("autopilot_step", item=seq, step=step + 1)
        crew.step = step
        return False

    def set_cruise(self, asked_mps: float) -> tuple[float, str]:
        """The operator's change of speed: the cruise from the next step on, bounded by
        :func:`bounded_cruise` (the plan's corners and stops are planned for its peak speed);
        a later DO_CHANGE_SPEED item of the mission sets it again. The speed applied and the
        limit that bounded it ("" when none)."""
        lo = speed_floor_mps(self.cfg.control.min_speed_mps)
        speed_mps, limit = bounded_cruise(asked_mps, lo, self.plan.peak_speed_mps)
        self.navigator.set_speed(speed_mps)
        return speed_mps, limit

    @property
    def _holding(self) -> bool:
        return self._seq_holding

    def _apply(self, seq_out: SequencerOutput) -> None:
        """Do what the sequencer found due (after the command left): speed and direction on
        the navigator, payload commands queued, events recorded."""
        self._seq_holding = seq_out.holding
        for a in seq_out.actions:
            if a.kind is ActionKind.SPEED:
                self.navigator.set_speed(a.value)
                log.info("mission_speed", item=a.item, speed_mps=round(a.value, 3))
            elif a.kind is ActionKind.REVERSE:
                self.navigator.set_reverse(a.value == 1.0)
                log.info("mission_reverse", item=a.item, reverse=a.value == 1.0)
            elif a.kind is ActionKind.SEND:
                if self.hooks.on_action is not None:
                    self.hooks.on_action(a)
            elif a.kind is ActionKind.NOTE:
                log.info("mission_item_note", item=a.item, text=a.text)
        if self.hooks.on_mission_event is not None:
            for ev in seq_out.events:
                self.hooks.on_mission_event(ev)

    def _held(self, sample: PoseSample, last: NavOutput | None) -> StepOutput:
        """A step spent holding: neutral out, the navigator not stepped (its last output, with
        nothing commanded, describes the row)."""
        mpose = self.frame.to_mission(sample.ned)
        nav = self.navigator.standing(mpose)
        if last is not None and last.reached_index is not None:
            nav = replace(last, command=BodyVelocity.zero())  # the arrival row itself
        slip = self.slip.estimate(self.navigator.mode)
        motion = self.navigator.mode.value
        return StepOutput(NEUTRAL_FRACTIONS, nav, BodyVelocity.zero(), mpose, slip, motion)

    def _neutral(self) -> None:
        self.sink.command(NEUTRAL_FRACTIONS)
        self._cmd_speed_mps = 0.0
        self._cmd_yaw_rate_radps = 0.0
        self._sent = None  # the slip fit restarts its command lag after a neutral

    def _pose_rejected(self, now: float, t_start: float, last: NavOutput | None) -> bool:
        """Neutral while the autopilot's pose telemetry is being rejected (once per burst:
        the sink repeats the latest command). Logged once per burst, with its reason, and
        shown to the operator (every tick; the display rate-limits) as a pose not fresh."""
        st = self.ap.state
        since = st.pose_invalid_since_s
        if since is None:
            if self._invalid_burst_s is not None:
                log.info("pose_telemetry_valid_again", rejected_total=st.pose_rejected_count)
                self._invalid_burst_s = None
            return False
        if since != self._invalid_burst_s:
            self._invalid_burst_s = since
            self._neutral()
            log.warning(
                "pose_telemetry_rejected",
                reason=st.pose_invalid_reason,
                rejected_total=st.pose_rejected_count,
                kinds=dict(st.pose_rejected_kinds),
                action="scrolls neutral; fall-back if no valid pose within pose_stale_s",
            )
        self.hooks.on_pose_rejected(
            PoseRejectedReport(
                last_target_index=last.target_index if last else 0,
                elapsed_s=now - t_start,
                link_ok=not st.link_lost,
            )
        )
        return True

    def _step(self, sample: PoseSample, t_boot_s: float) -> StepOutput:
        """One control step, pure of I/O: pose → navigator → slip feed-forward → fractions.

        Raises :class:`NonFiniteError` instead of returning a non-finite command.
        """
        mpose = self.frame.to_mission(sample.ned)
        slip = self._learn_slip(sample, t_boot_s)
        # the navigator's mode read once before its step and once after (a stop may change
        # it): it looks the stretch up in the plan, and six reads a step were 4 % of its CPU
        mode = self.navigator.mode
        if self._slip_enabled and mode is not MotionMode.OMNI:
            delivered_x, delivered_y = self.slip.delivered(mode)
            scroll = mode is MotionMode.SCROLL
            self.navigator.set_delivered_fraction(delivered_y if scroll else delivered_x)
        self.navigator.set_measured_speed(math.hypot(sample.vn_mps, sample.ve_mps))
        out = self.navigator.step(mpose, t_boot_s)
        mode = self.navigator.mode
        command = out.command
        if self._slip_enabled:
            command = self.slip.compensate(mode, out.command)
        fractions = scroll_fractions(command, self.cfg.vehicle, mode)
        if (
            not out.command.is_finite()
            or not command.is_finite()
            or not math.isfinite(fractions[0] + fractions[1] + fractions[2] + fractions[3])
        ):
            raise NonFiniteError(f"command {out.command} / fractions {list(fractions)}")
        return StepOutput(fractions, out, command, mpose, slip, mode.value)

    def _sent_step(self, step: StepOutput, t_boot_s: float) -> None:
        """Bookkeeping of what was sent, for the stall watchdog and the slip fit."""
        command = step.command
        # The stall watchdog compares the measured motion with what was sent (feed-forward
        # included): amplifying the command can only make a stall show sooner, never hide it.
        self._cmd_speed_mps = math.hypot(command.vx_mps, command.vy_mps)
        self._cmd_yaw_rate_radps = command.wz_radps
        self._sent = (t_boot_s, no_slip_body(command, self.cfg.vehicle, self.navigator.mode))

    def _report(self, sample: PoseSample, step: StepOutput, now: float, t_start: float) -> None:
        """After the send: arrivals, then the step's report for the recorder and display."""
        out = step.nav
        if out.reached_index is not None:
            t_boot_s = sample.time_boot_ms / 1000.0
            self.hooks.on_arrival(out.reached_index, t_boot_s, out.distance_error_m)
        state = self.ap.state
        self.hooks.on_step(
            StepReport(
                sample=sample,
                step=step,
                pwm_us=self.sink.last_pwm_us,
                now_s=now,
                elapsed_s=now - t_start,
                pose_fresh=now - sample.rx_monotonic_s <= self._pose_stale_s,
                mode=state.mode,
                armed=state.armed,
                link_ok=not state.link_lost,
            )
        )

    def _learn_slip(self, sample: PoseSample, t_boot_s: float) -> SlipEstimate:
        """Step the slip fit with what was sent at the last step and the motion measured now
        (LOCAL_POSITION_NED velocity rotated into the body frame, the yaw derivative)."""
        if self._sent is None:
            return self.slip.estimate(self.navigator.mode)
        t_sent_s, sent = self._sent
        measured = measured_body_velocity(
            sample.vn_mps, sample.ve_mps, sample.ned.yaw_ned_rad, self._yaw_rate.radps
        )
        ned = sample.ned
        here = self.frame.to_mission(ned)
        dt_s = t_boot_s - t_sent_s
        self.ground.feed(sent, measured, dt_s, ned.north_m, ned.east_m, (here.x_m, here.y_m))
        return self.slip.update(self.navigator.mode, sent, measured, t_boot_s - t_sent_s)

    @property
    def _paused(self) -> bool:
        """Held for the crew, which the time limit does not count: paused in HOLD, at the
        autopilot's place once reached, at a NAV_LOITER_UNLIM until the operator continues
        (a NAV_LOITER_TIME or NAV_DELAY is the plan's own and counts)."""
        seq = self.sequencer
        crew = self._crew
        return crew.gate is Gate.HOLD or crew.arrived or (seq is not None and seq.holding_forever)

    def _mission_time(self, wall_s: float, pose: PoseSample | None) -> MissionTime:
        """Mission time for the time limit (:class:`helixd.safety.mission_clock.MissionClock`):
        the later of the wall and the autopilot clock, the time held for the crew left out.

        ``mission_time_limit_s`` is checked against the plan's estimate, which is autopilot time
        (the two clocks agree on a rover; a simulator speed-up makes the autopilot's faster).
        After an autopilot reboot its clock restarts, and the wall clock still counts.
        """
        vehicle_s = None
        if pose is not None and self._t_boot_start_s is not None:
            vehicle_s = pose.time_boot_ms / 1000.0 - self._t_boot_start_s
        return self._mission_clock.update(wall_s, vehicle_s, self._paused)

    def _motion(self, now: float, t_start: float, pose: PoseSample | None) -> Motion:
        mission = self._mission_time(now - t_start, pose)
        return Motion(
            commanded_speed_mps=self._cmd_speed_mps,
            commanded_yaw_rate_radps=self._cmd_yaw_rate_radps,
            measured_yaw_rate_radps=self._yaw_rate.radps,
            mission_elapsed_s=mission.driving_s,
            mission_paused_s=mission.paused_s,
            crawl_watch=self.navigator.mode is MotionMode.ROLL,
        )
