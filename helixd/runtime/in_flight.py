"""What a run does while its flight loop flies: the loop's callbacks, in one place.

The flight loop (:class:`helixd.runtime.flight.FlightLoop`) knows nothing of the operator: it
calls back after each command has left. :class:`InFlight` turns those calls into what the
operator and the record see — the progress line, the ground station's texts (in its numbering),
flight.csv rows and the summary's figures (batched by
:class:`helixd.runtime.flight_report.StepJournal`), the host's current item, the watchdog's
heartbeat — so the runner (:class:`helixd.runtime.daemon.MissionRunner`) only starts the loop
and reads its result. Every callback is cheap: it runs at the control rate.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import structlog

from helixd.base.clock import now_s
from helixd.base.media import MediaMapNe
from helixd.base.plan import MissionAction, Numbering, Plan, mission_item_of
from helixd.config.root import HelixdConfig
from helixd.control.sequencer import SequencerEvent
from helixd.link.connection import Autopilot
from helixd.mav.constants import MAV_SEVERITY_WARNING
from helixd.mission.commands import command_name
from helixd.mission.resolve import places_from
from helixd.recorder.rows import FlightRow
from helixd.recorder.rundir import RunRecorder
from helixd.recorder.summary import SummaryBuilder
from helixd.report.display import ProgressDisplay
from helixd.report.gcs_feed import GcsFeed
from helixd.runtime.flight import FlightHooks, PoseRejectedReport, StepReport
from helixd.runtime.flight_report import StepJournal, rejected_progress, step_progress
from helixd.runtime.ground_watch import GroundChange
from helixd.runtime.host import FlightHost
from helixd.runtime.mode_gate import GOTO_MODES, LEFT_AUTO, Gate, crew_mode_of

log = structlog.get_logger(__name__)


@dataclass
class InFlight:
    """The flight loop's callbacks for one flight of ``plan`` (numbered by ``numbering``)."""

    cfg: HelixdConfig
    plan: Plan
    numbering: Numbering
    ap: Autopilot
    host: FlightHost
    gcs: GcsFeed
    display: ProgressDisplay
    summary: SummaryBuilder
    recorder: RunRecorder | None
    media: MediaMapNe | None = None  # the flight's media map, placed: flight.csv's medium
    journal: StepJournal = field(init=False)
    laps: tuple[str, ...] = field(init=False)
    inserted_before: tuple[int, ...] = field(init=False)
    radio_lost_told: bool = False
    # a pause seen as "AUTO left" only (MISSION_CURRENT before the HEARTBEAT): said once the
    # mode is known, and not at all when it is a place to go (the next flight says where)
    hold_untold: bool = False

    def __post_init__(self) -> None:
        # flight.csv rows and the summary's figures are built in batches, after sends
        media = self.media
        self.journal = StepJournal(
            self.plan,
            self.on_row,
            self.cfg.recorder.batch_interval_s,
            None if media is None else lambda n, e: media.medium_at(n, e).value,
        )
        program = self.plan.program
        self.laps = tuple(program.laps()) if program is not None else ()
        # per plan index, the media map's stops before it (not the mission's waypoints)
        inserted, count = [], 0
        for w in self.plan.waypoints:
            inserted.append(count)
            count += w.media_stop
        self.inserted_before = tuple(inserted)

    def announce(self, mission_name: str) -> None:
        """The flight starts: the log, the ground station and the host's current item."""
        numbering, program = self.numbering, self.plan.program
        if program is not None:
            log.info(
                "mission_program",
                items=numbering.total,  # numbered as the ground station shows them
                steps=len(program.steps),
                places_from=places_from(self.plan.frame),  # as `check` gives them
            )
        self.host.on_item(mission_item_of(self.plan, numbering, 0))
        if not self.host.tells_steps:
            return  # the service said what it flies
        if numbering.items:
            self.gcs.phase(f"fly {mission_name}: {numbering.total} items")
        else:
            self.gcs.phase(f"fly {mission_name}: {numbering.operator_count} waypoints")

    def hooks(self, on_action: Callable[[MissionAction], None] | None = None) -> FlightHooks:
        """The flight loop's callbacks; ``on_action``: where the mission's payload commands
        go (:class:`helixd.runtime.mission_commands.MissionCommands`)."""
        return FlightHooks(
            self.on_step,
            self.on_pose_rejected,
            self.on_arrival,
            self.on_tick,
            on_action,
            self.on_mission_event,
            self.on_gate,
            self.on_ground,
        )

    # -- the flight loop's callbacks ----------------------------------------------------------

    def on_step(self, report: StepReport) -> None:  # after the command left
        nav = report.step.nav
        numbering = self.numbering
        self.gcs.progress(nav.cross_track_m, numbering.number(nav.target_index))
        self.journal.add(report)
        self.display.update(lambda: step_progress(report, numbering))  # if shown

    def on_pose_rejected(self, report: PoseRejectedReport) -> None:
        self.display.update(rejected_progress(report, self.numbering))

    def on_tick(self) -> None:
        self.ap.feed()
        if self.hold_untold:
            self.tell_hold()
        self.tell_radio_lost()
        self.host.notifier.watchdog()
        self.journal.maybe_drain(now_s())
        if self.recorder is not None:
            self.recorder.maybe_flush()

    def on_mission_event(self, ev: SequencerEvent) -> None:
        lap = self.laps[ev.step] if 0 <= ev.step < len(self.laps) else ""
        log.info(
            "mission_step",
            kind=ev.kind,
            item=ev.item,  # as the ground station numbers it (home 0, the first item 1)
            lap=lap or None,  # "lap 2 of 3" where a DO_JUMP repeats the item
            command=command_name(ev.command),
            step=ev.step + 1,
            text=ev.text,
        )
        if ev.kind == "hold_started":
            self.gcs.phase(f"item {ev.item}{f' ({lap})' if lap else ''}: {ev.text}")

    def on_ground(self, change: GroundChange) -> None:
        """The ground is not what the media map says: the mode changed; the event, the GCS."""
        v = change.verdict
        log.warning(
            "ground_changed",
            soft=v.soft,
            mode=v.mode.value,
            planned=change.planned.value,
            delivered_fraction=round(v.fraction, 3),
            waypoint=self.numbering.label(change.target_index),
            north_m=round(change.north_m, 2),
            east_m=round(change.east_m, 2),
        )
        self.gcs.say(change.text(), MAV_SEVERITY_WARNING)

    def on_gate(self, gate: Gate, mode: str) -> None:
        """The autopilot's mode changed what a flight of its AUTO may do: tell the host (a
        pause, or going on) and the GCS."""
        self.hold_untold = False
        if gate in (Gate.HOLD, Gate.DRIVE):
            self.host.paused(gate is Gate.HOLD, mode)
        if gate is Gate.HOLD and not self.host.tells_steps and mode in (LEFT_AUTO, *GOTO_MODES):
            self.hold_untold = mode == LEFT_AUTO
            return
        self.say_gate(gate, mode)

    def say_gate(self, gate: Gate, mode: str) -> None:
        if gate is Gate.HOLD:
            driving = self.host.driving
            back = driving.mode if driving.goto is None else "a place to go"
            self.gcs.phase(f"paused: mode {mode}, scrolls held at neutral until {back}")
        elif gate is Gate.DRIVE:
            self.gcs.phase(f"continuing in {mode}")
        elif gate is Gate.RELEASE:
            self.gcs.phase(f"released: mode {mode}, the pilot drives")

    def mission_index(self, index: int) -> int | None:
        """The mission's index of plan waypoint ``index`` (None: a stop of the media map)."""
        wps = self.plan.waypoints
        if not 0 <= index < len(wps):
            return index
        return None if wps[index].media_stop else index - self.inserted_before[index]

    def tell_hold(self) -> None:
        """The pause seen first as "AUTO left", told once the HEARTBEAT names the mode."""
        mode = crew_mode_of(self.ap.state)
        if mode == LEFT_AUTO:
            return
        self.hold_untold = False
        if mode not in GOTO_MODES:
            self.say_gate(Gate.HOLD, mode)

    def on_arrival(self, index: int, t_boot_s: float, error_m: float) -> None:
        self.journal.drain()  # the summary has every step before the arrival
        numbering = self.numbering
        number, via, lap = numbering.number(index), numbering.via(index), numbering.lap(index)
        if not via:
            self.gcs.waypoint(number - 1, numbering.total, lap)
        self.summary.arrival(index, t_boot_s, error_m, number=number, via=via, lap=lap)
        start = self.summary.start_t_boot_s
        log.info(
            "waypoint_reached",
            # as the ground station numbers it: "3/5"; a mission with commands: item 3 of 5,
            # "3/5 (lap 2 of 3)" where a DO_JUMP repeats it
            waypoint=numbering.label(index),
            # 0-based index in the mission, the planner's via points included, the media
            # map's stops not (what --resume counts; None at such a stop)
            index=self.mission_index(index),
            elapsed_autopilot_s=(
                round(t_boot_s - start, 1) if start is not None and t_boot_s >= start else None
            ),
            t_boot_s=round(t_boot_s, 2),
            error_m=round(error_m, 3),
        )
        if index + 1 < len(self.plan.waypoints):
            self.host.on_item(mission_item_of(self.plan, numbering, index + 1))

    def on_row(self, row: FlightRow) -> None:
        self.summary.add(row)
        self.display.autopilot_time(row.t_boot_s)
        if self.recorder is not None:
            self.recorder.record(row)

    def tell_radio_lost(self) -> None:
        """With ``safety.stop_on_rc_loss`` off helixd drives on when the radio is lost (as
        ArduPilot reports it): the ground station is told, once per loss."""
        lost = self.ap.state.rc_receiver_healthy is False
        if lost and not self.radio_lost_told and not self.cfg.safety.stop_on_rc_loss:
            log.warning("rc_lost_driving_on", reason="safety.stop_on_rc_loss is off")
            self.gcs.say("radio lost: driving on, no safety pilot", MAV_SEVERITY_WARNING)
        self.radio_lost_told = lost
