"""How a run ends: an exception, and the stage it came from, mapped through one table
(:data:`EXIT_RULES`) to a fault cause and an exit code; a flight the loop ended by its
result; a completion whose disarm failed. Pure: the runner (:mod:`helixd.runtime.daemon`)
raises, catches and falls back; this says what it meant.

A command refused during setup is exit 3 ("nothing was armed"); the same refusal in flight (a
DO_SET_SERVO refused mid-mission) is a fault, exit 4, after the fall-back. Exit codes:
:class:`helixd.base.exitcodes.ExitCode`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from helixd.actuators.base import ActuatorError
from helixd.base.exitcodes import ExitCode
from helixd.base.frames import NedPose
from helixd.files.models import as_items
from helixd.link.services.command_client import CommandError
from helixd.mav.url import LinkError
from helixd.mission.resolve import PlanError
from helixd.runtime.flight import FlightResult
from helixd.runtime.setup import PreflightFailed, StartRefused, StopBeforeFlight
from helixd.safety.supervisor import FallbackReport
from helixd.safety.watchdogs import OPERATOR_CAUSES, Fault, FaultCause


class Stage(StrEnum):
    """Where an exception came from: the same error means different things before and after
    the rover was armed and driven."""

    SETUP = "setup"  # startup: connect, preflight, start gate, MANUAL, arm
    FLIGHT = "flight"  # main_loop: the scrolls are (or may be) driven


@dataclass(frozen=True)
class ExitRule:
    """One row of :data:`EXIT_RULES`."""

    exceptions: tuple[type[BaseException], ...]
    stage: Stage | None  # None: either stage
    cause: FaultCause | None  # None: the exception carries its own fault (StartRefused)
    code: ExitCode
    event: str | None  # the log event naming each problem (None: the fall-back's log says it)
    message_prefix: str | None  # the operator's message line ("preflight: …"); None: none


# First match wins. Setup failures happen before anything was driven (the fall-back still
# runs if the sink was started or we armed); flight failures are faults of a moving rover.
EXIT_RULES: tuple[ExitRule, ...] = (
    ExitRule((StopBeforeFlight,), None, FaultCause.SIGNAL, ExitCode.OPERATOR_STOP, None, None),
    ExitRule((StartRefused,), None, None, ExitCode.FAULT, None, None),
    ExitRule(
        (PreflightFailed, PlanError, CommandError),
        Stage.SETUP,
        FaultCause.PREFLIGHT,
        ExitCode.PREFLIGHT,
        "preflight_failed",
        "preflight",
    ),
    ExitRule((LinkError,), Stage.SETUP, FaultCause.LINK_LOST, ExitCode.LINK, "link_failed", "link"),
    ExitRule(
        (ActuatorError, CommandError),
        Stage.FLIGHT,
        FaultCause.ACTUATOR,
        ExitCode.FAULT,
        "flight_command_failed",
        None,
    ),
    ExitRule((LinkError,), Stage.FLIGHT, FaultCause.LINK_LOST, ExitCode.FAULT, "link_failed", None),
    ExitRule((Exception,), None, FaultCause.EXCEPTION, ExitCode.INTERNAL_ERROR, None, None),
)


def exit_rule(exc: BaseException, stage: Stage) -> ExitRule:
    """The first rule of :data:`EXIT_RULES` matching ``exc`` raised in ``stage``."""
    for rule in EXIT_RULES:
        if isinstance(exc, rule.exceptions) and rule.stage in (None, stage):
            return rule
    return EXIT_RULES[-1]


def as_item_numbers(exc: Exception) -> Exception:
    """A refusal of a ground-station mission with its entries named by mission item
    (``item 3``) instead of the YAML list (``waypoint 3 (waypoints[2])``); anything else as
    it is."""
    if isinstance(exc, PreflightFailed):
        return PreflightFailed([as_items(p) for p in exc.problems])
    if isinstance(exc, PlanError):
        return PlanError(as_items(str(exc)))
    return exc


def problems_of(exc: BaseException) -> list[str]:
    """The human lines an exception stands for (a failed preflight has several)."""
    return list(exc.problems) if isinstance(exc, PreflightFailed) else [str(exc)]


@dataclass(frozen=True)
class Ending:
    """How the run ended: what shutdown and the summary need."""

    fault: Fault | None
    code: ExitCode
    detected_s: float | None = None  # monotonic time the fault was detected
    last_pose: NedPose | None = None


def ending_for(exc: BaseException, stage: Stage, now_s: float) -> tuple[Ending, ExitRule]:
    """Map an exception to the run's ending through :data:`EXIT_RULES` (pure)."""
    rule = exit_rule(exc, stage)
    if isinstance(exc, StartRefused):
        return Ending(exc.fault, rule.code, exc.detected_s), rule
    cause = rule.cause or FaultCause.EXCEPTION
    detail = (
        f"{type(exc).__name__}: {exc}"
        if cause is FaultCause.EXCEPTION
        else "; ".join(problems_of(exc))
    )
    detected = now_s if stage is Stage.FLIGHT else None
    return Ending(Fault(cause, detail), rule.code, detected), rule


def ending_of_flight(result: FlightResult) -> Ending:
    """The ending of a flight the loop itself ended (mission done, a watchdog, a signal)."""
    fault = result.fault
    if fault is None:
        code = ExitCode.OK
    elif fault.cause in OPERATOR_CAUSES:
        code = ExitCode.OPERATOR_STOP
    else:
        code = ExitCode.FAULT
    return Ending(fault, code, result.detected_s, result.last_pose)


def ending_after_fallback(
    ending: Ending, report: FallbackReport, disarm_asked: bool = True
) -> Ending:
    """A completed mission (exit 0) whose disarm failed is not exit 0: the exit-code table
    says 0 means disarmed, and the rover is left armed (pure). Any other ending stands, and
    so does a completion left armed on purpose (``disarm_asked`` false)."""
    if ending.code is not ExitCode.OK or report.disarmed or not disarm_asked:
        return ending
    why = "; ".join(e for e in report.errors if e.startswith("disarm")) or "disarm not confirmed"
    fault = Fault(FaultCause.NOT_DISARMED, f"every waypoint reached, but {why}: still armed")
    return Ending(fault, ExitCode.FAULT, ending.detected_s, ending.last_pose)
