"""helixd.serve.flights: what the ground station reads when a flight ends, and what a refused
start leaves for the next."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any, cast

from helixd.base.clock import now_s
from helixd.base.plan import Numbering
from helixd.base.run_files import EVENTS_FILE
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandRejected
from helixd.link.vehicle import VehicleState
from helixd.mav.constants import MAV_RESULT_DENIED
from helixd.mission.expand import ExpandOptions
from helixd.prepare.builder import AutoWalk
from helixd.recorder.summary import RunSummary
from helixd.runtime.host import ServeHost
from helixd.runtime.signals import StopRequest
from helixd.safety.supervisor import FallbackReport
from helixd.safety.watchdogs import FaultCause
from helixd.serve.check import Verdict
from helixd.serve.core import AutoWatch, ServeState
from helixd.serve.flights import (
    Flights,
    Interrupted,
    WalkLetGo,
    after_flight,
    flight_end_text,
    held_walk,
    read_open_run,
    read_state_file,
    write_state_file,
)
from helixd.serve.mission import MissionWatch
from helixd.serve.options import ServeOptions
from helixd.serve.status import ServeStatus


def summary_of(rows: int, reached: int) -> RunSummary:
    values: dict[str, Any] = {"rows": rows, "waypoints_reached": reached}  # all it reads
    return RunSummary.model_construct(**values)


RESULT = "helixd: RESULT stopped paused: DO_PAUSE_CONTINUE 0 — 1/2 waypoints, 9.0 s, exit 5"


def test_a_resumed_flight_counts_in_the_ground_stations_numbering() -> None:
    # resumed from waypoint 2 of 3: 'reached WP 3/3' must not be followed by '2/2 waypoints'
    numbering = Numbering.of([False, False], first=2, total=3)
    summary = summary_of(rows=10, reached=2)
    text = flight_end_text(summary, numbering, [RESULT])
    assert text == "3/3 waypoints"


def test_no_result_line_or_exit_code() -> None:
    numbering = Numbering.of([False, True, False])
    summary = summary_of(rows=10, reached=1)
    text = flight_end_text(summary, numbering, [RESULT])
    assert text == "1/2 waypoints"


def test_a_flight_never_started_says_why() -> None:
    numbering = Numbering.of([False])
    summary = summary_of(rows=0, reached=0)
    why = "preflight refused: EKF not healthy"
    assert flight_end_text(summary, numbering, [why, RESULT]) == why
    assert flight_end_text(None, numbering, [RESULT]) == "not flown"


def test_a_patrol_ends_without_a_total_of_its_planned_laps() -> None:
    numbering = Numbering((1, 2, 1, 2), (False,) * 4, 3, items=True)
    values: dict[str, Any] = {
        "rows": 10, "waypoints_reached": 3, "waypoints_total": 40, "patrol_item": 3,
        "arrivals": (),
    }  # fmt: skip
    text = flight_end_text(RunSummary.model_construct(**values), numbering, [RESULT])
    assert text == "3 waypoints as flown (patrol)"


def _events(run_dir: Path, *events: dict[str, Any]) -> None:
    run_dir.mkdir()
    text = "".join(json.dumps(ev) + "\n" for ev in events)
    (run_dir / EVENTS_FILE).write_text(text + "{torn", encoding="utf-8")


def test_the_walk_held_is_where_the_autopilots_own_item_was(tmp_path: Path) -> None:
    opts = ExpandOptions(first_item=3)
    started = [{"event": "mission_step", "kind": "step_started", "step": n} for n in (1, 2, 3)]
    helixd_only = tmp_path / "a"
    _events(helixd_only, *started)
    assert held_walk(WalkLetGo("f", opts, helixd_only), "f") == AutoWalk(opts, 3, exact=False)
    assert held_walk(WalkLetGo("f", opts, helixd_only), "other mission") is None
    assert held_walk(None, "f") is None
    followed = tmp_path / "b"
    _events(
        followed,
        *started,
        {"event": "autopilot_step", "item": 4, "step": 4},
        {"event": "autopilot_step", "item": 3, "step": "5"},  # garbled: ignored
    )
    assert held_walk(WalkLetGo("f", opts, followed), "f") == AutoWalk(opts, 4, exact=True)
    item_set = tmp_path / "c"
    _events(
        item_set,
        *started,
        {"event": "autopilot_step", "item": 4, "step": 2},
        {"event": "autopilot_item_set", "item": 1, "autopilot_step": 2},
    )
    assert held_walk(WalkLetGo("f", opts, item_set), "f") == AutoWalk(opts, 2, exact=True)


class _Pane:
    """The ground station's message pane (``ServeStatus.gcs``): what was said."""

    def __init__(self) -> None:
        self.texts: list[str] = []

    def say(self, text: str, severity: int) -> None:
        self.texts.append(text)


class _Action:
    """The autopilot's answer to helixd's HOLD: accepted, or refused."""

    def __init__(self, refuses: bool) -> None:
        self.refuses = refuses
        self.asked: list[str] = []

    async def set_mode(self, name: str, timeout_s: float | None = None) -> None:
        self.asked.append(name)
        if self.refuses:
            raise CommandRejected("DO_SET_MODE", MAV_RESULT_DENIED)


def _refusing(tmp_path: Path, refuses_hold: bool) -> tuple[Flights, Any, _Pane, AutoWatch]:
    """Flights on an autopilot armed in AUTO whose start was just taken from the watch."""
    opts = ServeOptions(HelixdConfig(), None, tmp_path)
    pane = _Pane()
    status = cast(ServeStatus, SimpleNamespace(gcs=pane))
    flights = Flights(opts, MissionWatch(opts), status, None, StopRequest())
    watch = flights.auto_watch
    watch.update(True, "HOLD", False, 1.0)
    assert watch.update(True, "AUTO", False, 2.0)
    watch.taken()
    st = VehicleState()
    st.armed, st.mode, st.last_heartbeat_s = True, "AUTO", 2.0
    return flights, SimpleNamespace(state=st, action=_Action(refuses_hold)), pane, watch


async def test_a_refused_starts_acknowledged_hold_makes_the_next_auto_a_start(
    tmp_path: Path,
) -> None:
    flights, ap, pane, watch = _refusing(tmp_path, refuses_hold=False)
    before_s = now_s()
    await flights._refuse(ap, "start refused: new plan failed its checks")
    assert ap.action.asked == ["HOLD"]
    assert pane.texts == ["start refused: new plan failed its checks"]
    # AUTO as reported before the acknowledgement: stale, no start
    assert not watch.update(True, "AUTO", False, before_s)
    # the crew's next Start Mission, before any report showed the HOLD: a start
    assert watch.update(True, "AUTO", False, now_s() + 0.2)


async def test_a_refused_hold_tells_the_crew_to_leave_auto_first(tmp_path: Path) -> None:
    """Rover takes Start Mission in AUTO without a mode change: helixd would not see it."""
    flights, ap, pane, watch = _refusing(tmp_path, refuses_hold=True)
    await flights._refuse(ap, "start refused: new plan failed its checks")
    assert ap.action.asked == ["HOLD"]
    said = pane.texts[-1]
    assert said.startswith("HOLD refused: ") and said.endswith("; leave AUTO, then start"), said
    assert not watch.update(True, "AUTO", False, now_s() + 0.2)  # still the start taken


def test_after_a_fault_whose_hold_was_acknowledged_the_next_auto_is_a_start() -> None:
    """A flight faulted in AUTO; its fall-back's HOLD was acknowledged at 10.0 s. Reports
    received until then (AUTO still) are no news; the first AUTO after it is the crew's Start,
    with no sighting of the HOLD needed (it may last less than one mode report)."""
    watch = AutoWatch()
    after_flight(watch, FaultCause.STALL, hold_acked_s=10.0)
    assert not watch.update(True, "AUTO", False, 9.9)
    assert watch.update(True, "AUTO", False, 10.1)


def test_after_a_fault_without_an_acknowledged_hold_auto_must_be_left_first() -> None:
    """No HOLD acknowledged (refused, or not asked): the autopilot may still be in AUTO, which
    must not start the next flight by itself; out of AUTO, then AUTO, is a start."""
    watch = AutoWatch()
    after_flight(watch, FaultCause.STALL, hold_acked_s=None)
    assert not watch.update(True, "AUTO", False, 10.1)
    assert not watch.update(True, "HOLD", False, 10.2)
    assert watch.update(True, "AUTO", False, 10.3)


def test_after_a_handover_auto_again_starts_at_once() -> None:
    watch = AutoWatch()
    after_flight(watch, FaultCause.RELEASED, hold_acked_s=None)
    assert watch.update(True, "AUTO", False, 10.1)


def test_the_service_host_keeps_when_the_fall_backs_hold_was_acknowledged() -> None:
    host = ServeHost(cast(Autopilot, None), StopRequest())
    host.secured(FallbackReport("stall", "dug in", hold_acked=False))
    assert host.hold_acked_s is None
    host.secured(FallbackReport("stall", "dug in", hold_acked=True))
    assert host.hold_acked_s is not None


def flights_told(opts: ServeOptions, told: _Told) -> Flights:
    """The service's flights with ``told`` as its status (no switch, no stop asked)."""
    return Flights(opts, MissionWatch(opts), cast(ServeStatus, told), None, StopRequest())


class _Told:
    """ServeStatus as the verdicts set it: the states, and what the pane was told."""

    def __init__(self) -> None:
        self.gcs = _Pane()
        self.state = ServeState.IDLE
        self.detail = ""
        self.sets: list[tuple[ServeState, str]] = []

    def set(self, state: ServeState, detail: str = "", severity: int | None = None) -> None:
        self.state, self.detail = state, detail
        self.sets.append((state, detail))


def test_a_verdict_is_applied_by_the_flights_with_a_continue_named(tmp_path: Path) -> None:
    """READY with the interrupted run a start continues (the state file's record, of this
    mission), REFUSED with the first problem and the next ones to the pane."""
    run_dir = tmp_path / "runs" / "run-1"
    run_dir.mkdir(parents=True)
    opts = ServeOptions(HelixdConfig(), None, tmp_path / "runs")
    write_state_file(opts.state_file, Interrupted("fp", run_dir), ServeState.PAUSED)
    told = _Told()
    flights = flights_told(opts, told)
    assert flights.interrupted == Interrupted("fp", run_dir)
    ready = cast(Any, SimpleNamespace(fingerprint="fp", waypoints=2))
    flights.apply(Verdict(ServeState.READY, "plan 0a0b0c: 2 waypoints checked", ready))
    assert told.sets[-1] == (
        ServeState.READY,
        "plan 0a0b0c: 2 waypoints checked (interrupted: a start continues it)",
    )
    other = cast(Any, SimpleNamespace(fingerprint="another plan", waypoints=2))
    flights.apply(Verdict(ServeState.READY, "plan 1a: 2 waypoints checked", other))
    assert told.sets[-1] == (ServeState.READY, "plan 1a: 2 waypoints checked")
    problems = ["item 2: too far", "item 3: too far"]
    flights.apply(Verdict(ServeState.REFUSED, problems[0], None, ["refused: item 3"], problems))
    assert told.sets[-1] == (ServeState.REFUSED, "item 2: too far")
    assert told.gcs.texts == ["refused: item 3"]
    flights.apply(Verdict(ServeState.IDLE, "no mission on the autopilot"))
    assert told.sets[-1] == (ServeState.IDLE, "no mission on the autopilot")


def test_the_state_file_keeps_the_interrupted_run(tmp_path: Path) -> None:
    path = tmp_path / "serve-state.json"
    assert read_state_file(path) is None  # none yet
    run_dir = tmp_path / "run-1"
    run_dir.mkdir()
    write_state_file(path, Interrupted("fp", run_dir), ServeState.PAUSED)
    assert read_state_file(path) == Interrupted("fp", run_dir.resolve())
    record = json.loads(path.read_text(encoding="utf-8"))
    assert (record["state"], record["mission_sha256"]) == ("paused", "fp")
    write_state_file(path, None, ServeState.COMPLETED)
    assert read_state_file(path) is None
    write_state_file(path, Interrupted("fp", tmp_path / "gone"), ServeState.PAUSED)
    assert read_state_file(path) is None  # its run directory is gone: nothing to continue


def test_a_flight_under_way_is_in_the_state_file_and_a_start_closes_it_if_killed(
    tmp_path: Path,
) -> None:
    """The record names the flight's run as it opens it (open_run_dir); a service started
    with that run still without a summary (killed) closes it, says so once, and a start
    continues it; the record then names no open run."""
    runs = tmp_path / "runs"
    run_dir = runs / "run-1"
    run_dir.mkdir(parents=True)
    (run_dir / EVENTS_FILE).write_text('{"event": "run_started", "mission": "m"}\n')
    opts = ServeOptions(HelixdConfig(), None, runs)
    write_state_file(opts.state_file, Interrupted("fp", run_dir), ServeState.FLYING, run_dir)
    record = json.loads(opts.state_file.read_text(encoding="utf-8"))
    assert record["state"] == "flying" and record["open_run_dir"] == str(run_dir.resolve())
    assert read_open_run(opts.state_file) == run_dir.resolve()
    told = _Told()
    flights = flights_told(opts, told)
    assert flights.interrupted == Interrupted("fp", run_dir.resolve())
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    assert summary["fault"].startswith("killed:") and summary["completed"] is False
    assert (
        flights.take_cut_text() == "helixd restarted: the last flight was cut; a start continues it"
    )
    assert flights.take_cut_text() is None  # told once
    assert read_open_run(opts.state_file) is None
    assert read_state_file(opts.state_file) == Interrupted("fp", run_dir.resolve())
    again = flights_told(opts, told)
    assert again.take_cut_text() is None  # closed already: nothing to tell a second start


def test_a_flight_killed_after_its_summary_said_completed_is_not_continued(
    tmp_path: Path,
) -> None:
    runs = tmp_path / "runs"
    run_dir = runs / "run-1"
    run_dir.mkdir(parents=True)
    (run_dir / "summary.json").write_text('{"completed": true}')
    opts = ServeOptions(HelixdConfig(), None, runs)
    write_state_file(opts.state_file, Interrupted("fp", run_dir), ServeState.FLYING, run_dir)
    told = _Told()
    flights = flights_told(opts, told)
    assert flights.interrupted is None and flights.take_cut_text() is None


def test_a_goto_flight_killed_is_closed_and_the_interrupted_run_stays(tmp_path: Path) -> None:
    runs = tmp_path / "runs"
    paused, goto = runs / "run-1", runs / "run-2-RTL"
    for d in (paused, goto):
        d.mkdir(parents=True)
    (paused / "summary.json").write_text('{"completed": false}')
    opts = ServeOptions(HelixdConfig(), None, runs)
    write_state_file(opts.state_file, Interrupted("fp", paused), ServeState.FLYING, goto)
    told = _Told()
    flights = flights_told(opts, told)
    assert flights.interrupted == Interrupted("fp", paused.resolve())
    assert (goto / "summary.json").is_file()
    assert flights.take_cut_text() == (
        "helixd restarted: the last flight was cut; the rover was left as it was"
    )
