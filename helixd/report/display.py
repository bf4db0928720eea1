"""What the operator sees during ``helixd run``.

On a terminal: a live ``rich`` line (phase, waypoint i/N, distance to go, speed, heading
error, link/pose health; under it the mission time on the autopilot's and the wall clock; 80
columns in the usual case) redrawn at most ``refresh_hz`` times a second, then a result table.
Not on a terminal (systemd/journald): the same facts as structured ``progress`` events every
``event_interval_s`` and one ``result`` event — no escape codes. Either way the run ends with
one plain, greppable line (:func:`result_line`, ``helixd: RESULT …``).

Two clocks, always named: *autopilot time* (the autopilot's ``time_boot_ms``; a simulator
speed-up makes it run faster than the wall) and *wall time* (the companion's monotonic clock).

Cheap from a 50 Hz loop: :meth:`ProgressDisplay.update` stores the values and returns unless a
redraw or an event is due (one clock read and a comparison).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import structlog
from rich.console import Console
from rich.live import Live
from rich.table import Table
from rich.text import Text

from helixd.base.clock import now_s
from helixd.base.exitcodes import ExitCode
from helixd.base.plan import waypoint_label
from helixd.recorder.outcome import crew_ending, result_word
from helixd.recorder.summary import Arrival, RunSummary

log = structlog.get_logger(__name__)

REFRESH_HZ = 4.0  # live line redraws per second, at most
EVENT_INTERVAL_S = 2.0  # progress events when not on a terminal
ARRIVALS_LISTED_MAX = 6  # the result table lists each arrival up to this many
RESULT_PREFIX = "helixd: RESULT"
# the word after RESULT, per exit code: one greppable token
RESULT_WORDS: dict[int, str] = {
    ExitCode.OK: "ok",
    ExitCode.INTERNAL_ERROR: "internal-error",
    ExitCode.USAGE: "usage-error",
    ExitCode.PREFLIGHT: "refused",
    ExitCode.FAULT: "fault",
    ExitCode.OPERATOR_STOP: "stopped",
    ExitCode.LINK: "link-failed",
}


@dataclass(frozen=True, slots=True)
class ProgressInfo:
    waypoint_index: int  # i of "waypoint i/N": 1-based number of the waypoint being flown to
    waypoints_total: int
    distance_to_go_m: float  # to the current target
    speed_mps: float  # measured ground speed
    heading_error_deg: float
    link_ok: bool
    pose_fresh: bool
    elapsed_s: float  # wall (companion monotonic) time since the mission started
    phase: str | None = None  # overrides the phase set by ProgressDisplay.phase() when given
    nav_state: str = ""  # navigator state (align, track, …)
    # autopilot time since the mission started; None: ProgressDisplay fills it from the rows
    # it was told about (ProgressDisplay.autopilot_time), or it is shown as unknown
    autopilot_elapsed_s: float | None = None
    via: bool = False  # flying to a via point on the leg to waypoint i
    lap: str = ""  # a mission with commands: "lap 2 of 3" where a DO_JUMP repeats item i


class AutopilotElapsed:
    """Autopilot time flown so far, from a stream of ``time_boot_ms`` readings (seconds).

    Sums the forward steps of the autopilot clock, so an autopilot reboot (clock steps back)
    or a non-finite reading neither goes negative nor jumps. Pure; O(1) per reading.
    """

    def __init__(self) -> None:
        self._last: float | None = None
        self.elapsed_s: float | None = None  # None until the first finite reading

    def add(self, t_boot_s: float) -> None:
        if not math.isfinite(t_boot_s):
            return
        if self._last is None:
            self.elapsed_s = 0.0
        elif t_boot_s > self._last and self.elapsed_s is not None:
            self.elapsed_s += t_boot_s - self._last
        self._last = t_boot_s


def _fmt(value: float, spec: str) -> str:
    """``spec``-formatted, "-" when not finite; never "-0" (a rounded-away sign)."""
    if not math.isfinite(value):
        return "-"
    text = format(value, spec)
    if text.lstrip("+-").strip("0.") == "":  # rounds to zero: drop a "-" sign
        text = format(0.0, spec)
    return text


def summary_rows(summary: RunSummary, run_dir: Path | None = None) -> list[tuple[str, str]]:
    """Label/value pairs shared by the final table, ``helixd replay`` and plain-text output."""

    def metres(v: float | None) -> str:
        return "-" if v is None else f"{v:.2f} m"

    def seconds(v: float | None) -> str:
        return "-" if v is None or not math.isfinite(v) else f"{v:.1f} s"

    rows = [
        ("mission", f"{summary.mission_name} ({summary.mode})"),
        ("result", result_word(summary.completed, summary.fault)),
        ("ended by" if crew_ending(summary.fault) else "fault", summary.fault or "-"),
        ("exit code", str(summary.exit_code)),
        ("waypoints", waypoints_text(summary)),
    ]
    if summary.duration_clock == "autopilot":
        rows.append(("flight time (autopilot clock)", seconds(summary.duration_s)))
        if summary.patrol_item is not None:
            rows.append(("estimated at preflight", "a patrol: until stopped or the time limit"))
        elif summary.estimated_s is not None:
            rows.append(("estimated at preflight", seconds(summary.estimated_s)))
    else:
        rows.append(("flight time (autopilot clock)", "- (autopilot rebooted)"))
    if summary.companion_clock == "simulated":  # no wall time was measured
        rows.append(("whole run (simulated clock)", seconds(summary.wall_duration_s)))
    else:
        rows += [
            ("flight time (wall clock)", seconds(summary.duration_mono_s)),
            ("whole run (wall clock)", seconds(summary.wall_duration_s)),
        ]
    rows += [
        ("path driven", f"{summary.path_length_m:.1f} m"),
        ("cross-track rms", metres(summary.cross_track_rms_m)),
        ("cross-track max", metres(summary.cross_track_max_m)),
        ("final error", metres(summary.final_error_m)),
        ("arrivals", _arrivals_text(summary)),
        ("helixd", summary.helixd_version),
    ]
    if run_dir is not None:
        rows.append(("run directory", str(run_dir)))
    return rows


def waypoints_text(summary: RunSummary) -> str:
    """``3/3`` (the operator's waypoints), ``3/3 (+9/9 via points)`` with planned via points;
    a mission with commands: ``10/10 as flown (mission items 1–5, DO_JUMP laps each
    counted)``."""
    text = f"{summary.waypoints_reached}/{summary.waypoints_total}"
    if summary.patrol_item is not None:  # no total: it is flown until stopped
        text = f"{summary.waypoints_reached}"
    if summary.items_total is not None:
        text += f" as flown ({items_text(summary)})"
    if summary.via_points_total:
        text += f" (+{summary.via_points_reached}/{summary.via_points_total} via points)"
    return text


def items_text(summary: RunSummary) -> str:
    """What the count of a mission with commands is made of: ``mission items 1–5, DO_JUMP
    laps each counted`` (the laps only when a jump repeated an item)."""
    laps = any(a.lap for a in summary.arrivals)
    counted = ", DO_JUMP laps each counted" if laps else ""
    if summary.patrol_item is not None:
        counted = f", a patrol: DO_JUMP item {summary.patrol_item} repeats until stopped{counted}"
    return f"mission items 1–{summary.items_total}{counted}"


def _arrivals_text(summary: RunSummary) -> str:
    """``#1 +17.6 s (0.99 m)``: the operator's waypoint number (1-based, as the ground station
    numbers it), autopilot time since the first step, error. Via points are left out.

    More than :data:`ARRIVALS_LISTED_MAX` (a 25-point circle) are condensed to one line.
    """
    arrivals = [a for a in summary.arrivals if not a.via]
    if not arrivals:
        return "-"
    t0 = summary.start_t_boot_s
    clock = "" if t0 is None else " (autopilot clock)"

    def one(number: str, t_boot_s: float, error_m: float) -> str:
        when = "" if t0 is None or t_boot_s < t0 else f" +{t_boot_s - t0:.1f} s"
        return f"#{number}{when} ({error_m:.2f} m)"

    def num(a: Arrival) -> str:
        n = a.index + 1 if a.number is None else a.number  # older summaries: index
        return f"{n} ({a.lap})" if a.lap else str(n)

    if len(arrivals) > ARRIVALS_LISTED_MAX:
        errors = [a.error_m for a in arrivals]
        last = arrivals[-1]
        return (
            f"{len(arrivals)} waypoints, error {min(errors):.2f}–{max(errors):.2f} m, "
            f"last {one(num(last), last.t_boot_s, last.error_m)}{clock}; each in summary.json"
        )
    return ", ".join(one(num(a), a.t_boot_s, a.error_m) for a in arrivals) + clock


def _cause_text(fault: str | None) -> str:
    """The cause, whole (several preflight problems included), joined onto one line: the
    crew greps the journal for this line and reads nothing else."""
    if not fault:
        return ""
    return " " + " ".join(fault.split())


def result_line(summary: RunSummary) -> str:
    """The run's outcome as ONE plain line, on a terminal or not, for every exit path.

    ``helixd: RESULT ok — 4/4 waypoints, 72.3 s autopilot time (18.1 s wall), exit 0``
    ``helixd: RESULT fault pose_stale: … — 2/4 waypoints, 30.0 s autopilot time (7.5 s wall),
    exit 4``; on the simulated clock ``… 71.0 s autopilot time (simulated clock), exit 0``
    (its seconds are not the wall's). The word after RESULT depends on the exit code only
    (:data:`RESULT_WORDS`).
    """
    code = summary.exit_code
    word = RESULT_WORDS.get(code, "exit")
    count, _, rest = waypoints_text(summary).partition(" ")
    done = f"{count} waypoints" + (f" {rest}" if rest else "")
    wall = summary.duration_mono_s
    if summary.rows == 0 or wall is None:
        times = "not flown"
    elif summary.companion_clock == "simulated" and summary.duration_clock == "autopilot":
        times = f"{summary.duration_s:.1f} s autopilot time (simulated clock)"
    elif summary.duration_clock == "autopilot":
        times = f"{summary.duration_s:.1f} s autopilot time ({wall:.1f} s wall)"
    else:
        clock = "simulated" if summary.companion_clock == "simulated" else "wall"
        times = f"{wall:.1f} s {clock} (autopilot clock reset: rebooted)"
    if summary.record_cut_at_s is not None:  # the flight may be fine; its record is not
        times += f", record cut at {summary.record_cut_at_s:.1f} s"
    return f"{RESULT_PREFIX} {word}{_cause_text(summary.fault)} — {done}, {times}, exit {code}"


def summary_table(summary: RunSummary, run_dir: Path | None = None) -> Table:
    ok = summary.completed and summary.fault is None
    table = Table(
        title="helixd run result", show_header=False, title_style="bold green" if ok else "bold red"
    )
    table.add_column("", style="bold")
    table.add_column("")
    for label, value in summary_rows(summary, run_dir):
        style = ""
        if label in ("result", "fault") and not ok:
            style = "red"
        table.add_row(label, Text(value, style=style))
    return table


def _round(value: float, digits: int) -> float | None:
    return round(value, digits) + 0.0 if math.isfinite(value) else None  # + 0.0: no -0.0


def _opt_round(value: float | None, digits: int) -> float | None:
    return None if value is None else _round(value, digits)


def exit_result_line(code: ExitCode, cause: str | None = None) -> str:
    """The result line for an exit with no run behind it (e.g. a usage error in the CLI):
    ``helixd: RESULT usage-error mission.yaml: … — not flown, exit 2``."""
    word = RESULT_WORDS.get(int(code), "exit")
    return f"{RESULT_PREFIX} {word}{_cause_text(cause)} — not flown, exit {int(code)}"


def progress_fields(phase: str, info: ProgressInfo | None) -> dict[str, object]:
    """The ``progress`` event's fields (also what the live line shows)."""
    if info is None:
        return {"phase": phase}
    ap = info.autopilot_elapsed_s
    return {
        "phase": info.phase or phase,
        "nav_state": info.nav_state or None,
        "waypoint": waypoint_label(info.waypoint_index, info.via, info.waypoints_total, info.lap),
        "distance_to_go_m": _round(info.distance_to_go_m, 2),
        "speed_mps": _round(info.speed_mps, 2),
        "heading_error_deg": _round(info.heading_error_deg, 1),
        "link_ok": info.link_ok,
        "pose_fresh": info.pose_fresh,
        "elapsed_autopilot_s": None if ap is None else _round(ap, 1),
        "elapsed_wall_s": _round(info.elapsed_s, 1),
    }


def progress_line(phase: str, info: ProgressInfo | None) -> Text:
    text = Text()
    shown = (info.phase if info is not None and info.phase else None) or phase
    word, _, rest = shown.partition(" ")  # "arm (autopilot says: …)": only the phase shouts
    text.append(f" {word.upper()}{' ' + rest if rest else ''} ", style="bold reverse")
    if info is None:
        return text
    state = f" {info.nav_state}" if info.nav_state else ""
    wp = waypoint_label(info.waypoint_index, info.via, info.waypoints_total, info.lap)
    text.append(f" wp {wp}{state}")
    text.append(f"  {_fmt(info.distance_to_go_m, '.1f')} m to go")
    text.append(f"  {_fmt(info.speed_mps, '.2f')} m/s")
    text.append(f"  hdg {_fmt(info.heading_error_deg, '+.0f')}°")
    text.append("  link ")
    text.append("OK" if info.link_ok else "LOST", style="green" if info.link_ok else "bold red")
    text.append(" pose ")
    text.append(
        "OK" if info.pose_fresh else "STALE", style="green" if info.pose_fresh else "bold red"
    )
    ap = info.autopilot_elapsed_s
    ap_text = "-" if ap is None else _fmt(ap, ".0f")
    # a second line: both clocks named, without pushing the first line past 80 columns
    text.append(
        f"\n  mission time: {ap_text} s autopilot clock, {_fmt(info.elapsed_s, '.0f')} s wall"
    )
    return text


class ProgressDisplay:
    """Operator display; ``tty`` picks the live line (True) or progress events (False).

    ``plain_lines`` (not on a terminal, with a console quieter than the info events, e.g.
    ``make demo``): the progress line is also printed as plain text every event interval, and
    the result table at the end, so the operator sees progress and a summary without the
    event stream.
    """

    def __init__(
        self,
        tty: bool,
        *,
        plain_lines: bool = False,
        console: Console | None = None,
        clock: Callable[[], float] = now_s,
        refresh_hz: float = REFRESH_HZ,
        event_interval_s: float = EVENT_INTERVAL_S,
    ) -> None:
        self._tty = tty
        self._plain_lines = plain_lines and not tty
        self._console = console
        self._clock = clock
        self._min_gap_s = 1.0 / refresh_hz if tty else event_interval_s
        self._phase = "startup"
        self._info: ProgressInfo | Callable[[], ProgressInfo] | None = None
        self._last_out_s = -math.inf
        self._live: Live | None = None
        self._autopilot = AutopilotElapsed()
        self.outputs = 0  # redraws (tty) or progress events (not a tty) so far

    def phase(self, name: str) -> None:
        """The daemon entered a phase (connect, preflight, arm, run, stop, …).

        Redraws the live line on a terminal. Not on a terminal it logs nothing: the daemon's
        ``phase_start``/``phase_end`` events already say it (one line per event, not two).
        """
        if name == self._phase:
            return
        self._phase = name
        if self._tty:
            self._redraw(self._clock())

    def autopilot_time(self, t_boot_s: float) -> None:
        """The autopilot clock of the latest control step (s), for the elapsed-time display."""
        self._autopilot.add(t_boot_s)

    def update(self, info: ProgressInfo | Callable[[], ProgressInfo]) -> None:
        """New values; output only when a redraw (≤ refresh_hz) or an event is due.

        ``info`` may be a function building the values: it is called only when they are shown
        (the control loop hands one per step, and most steps are never drawn).
        """
        self._info = info
        now = self._clock()
        if now - self._last_out_s < self._min_gap_s:
            return
        if self._tty:
            self._redraw(now)
        else:
            self._last_out_s = now
            self.outputs += 1
            log.info("progress", **progress_fields(self._phase, self._shown()))
            if self._plain_lines:
                line = progress_line(self._phase, self._shown()).plain
                self._get_console().print(" ".join(line.split()), highlight=False, soft_wrap=True)

    def final(
        self, summary: RunSummary, run_dir: Path | None = None, *, log_event: bool = True
    ) -> None:
        """The run is over: log the one ``result`` event (``log_event``; see
        :meth:`log_result`) and, on a terminal, show the result table.

        (The plain :func:`result_line` is the caller's to print last, after every other line.)
        """
        self.close()
        if log_event:
            self.log_result(summary, run_dir)
        if self._tty or self._plain_lines:
            self._get_console().print(summary_table(summary, run_dir))

    def log_result(self, summary: RunSummary, run_dir: Path | None = None) -> None:
        """The ``result`` event: outcome, both clocks, accuracy (on a terminal and not)."""
        on_ap = summary.duration_clock == "autopilot" and summary.rows > 0
        wall = summary.duration_mono_s
        log.info(
            "result",
            mission=summary.mission_name,
            mode=summary.mode,
            completed=summary.completed,
            fault=summary.fault,
            exit_code=summary.exit_code,
            waypoints=waypoints_text(summary),
            flight_autopilot_s=round(summary.duration_s, 1) if on_ap else None,
            flight_wall_s=None if wall is None else round(wall, 1),
            run_wall_s=(
                None if summary.wall_duration_s is None else round(summary.wall_duration_s, 1)
            ),
            path_length_m=round(summary.path_length_m, 2),
            cross_track_rms_m=_opt_round(summary.cross_track_rms_m, 3),
            cross_track_max_m=_opt_round(summary.cross_track_max_m, 3),
            final_error_m=_opt_round(summary.final_error_m, 3),
            run_dir=None if run_dir is None else str(run_dir),
        )

    def close(self) -> None:
        """Stop the live line (leaves its last state on screen). Idempotent."""
        live, self._live = self._live, None
        if live is not None:
            live.update(progress_line(self._phase, self._shown()), refresh=True)
            live.stop()

    def _shown(self) -> ProgressInfo | None:
        """The latest values, the autopilot clock filled in from the rows (only when drawn)."""
        info = self._info
        if callable(info):
            info = self._info = info()  # built once, when first shown
        if info is None or info.autopilot_elapsed_s is not None:
            return info
        if self._autopilot.elapsed_s is None:
            return info
        return dataclasses.replace(info, autopilot_elapsed_s=self._autopilot.elapsed_s)

    def _get_console(self) -> Console:
        if self._console is None:
            self._console = Console(stderr=True)
        return self._console

    def _redraw(self, now: float) -> None:
        self._last_out_s = now
        self.outputs += 1
        line = progress_line(self._phase, self._shown())
        if self._live is None:
            self._live = Live(
                line, console=self._get_console(), auto_refresh=False, transient=False
            )
            self._live.start(refresh=True)
        else:
            self._live.update(line, refresh=True)

    def __enter__(self) -> ProgressDisplay:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


__all__ = [
    "EVENT_INTERVAL_S",
    "REFRESH_HZ",
    "RESULT_PREFIX",
    "AutopilotElapsed",
    "ProgressDisplay",
    "ProgressInfo",
    "exit_result_line",
    "progress_fields",
    "result_line",
    "summary_rows",
    "summary_table",
]
