"""What the operator sees during ``helixd run``.

On a terminal: one live ``rich`` line (phase, waypoint i/N, distance to go, speed, heading
error, link/pose health, elapsed time; 80 columns in the usual case) redrawn at most
``refresh_hz`` times a second, then a result table. Not on a terminal (systemd/journald):
the same facts as structured ``progress`` events every ``event_interval_s`` and one
``result`` event — no escape codes.

Cheap from a 50 Hz loop: :meth:`ProgressDisplay.update` stores the values and returns unless a
redraw or an event is due (one clock read and a comparison).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import structlog
from rich.console import Console
from rich.live import Live
from rich.table import Table
from rich.text import Text

from helixd.recorder.summary import RunSummary

log = structlog.get_logger(__name__)

REFRESH_HZ = 4.0  # live line redraws per second, at most
EVENT_INTERVAL_S = 2.0  # progress events when not on a terminal


@dataclass(frozen=True, slots=True)
class ProgressInfo:
    waypoint_index: int  # i of "waypoint i/N": 1-based number of the waypoint being flown to
    waypoints_total: int
    distance_to_go_m: float  # to the current target
    speed_mps: float  # measured ground speed
    heading_error_deg: float
    link_ok: bool
    pose_fresh: bool
    elapsed_s: float  # since the mission started
    phase: str | None = None  # overrides the phase set by ProgressDisplay.phase() when given
    nav_state: str = ""  # navigator state (align, track, …)


def _fmt(value: float, spec: str) -> str:
    return format(value, spec) if math.isfinite(value) else "-"


def summary_rows(summary: RunSummary, run_dir: Path | None = None) -> list[tuple[str, str]]:
    """Label/value pairs shared by the final table, ``helixd replay`` and plain-text output."""

    def metres(v: float | None) -> str:
        return "-" if v is None else f"{v:.2f} m"

    rows = [
        ("mission", f"{summary.mission_name} ({summary.mode})"),
        ("result", "completed" if summary.completed else "NOT completed"),
        ("fault", summary.fault or "-"),
        ("exit code", str(summary.exit_code)),
        ("waypoints", f"{summary.waypoints_reached}/{summary.waypoints_total}"),
        ("duration", f"{summary.duration_s:.1f} s"),
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


def _arrivals_text(summary: RunSummary) -> str:
    if not summary.arrivals:
        return "-"
    return ", ".join(f"#{a.index} ({a.error_m:.2f} m)" for a in summary.arrivals)


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
    return round(value, digits) if math.isfinite(value) else None


def progress_fields(phase: str, info: ProgressInfo | None) -> dict[str, object]:
    """The ``progress`` event's fields (also what the live line shows)."""
    if info is None:
        return {"phase": phase}
    return {
        "phase": info.phase or phase,
        "nav_state": info.nav_state or None,
        "waypoint": f"{info.waypoint_index}/{info.waypoints_total}",
        "distance_to_go_m": _round(info.distance_to_go_m, 2),
        "speed_mps": _round(info.speed_mps, 2),
        "heading_error_deg": _round(info.heading_error_deg, 1),
        "link_ok": info.link_ok,
        "pose_fresh": info.pose_fresh,
        "elapsed_s": round(info.elapsed_s, 1),
    }


def progress_line(phase: str, info: ProgressInfo | None) -> Text:
    text = Text()
    shown = (info.phase if info is not None and info.phase else None) or phase
    text.append(f" {shown.upper()} ", style="bold reverse")
    if info is None:
        return text
    state = f" {info.nav_state}" if info.nav_state else ""
    text.append(f" wp {info.waypoint_index}/{info.waypoints_total}{state}")
    text.append(f"  {_fmt(info.distance_to_go_m, '.1f')} m to go")
    text.append(f"  {_fmt(info.speed_mps, '.2f')} m/s")
    text.append(f"  hdg {_fmt(info.heading_error_deg, '+.0f')}°")
    text.append("  link ")
    text.append("OK" if info.link_ok else "LOST", style="green" if info.link_ok else "bold red")
    text.append(" pose ")
    text.append(
        "OK" if info.pose_fresh else "STALE", style="green" if info.pose_fresh else "bold red"
    )
    text.append(f"  {info.elapsed_s:.0f} s")
    return text


class ProgressDisplay:
    """Operator display; ``tty`` picks the live line (True) or progress events (False)."""

    def __init__(
        self,
        tty: bool,
        *,
        console: Console | None = None,
        clock: Callable[[], float] = time.monotonic,
        refresh_hz: float = REFRESH_HZ,
        event_interval_s: float = EVENT_INTERVAL_S,
    ) -> None:
        self._tty = tty
        self._console = console
        self._clock = clock
        self._min_gap_s = 1.0 / refresh_hz if tty else event_interval_s
        self._phase = "startup"
        self._info: ProgressInfo | None = None
        self._last_out_s = -math.inf
        self._live: Live | None = None
        self.outputs = 0  # redraws (tty) or progress events (not a tty) so far

    def phase(self, name: str) -> None:
        """The daemon entered a phase (connect, preflight, arm, run, stop, …)."""
        if name == self._phase:
            return
        self._phase = name
        if self._tty:
            self._redraw(self._clock())
        else:
            log.info("phase", phase=name)

    def update(self, info: ProgressInfo) -> None:
        """New values; output only when a redraw (≤ refresh_hz) or an event is due."""
        self._info = info
        now = self._clock()
        if now - self._last_out_s < self._min_gap_s:
            return
        if self._tty:
            self._redraw(now)
        else:
            self._last_out_s = now
            self.outputs += 1
            log.info("progress", **progress_fields(self._phase, info))

    def final(self, summary: RunSummary, run_dir: Path | None = None) -> None:
        """Show the result: a table on a terminal, one ``result`` event otherwise."""
        self.close()
        if self._tty:
            self._get_console().print(summary_table(summary, run_dir))
        else:
            log.info(
                "result",
                mission=summary.mission_name,
                mode=summary.mode,
                completed=summary.completed,
                fault=summary.fault,
                exit_code=summary.exit_code,
                waypoints=f"{summary.waypoints_reached}/{summary.waypoints_total}",
                duration_s=round(summary.duration_s, 1),
                path_length_m=round(summary.path_length_m, 2),
                cross_track_rms_m=summary.cross_track_rms_m,
                cross_track_max_m=summary.cross_track_max_m,
                final_error_m=summary.final_error_m,
                run_dir=None if run_dir is None else str(run_dir),
            )

    def close(self) -> None:
        """Stop the live line (leaves its last state on screen). Idempotent."""
        live, self._live = self._live, None
        if live is not None:
            live.update(progress_line(self._phase, self._info), refresh=True)
            live.stop()

    def _get_console(self) -> Console:
        if self._console is None:
            self._console = Console(stderr=True)
        return self._console

    def _redraw(self, now: float) -> None:
        self._last_out_s = now
        self.outputs += 1
        line = progress_line(self._phase, self._info)
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
    "ProgressDisplay",
    "ProgressInfo",
    "progress_fields",
    "summary_rows",
    "summary_table",
]
