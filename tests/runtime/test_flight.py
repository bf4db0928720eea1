"""The flight loop's order of work and its actuator-fault path, against a fed vehicle state
(no sockets: the link's reader is played by applying decoded messages)."""

from __future__ import annotations

import asyncio
import itertools
import math
import random
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from helixd.actuators.base import ServoCommandRefused
from helixd.base.frames import MissionFrame, NedPose
from helixd.base.plan import Plan
from helixd.config.root import HelixdConfig
from helixd.control.navigator import Navigator
from helixd.link.services.command_client import CommandRejected
from helixd.link.telemetry import ChangeWaiters, Telemetry
from helixd.link.vehicle import Change, PoseSample, PositionTarget, VehicleState
from helixd.mission.expand import ExpandOptions
from helixd.mission.model import Mission
from helixd.mission.resolve import resolve_plan
from helixd.runtime.flight import FlightHooks, FlightLoop, StepReport, bounded_cruise
from helixd.runtime.flight_report import StepJournal, flight_row
from helixd.runtime.loop_state import ceiling_next_due
from helixd.runtime.mode_gate import DRIVE_MANUAL, Driving, PlaceRule
from helixd.runtime.signals import StopRequest
from helixd.safety.watchdogs import FaultCause
from tests.support.mavmsgs import AP, att, decoded, hb, lpn
from tests.support.mavmsgs import EKF_HEALTHY_FLAGS as EKF_OK


class FedTelemetry(Telemetry):
    """The telemetry plugin over the fed state; once the loop subscribes to poses, the fed
    autopilot delivers its pose periods, one per event-loop turn (no wall-clock pacing)."""

    def __init__(self, ap: FedAutopilot) -> None:
        super().__init__(ap.state, ap.waiters, lambda cb: None, lambda cb: None)
        self._ap = ap

    def on_pose(self, callback: Callable[[PoseSample], None]) -> Callable[[], None]:
        unsubscribe = super().on_pose(callback)
        asyncio.get_running_loop().call_soon(self._ap.deliver)
        return unsubscribe


class FedAutopilot:
    """What the flight loop uses of an Autopilot: state, telemetry, feed()."""

    def __init__(self) -> None:
        self.state = VehicleState()
        self.waiters = ChangeWaiters()
        self.telemetry = FedTelemetry(self)
        self.t_ms = 1000
        self.periods_left = 0
        self.stop: StopRequest | None = None
        self.modes: list[int] = []  # the HEARTBEAT's custom mode per period (then MANUAL)

    def feed(self) -> None:
        pass

    def rx(self, msg: Any) -> None:
        """As the link's reader: the state takes the message, then waiters and pose
        subscribers (the flight loop's step) are called."""
        changes = self.state.apply(msg, time.monotonic())
        self.waiters.wake(changes)
        if changes & Change.POSE and self.state.pose is not None:
            self.telemetry.pose_read(self.state.pose)

    def tick(self) -> None:
        """One pose period: a heartbeat (armed, MANUAL), EKF healthy, a 3D GPS fix, attitude
        and position."""
        self.t_ms += 20
        self.rx(hb(self.modes.pop(0) if self.modes else 0, armed=True))
        self.rx(decoded(AP.ekf_status_report_encode(EKF_OK, 0.1, 0.1, 0.1, 0.05, 0.0), AP))
        self.rx(
            decoded(AP.gps_raw_int_encode(self.t_ms * 1000, 3, 0, 0, 0, 100, 200, 0, 0, 12), AP)
        )
        self.rx(att(self.t_ms, 0.0))
        self.rx(lpn(self.t_ms, 0.0, 0.0))

    def deliver(self) -> None:
        """The next pose period, then (on the next loop turn) the one after; the stop once
        they are all delivered."""
        if self.periods_left > 0:
            self.periods_left -= 1
            self.tick()
            asyncio.get_running_loop().call_soon(self.deliver)
        elif self.stop is not None:
            self.stop.trigger("test end")


class Sink:
    def __init__(self, trace: list[str], refuse_after: int | None = None) -> None:
        self.trace = trace
        self.refuse_after = refuse_after
        self.commands: list[tuple[float, ...]] = []
        self.last_pwm_us = (1500, 1500, 1500, 1500)
        self.held_channels: frozenset[int] = frozenset()

    async def start(self) -> None: ...

    def command(self, fractions: Sequence[float]) -> None:
        if self.refuse_after is not None and len(self.commands) >= self.refuse_after:
            raise ServoCommandRefused(1, 1700, CommandRejected("DO_SET_SERVO", 4))
        self.trace.append("command")
        self.commands.append(tuple(fractions))

    async def stop(self) -> None: ...

    async def close(self) -> None: ...


def quiet_loop(
    cfg: HelixdConfig,
    plan: Plan,
    ap: Any,
    sink: Any,
    driving: Driving = DRIVE_MANUAL,
    **callbacks: Any,
) -> FlightLoop:
    """A flight loop of ``plan`` from the origin, every callback a no-op unless given."""
    start = NedPose(0.0, 0.0, 0.0)
    quiet: dict[str, Any] = {
        "on_step": lambda r: None,
        "on_pose_rejected": lambda r: None,
        "on_arrival": lambda i, t, e: None,
        "on_tick": lambda: None,
    }
    return FlightLoop(
        cfg=cfg,
        plan=plan,
        frame=MissionFrame.start_at(start),
        autopilot=ap,
        sink=sink,
        stop=StopRequest(),
        start_ned=start,
        hooks=FlightHooks(**{**quiet, **callbacks}),
        driving=driving,
    )


def make_loop(
    ap: FedAutopilot,
    sink: Sink,
    trace: list[str],
    driving_mode: str = "MANUAL",
    cfg: HelixdConfig | None = None,
    goto: PositionTarget | None = None,
) -> FlightLoop:
    cfg = cfg or HelixdConfig()
    driving = DRIVE_MANUAL
    if driving_mode != "MANUAL":  # as helixd serve hands it in
        places = PlaceRule(cfg.serve.target_stale_s, cfg.serve.same_place_m)
        driving = Driving(driving_mode, goto, places)
    mission = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": [{"x": 20, "y": 0}]}
    )
    plan = resolve_plan(mission, cfg.control, cfg.mission, None)

    def on_step(report: StepReport) -> None:
        trace.append("report")
        assert report.step.fractions == sink.commands[-1]  # what was sent, reported after

    return quiet_loop(cfg, plan, ap, sink, driving, on_step=on_step)


async def fly(ap: FedAutopilot, loop: FlightLoop, periods: int) -> Any:
    """Run the loop over ``periods`` pose periods, then stop it."""
    ap.periods_left, ap.stop = periods, loop.stop
    return await asyncio.wait_for(loop.run(), 2.0)


def test_command_leaves_before_the_report() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    sink = Sink(trace)
    result = asyncio.run(fly(ap, make_loop(ap, sink, trace), 6))
    assert result.fault is not None and result.fault.cause is FaultCause.SIGNAL  # our stop
    assert len(sink.commands) >= 3
    assert trace[:4] == ["command", "report", "command", "report"]
    assert all(math.isfinite(f) for c in sink.commands for f in c)


def test_step_is_pure_of_io() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    sink = Sink(trace)
    loop = make_loop(ap, sink, trace)
    assert ap.state.pose is not None
    step = loop._step(ap.state.pose, ap.state.pose.time_boot_ms / 1000.0)
    assert trace == [] and sink.commands == []  # nothing sent, nothing reported
    assert len(step.fractions) == 4 and all(math.isfinite(f) for f in step.fractions)
    assert step.nav.distance_error_m == pytest.approx(20.0)  # the navigator's output returned


def test_servo_refused_in_flight_is_an_actuator_fault() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    sink = Sink(trace, refuse_after=2)
    result = asyncio.run(fly(ap, make_loop(ap, sink, trace), 10))
    assert result.fault is not None and result.fault.cause is FaultCause.ACTUATOR
    assert "DO_SET_SERVO" in result.fault.detail
    assert result.detected_s is not None and result.last_pose is not None
    assert len(sink.commands) == 2


class BrokenSink(Sink):
    """A sink with a bug: its third command raises what no fault path expects."""

    def command(self, fractions: Sequence[float]) -> None:
        if len(self.commands) == 2:
            raise RuntimeError("a bug in the sink")
        super().command(fractions)


def test_a_bug_in_a_step_is_raised_by_run_not_swallowed_by_the_reader() -> None:
    """The step runs inside the link's reader (which logs and goes on after a handler's
    exception); the flight must still end with the exception, for the daemon's crash path."""
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    sink = BrokenSink(trace)
    with pytest.raises(RuntimeError, match="a bug in the sink"):
        asyncio.run(fly(ap, make_loop(ap, sink, trace), 10))
    assert len(sink.commands) == 2


def test_no_step_after_the_flight_ended() -> None:
    """Poses read after ``run()`` returned (a fault, a stop) are not stepped on: nothing is
    commanded behind the daemon's fall-back."""
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    sink = Sink(trace)
    loop = make_loop(ap, sink, trace)
    result = asyncio.run(fly(ap, loop, 4))
    assert result.fault is not None and result.fault.cause is FaultCause.SIGNAL
    sent = len(sink.commands)
    assert sent >= 2
    for _ in range(5):
        ap.tick()  # the reader goes on reading poses
    assert len(sink.commands) == sent


def test_watchdogs_tick_without_poses() -> None:
    """No pose at all after the start: the loop still wakes (every tick) and the stale-pose
    watchdog ends the flight, within the stale-pose limit and a tick."""
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    sink = Sink(trace)
    loop = make_loop(ap, sink, trace)
    t0 = time.monotonic()
    result = asyncio.run(asyncio.wait_for(loop.run(), 5.0))  # no stop asked: a watchdog ends it
    elapsed_s = time.monotonic() - t0
    assert result.fault is not None and result.fault.cause is FaultCause.POSE_STALE
    assert elapsed_s < loop.cfg.safety.pose_stale_s + 0.5
    assert sink.commands == []


# -- the step journal: flight.csv rows built in batches, after sends ------------------------


def one_report() -> tuple[StepReport, Any]:
    """A real step report from the fed loop, and the loop's plan."""
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    reports: list[StepReport] = []
    loop = make_loop(ap, Sink(trace), trace)
    inner = loop.hooks.on_step

    def on_step(r: StepReport) -> None:
        inner(r)
        reports.append(r)

    loop.hooks = replace(loop.hooks, on_step=on_step)
    asyncio.run(fly(ap, loop, 3))
    return reports[0], loop.plan


def test_journal_builds_rows_in_batches_in_step_order() -> None:
    report, plan = one_report()
    rows: list[Any] = []
    journal = StepJournal(plan, rows.append, batch_s=0.25)
    for k in range(13):  # 0 … 0.24 s: younger than one batch
        journal.add(replace(report, now_s=100.0 + 0.02 * k))
    assert rows == [] and journal.pending == 13  # nothing built on the steps themselves
    journal.add(replace(report, now_s=100.26))  # the oldest is now a batch old: all built
    assert journal.pending == 0
    assert [r.t_mono_s for r in rows] == pytest.approx(
        [100.0 + 0.02 * k for k in range(13)] + [100.26]
    )
    assert rows[0] == flight_row(replace(report, now_s=100.0), plan)  # the row, as built alone


def test_journal_hands_rows_on_when_steps_pause_and_on_demand() -> None:
    report, plan = one_report()
    rows: list[Any] = []
    journal = StepJournal(plan, rows.append, batch_s=0.25)
    journal.add(replace(report, now_s=10.0))
    journal.maybe_drain(10.2)  # the newest step is younger than a batch: kept
    assert rows == []
    journal.maybe_drain(10.25)  # steps paused a batch long: handed on
    assert len(rows) == 1 and journal.pending == 0
    journal.add(replace(report, now_s=11.0))
    journal.drain()  # e.g. before a waypoint arrival or the summary
    assert len(rows) == 2 and rows[1].t_mono_s == 11.0
    journal.drain()
    journal.maybe_drain(99.0)
    assert len(rows) == 2  # nothing twice


# -- a mission with commands: the sequencer beside the navigator ------------------------------


def test_a_hold_sends_neutral_then_the_leg_and_queues_the_commands_due() -> None:
    """NAV_DELAY 0.2 s, a servo command, then a waypoint 20 m ahead: neutral (the navigator not
    stepped) for the 0.2 s of autopilot time, the servo command handed over when the delay
    ends and the leg starts, then the leg's commands."""
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    sink = Sink(trace)
    cfg = HelixdConfig()
    mission = Mission.model_validate(
        {
            "name": "t",
            "mode": "roll",
            "frame": "start",
            "waypoints": [
                {"command": "NAV_DELAY", "delay_s": 0.2},
                {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900},
                {"x": 20, "y": 0},
            ],
        }
    )
    plan = resolve_plan(mission, cfg.control, cfg.mission, None)
    actions: list[Any] = []
    events: list[Any] = []
    loop = quiet_loop(
        cfg,
        plan,
        ap,
        sink,
        on_step=lambda r: trace.append("report"),
        on_action=actions.append,
        on_mission_event=events.append,
    )
    asyncio.run(fly(ap, loop, 30))
    neutral = [c == (0.0, 0.0, 0.0, 0.0) for c in sink.commands]
    first_drive = neutral.index(False)
    assert 9 <= first_drive <= 12  # 0.2 s at 20 ms a pose, stepped at the control ceiling
    assert all(neutral[:first_drive]) and not any(neutral[first_drive:])
    assert [(a.item, a.command) for a in actions] == [(2, 183)]
    assert [e.kind for e in events][:3] == ["step_started", "hold_started", "step_completed"]


# -- the control-rate ceiling (autopilot time) --------------------------------------------------

PERIOD_S = 0.005  # a 200 Hz ceiling
EARLY_S = 0.25 * PERIOD_S


def stepped(times_s: Sequence[float]) -> list[float]:
    """The poses the ceiling steps on, of poses at these autopilot times."""
    out: list[float] = []
    last, due = -math.inf, -math.inf
    for t in times_s:
        nxt = ceiling_next_due(t, last, due, PERIOD_S, EARLY_S)
        if nxt is not None:
            out.append(t)
            last, due = t, nxt
    return out


def test_ceiling_steps_every_pose_at_its_rate_despite_jitter() -> None:
    """Poses at the ceiling rate, each up to 0.2 ms early or up to 4 ms late: all stepped
    (a late pose does not make the next, on-time one look early)."""
    rng = random.Random(7)
    times = [
        k * PERIOD_S + rng.choice((-0.0002, 0.0, 0.0, 0.004 * rng.random())) for k in range(1000)
    ]
    assert stepped(times) == times


def test_ceiling_thins_a_flood_to_its_rate() -> None:
    flood = [k * PERIOD_S / 4 for k in range(4000)]  # 800 Hz for 5 s
    steps = stepped(flood)
    assert len(steps) in (1000, 1001)
    gaps = [b - a for a, b in itertools.pairwise(steps)]
    assert min(gaps) >= PERIOD_S - EARLY_S - 1e-9  # never closer than the jitter allows


def test_ceiling_restarts_after_a_gap_and_after_a_reboot() -> None:
    before = [k * PERIOD_S for k in range(10)]
    after_gap = [1.0 + k * PERIOD_S / 4 for k in range(8)]  # a flood resuming after 1 s
    assert stepped(before + after_gap) == [*before, after_gap[0], after_gap[3], after_gap[7]]
    rebooted = [0.002, 0.0021, 0.0075]  # the autopilot's clock starts again
    assert stepped(before + rebooted) == [*before, 0.002, 0.0075]


@given(
    gaps=st.lists(
        st.floats(min_value=0.0, max_value=3 * PERIOD_S, allow_nan=False), min_size=1, max_size=300
    )
)
def test_ceiling_never_exceeds_its_rate(gaps: list[float]) -> None:
    """Whatever the arrival times (non-decreasing), no window of k periods holds more than
    k + 2 steps."""
    times = list(itertools.accumulate(gaps))
    steps = stepped(times)
    for i, a in enumerate(steps):
        k = 4
        in_window = [b for b in steps[i:] if b < a + k * PERIOD_S]
        assert len(in_window) <= k + 2


AUTO, HOLD, MANUAL = 10, 4, 0  # ArduPilot Rover's custom modes


def test_a_flight_of_auto_pauses_in_hold_goes_on_in_auto_and_lets_go_in_manual() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.modes = [AUTO] * 8 + [HOLD] * 8 + [AUTO] * 8 + [MANUAL]
    ap.tick()
    sink = Sink(trace)
    loop = make_loop(ap, sink, trace, driving_mode="AUTO")
    gates: list[str] = []
    loop.hooks = replace(
        loop.hooks, on_gate=lambda gate, mode: gates.append(f"{gate.value} {mode}")
    )
    result = asyncio.run(fly(ap, loop, 30))
    # MANUAL: the flight ends as a release to the pilot (no takeover fault, no HOLD asked)
    assert result.fault is not None and result.fault.cause is FaultCause.RELEASED
    assert gates == ["hold HOLD", "drive AUTO", "release MANUAL"]
    neutral = (0.0, 0.0, 0.0, 0.0)
    driven = [c != neutral for c in sink.commands]
    # driven, then neutral at every step of the pause (the overrides kept), then driven again
    first_hold = driven.index(False, 1)  # the first step starts from rest
    again = driven.index(True, first_hold)
    assert any(driven[:first_hold]) and again - first_hold >= 6
    assert all(not d for d in driven[first_hold:again])
    assert any(driven[again:])


def test_the_loop_reads_no_serve_section_its_host_hands_in_the_place_rule() -> None:
    """A flight of AUTO flies with the config's serve section gone: the place rule comes from
    its host (helixd serve), not from ``cfg.serve``."""
    trace: list[str] = []
    ap = FedAutopilot()
    ap.modes = [AUTO] * 8 + [MANUAL]
    ap.tick()
    plan = make_loop(ap, Sink(trace), trace).plan
    no_serve = HelixdConfig().model_copy(update={"serve": None})
    driving = Driving("AUTO", places=PlaceRule(1.5, 0.5))
    loop = quiet_loop(no_serve, plan, ap, Sink(trace), driving)
    result = asyncio.run(fly(ap, loop, 12))
    assert result.fault is not None and result.fault.cause is FaultCause.RELEASED


def test_a_flight_that_follows_the_mode_needs_its_place_rule() -> None:
    with pytest.raises(ValueError, match="needs its PlaceRule"):
        Driving("AUTO")
    assert (
        not DRIVE_MANUAL.follows_mode and Driving("AUTO", places=PlaceRule(1.5, 0.5)).follows_mode
    )


def test_a_flight_that_set_manual_takes_a_mode_change_for_a_takeover() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.modes = [MANUAL] * 4 + [HOLD]
    ap.tick()
    result = asyncio.run(fly(ap, make_loop(ap, Sink(trace), trace), 10))
    assert result.fault is not None and result.fault.cause is FaultCause.PILOT_TAKEOVER


def test_a_flight_of_auto_ends_when_the_crew_sets_another_item() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.modes = [AUTO] * 30
    ap.tick()
    loop = make_loop(ap, Sink(trace), trace, driving_mode="AUTO")
    ap.rx(decoded(AP.mission_current_encode(1, 3, 3, 1), AP))
    ap.rx(decoded(AP.mission_current_encode(2, 3, 3, 1), AP))  # ArduPilot's own progress
    ap.periods_left, ap.stop = 30, loop.stop

    async def main() -> Any:
        task = asyncio.create_task(loop.run())
        for _ in range(5):
            await asyncio.sleep(0)
        ap.rx(decoded(AP.mission_current_encode(1, 3, 3, 1), AP))  # set back to item 1
        return await asyncio.wait_for(task, 2.0)

    result = asyncio.run(main())
    assert result.fault is not None and result.fault.cause is FaultCause.ITEM_SET
    assert "item 1" in result.fault.detail


GUIDED = 15
HERE = PositionTarget(520_000_000, 130_000_000, 0.0)  # lat/lon of a place (degE7)


class GotoAutopilot(FedAutopilot):
    """Also publishes its place each period, as ArduPilot's GUIDED does (None: none)."""

    def __init__(self) -> None:
        super().__init__()
        self.places: list[tuple[int, int] | None] = []
        self.norths_m: list[float] = []  # the rover's position (north) per period, then 0

    def tick(self) -> None:
        self.t_ms += 20
        self.rx(hb(self.modes.pop(0) if self.modes else 0, armed=True))
        self.rx(decoded(AP.ekf_status_report_encode(EKF_OK, 0.1, 0.1, 0.1, 0.05, 0.0), AP))
        self.rx(decoded(AP.gps_raw_int_encode(0, 3, 0, 0, 0, 100, 200, 0, 0, 12), AP))
        self.rx(att(self.t_ms, 0.0))
        self.rx(lpn(self.t_ms, self.norths_m.pop(0) if self.norths_m else 0.0, 0.0))
        place = self.places.pop(0) if self.places else (HERE.lat_e7, HERE.lon_e7)
        if place is not None:
            zeros = [0.0] * 8
            msg = AP.position_target_global_int_encode(self.t_ms, 0, 0xFFF8, *place, 0.0, *zeros)
            self.rx(decoded(msg, AP))


def goto_loop(
    ap: FedAutopilot, sink: Sink, trace: list[str], x_m: float, cfg: HelixdConfig | None = None
) -> FlightLoop:
    loop = make_loop(ap, sink, trace, driving_mode="GUIDED", cfg=cfg, goto=HERE)
    mission = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": [{"x": x_m, "y": 0}]}
    )
    loop.plan = resolve_plan(mission, loop.cfg.control, loop.cfg.mission, None)
    loop.navigator = Navigator(loop.plan, loop.cfg.control)
    return loop


def test_a_flight_to_a_place_holds_there_and_never_completes() -> None:
    trace: list[str] = []
    ap = GotoAutopilot()
    ap.modes = [GUIDED] * 60
    # driven onto the place at 1 m/s, past its line within control.stop_tolerance_m; stays
    ap.norths_m = [0.02 * i for i in range(27)] + [0.52] * 20
    ap.tick()
    sink = Sink(trace)
    loop = goto_loop(ap, sink, trace, 0.5)
    result = asyncio.run(fly(ap, loop, 45))
    assert result.fault is not None and result.fault.cause is FaultCause.SIGNAL  # our stop
    assert loop._crew.arrived
    neutral = [c == (0.0,) * 4 for c in sink.commands]
    arrived_at = neutral.index(True, 1)
    assert not all(neutral[:arrived_at]) and all(neutral[arrived_at:])
    assert len(neutral) - arrived_at >= 10  # held there to the end, the flight still on


def test_a_flight_to_a_place_hands_over_to_a_new_place_and_holds_without_one() -> None:
    trace: list[str] = []
    ap = GotoAutopilot()
    ap.modes = [GUIDED] * 40
    ap.places = [None] * 3 + [(HERE.lat_e7, HERE.lon_e7)] * 5 + [(HERE.lat_e7 + 900, HERE.lon_e7)]
    ap.tick()
    sink = Sink(trace)
    loop = goto_loop(ap, sink, trace, 20.0)
    gates: list[str] = []
    loop.hooks = replace(loop.hooks, on_gate=lambda gate, mode: gates.append(gate.value))
    result = asyncio.run(fly(ap, loop, 30))
    assert result.fault is not None and result.fault.cause is FaultCause.HANDOVER
    assert gates[-1] == "handover" and "GUIDED to 52.0000900" in result.fault.detail
    assert any(c != (0.0,) * 4 for c in sink.commands)  # driven toward the place meanwhile


def test_an_operators_cruise_is_bounded_by_the_flights_limits() -> None:
    assert bounded_cruise(0.3, 0.1, 0.6) == (0.3, "")
    assert bounded_cruise(2.0, 0.1, 0.6) == (0.6, "the mission's top speed")
    assert bounded_cruise(0.05, 0.1, 0.6) == (0.1, "control.min_speed_mps")
    assert bounded_cruise(math.nan, 0.1, 0.6) == (0.1, "control.min_speed_mps")
    assert bounded_cruise(math.inf, 0.1, 0.6) == (0.1, "control.min_speed_mps")
    assert bounded_cruise(0.3, 0.4, 0.2) == (0.2, "control.min_speed_mps")  # never above peak


# -- the mission time limit counts driving time only --------------------------------------------

# 0.3 s of autopilot time: 15 pose periods of 20 ms (the wall clock of these fed flights runs
# far faster, so the autopilot clock is the one counted)
SHORT_LIMIT = HelixdConfig.model_validate({"safety": {"mission_time_limit_s": 0.3}})


def test_a_flight_paused_in_hold_longer_than_the_limit_goes_on_without_a_time_fault() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    # 0.1 s driven, 0.8 s paused in HOLD, 0.1 s driven: 0.2 s of driving against 0.3 s
    ap.modes = [AUTO] * 5 + [HOLD] * 40 + [AUTO] * 5 + [MANUAL]
    ap.tick()
    sink = Sink(trace)
    loop = make_loop(ap, sink, trace, driving_mode="AUTO", cfg=SHORT_LIMIT)
    result = asyncio.run(fly(ap, loop, 60))
    assert result.fault is not None and result.fault.cause is FaultCause.RELEASED, result.fault
    # driven again after the pause, within the limit
    neutral = (0.0, 0.0, 0.0, 0.0)
    driven = [c != neutral for c in sink.commands]
    first_hold = driven.index(False, 1)
    assert any(driven[driven.index(True, first_hold) :])


def test_driving_past_the_limit_after_a_pause_is_a_time_fault_naming_the_pause() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.modes = [AUTO] * 5 + [HOLD] * 40 + [AUTO] * 40
    ap.tick()
    loop = make_loop(ap, Sink(trace), trace, driving_mode="AUTO", cfg=SHORT_LIMIT)
    result = asyncio.run(fly(ap, loop, 80))
    assert result.fault is not None and result.fault.cause is FaultCause.MISSION_TIME
    assert "(limit 0 s;" in result.fault.detail and "s paused not counted" in result.fault.detail


def test_a_flight_driving_past_the_limit_is_a_time_fault() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.modes = [AUTO] * 30
    ap.tick()
    loop = make_loop(ap, Sink(trace), trace, driving_mode="AUTO", cfg=SHORT_LIMIT)
    result = asyncio.run(fly(ap, loop, 30))
    assert result.fault is not None and result.fault.cause is FaultCause.MISSION_TIME
    assert result.fault.detail.startswith("driving 0 s (limit 0 s)"), result.fault.detail


def test_a_flight_held_at_its_place_longer_than_the_limit_does_not_fault() -> None:
    trace: list[str] = []
    ap = GotoAutopilot()
    ap.modes = [GUIDED] * 100
    # on the place after 0.54 s (27 periods), then held there 1.1 s: 0.7 s limit
    ap.norths_m = [0.02 * i for i in range(27)] + [0.52] * 80
    ap.tick()
    cfg = HelixdConfig.model_validate({"safety": {"mission_time_limit_s": 0.7}})
    loop = goto_loop(ap, Sink(trace), trace, 0.5, cfg)
    result = asyncio.run(fly(ap, loop, 90))
    assert loop._crew.arrived
    assert result.fault is not None and result.fault.cause is FaultCause.SIGNAL, result.fault


def program_loop(
    ap: FedAutopilot, trace: list[str], items: list[dict[str, Any]], limit_s: float
) -> FlightLoop:
    """A flight of a mission with commands, its time limit ``limit_s``."""
    cfg = HelixdConfig.model_validate({"safety": {"mission_time_limit_s": limit_s}})
    mission = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": items}
    )
    options = ExpandOptions(operator_continue=True)
    plan = resolve_plan(mission, cfg.control, cfg.mission, None, options=options)
    return quiet_loop(cfg, plan, ap, Sink(trace))


def test_a_hold_at_a_loiter_unlim_waiting_for_the_operator_is_not_counted() -> None:
    trace: list[str] = []
    ap = GotoAutopilot()
    ap.norths_m = [0.02 * i for i in range(27)] + [0.52] * 80
    ap.tick()
    loop = program_loop(ap, trace, [{"command": "NAV_LOITER_UNLIM", "x": 0.5, "y": 0}], 0.7)
    result = asyncio.run(fly(ap, loop, 90))
    assert loop.sequencer is not None and loop.sequencer.holding_forever
    assert result.fault is not None and result.fault.cause is FaultCause.SIGNAL, result.fault


def test_a_nav_delay_is_the_plans_own_wait_and_counts() -> None:
    trace: list[str] = []
    ap = FedAutopilot()
    ap.tick()
    items = [{"command": "NAV_DELAY", "delay_s": 1.0}, {"x": 20, "y": 0}]
    loop = program_loop(ap, trace, items, 0.3)
    result = asyncio.run(fly(ap, loop, 40))
    assert result.fault is not None and result.fault.cause is FaultCause.MISSION_TIME
    assert "paused" not in result.fault.detail
