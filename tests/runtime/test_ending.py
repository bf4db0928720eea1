"""How a run ends (pure): the exception → exit-code table by stage, a flight's own ending, and a
completion whose disarm failed."""

from __future__ import annotations

import pytest

from helixd.actuators.base import ServoCommandRefused
from helixd.base.exitcodes import ExitCode
from helixd.base.frames import NedPose
from helixd.link.services.command_client import CommandRejected, CommandTimeout
from helixd.mav.url import LinkError
from helixd.mission.resolve import PlanError
from helixd.runtime.ending import (
    EXIT_RULES,
    Ending,
    Stage,
    as_item_numbers,
    ending_after_fallback,
    ending_for,
    ending_of_flight,
    exit_rule,
    problems_of,
)
from helixd.runtime.flight import FlightResult
from helixd.runtime.setup import PreflightFailed, StartRefused, StopBeforeFlight
from helixd.safety.supervisor import FallbackReport
from helixd.safety.watchdogs import Fault, FaultCause


def servo_refused() -> ServoCommandRefused:
    return ServoCommandRefused(2, 1700, CommandRejected("DO_SET_SERVO", 4))


@pytest.mark.parametrize(
    ("exc", "stage", "cause", "code"),
    [
        (servo_refused(), Stage.SETUP, FaultCause.PREFLIGHT, ExitCode.PREFLIGHT),
        # a refusal in flight is a fault of a moving rover, not "nothing was armed"
        (servo_refused(), Stage.FLIGHT, FaultCause.ACTUATOR, ExitCode.FAULT),
        (CommandTimeout("DO_SET_SERVO", 3, 0.5), Stage.FLIGHT, FaultCause.ACTUATOR, ExitCode.FAULT),
        (CommandRejected("DO_SET_MODE", 4), Stage.SETUP, FaultCause.PREFLIGHT, ExitCode.PREFLIGHT),
        (PlanError("bad plan"), Stage.SETUP, FaultCause.PREFLIGHT, ExitCode.PREFLIGHT),
        (PreflightFailed(["a", "b"]), Stage.SETUP, FaultCause.PREFLIGHT, ExitCode.PREFLIGHT),
        (LinkError("no such device"), Stage.SETUP, FaultCause.LINK_LOST, ExitCode.LINK),
        (LinkError("gone"), Stage.FLIGHT, FaultCause.LINK_LOST, ExitCode.FAULT),
        (
            StopBeforeFlight("SIGINT received"),
            Stage.SETUP,
            FaultCause.SIGNAL,
            ExitCode.OPERATOR_STOP,
        ),
        (RuntimeError("bug"), Stage.SETUP, FaultCause.EXCEPTION, ExitCode.INTERNAL_ERROR),
        (RuntimeError("bug"), Stage.FLIGHT, FaultCause.EXCEPTION, ExitCode.INTERNAL_ERROR),
    ],
)
def test_exit_table(exc: Exception, stage: Stage, cause: FaultCause, code: ExitCode) -> None:
    ending, rule = ending_for(exc, stage, now_s=12.5)
    assert rule is exit_rule(exc, stage)
    assert ending.code is code
    assert ending.fault is not None and ending.fault.cause is cause
    # a flight failure is detected now (the fall-back's timing starts there); setup: no motion
    assert ending.detected_s == (12.5 if stage is Stage.FLIGHT else None)


def test_preflight_problems_are_joined_and_exceptions_named() -> None:
    ending, rule = ending_for(PreflightFailed(["no pose", "EKF"]), Stage.SETUP, 0.0)
    assert ending.fault == Fault(FaultCause.PREFLIGHT, "no pose; EKF")
    assert (rule.event, rule.message_prefix) == ("preflight_failed", "preflight")
    ending, _ = ending_for(ValueError("x"), Stage.FLIGHT, 0.0)
    assert ending.fault == Fault(FaultCause.EXCEPTION, "ValueError: x")


def test_start_refused_keeps_its_own_fault_and_time() -> None:
    fault = Fault(FaultCause.PREFLIGHT, "moved out of the fence")
    ending, _ = ending_for(StartRefused(fault, 3.0), Stage.SETUP, 9.0)
    assert (ending.fault, ending.code, ending.detected_s) == (fault, ExitCode.FAULT, 3.0)


def test_every_exit_code_of_a_run_is_reachable_and_last_rule_catches_all() -> None:
    codes = {rule.code for rule in EXIT_RULES}
    assert codes == {
        ExitCode.OPERATOR_STOP,
        ExitCode.FAULT,
        ExitCode.PREFLIGHT,
        ExitCode.LINK,
        ExitCode.INTERNAL_ERROR,
    }
    assert EXIT_RULES[-1].exceptions == (Exception,) and EXIT_RULES[-1].stage is None


def test_a_completed_mission_left_armed_is_no_exit_0() -> None:
    """Exit 0 means disarmed: a completed mission whose disarm the autopilot refused ends as a
    fault naming it, so the operator is never told 'ok' about a rover still armed."""
    done = Ending(None, ExitCode.OK)
    refused = FallbackReport("completed", "", hold_acked=True, errors=["disarm: DENIED"])
    got = ending_after_fallback(done, refused)
    assert got.code is ExitCode.FAULT and got.fault is not None
    assert got.fault.cause is FaultCause.NOT_DISARMED
    assert got.fault.detail == "every waypoint reached, but disarm: DENIED: still armed"
    ok = FallbackReport("completed", "", hold_acked=True, disarmed=True)
    assert ending_after_fallback(done, ok) is done
    takeover = Ending(Fault(FaultCause.PILOT_TAKEOVER, "HOLD"), ExitCode.OPERATOR_STOP)
    assert ending_after_fallback(takeover, refused) is takeover  # left armed for the pilot


@pytest.mark.parametrize(
    ("fault", "code"),
    [
        (None, ExitCode.OK),  # every waypoint reached
        (Fault(FaultCause.SIGNAL, "SIGINT received"), ExitCode.OPERATOR_STOP),
        (Fault(FaultCause.PILOT_TAKEOVER, "HOLD"), ExitCode.OPERATOR_STOP),
        (Fault(FaultCause.STALL, "no progress"), ExitCode.FAULT),
    ],
)
def test_a_flight_the_loop_ended_keeps_its_fault_time_and_pose(
    fault: Fault | None, code: ExitCode
) -> None:
    pose = NedPose(3.0, 4.0, 0.5)
    ending = ending_of_flight(FlightResult(fault, 42.0, None, pose))
    assert (ending.fault, ending.code, ending.detected_s, ending.last_pose) == (
        fault,
        code,
        42.0,
        pose,
    )


def test_a_ground_station_missions_refusals_name_its_items() -> None:
    named = as_item_numbers(PreflightFailed(["waypoint 3 (waypoints[2]): too far"]))
    assert isinstance(named, PreflightFailed)
    assert named.problems == ["item 3: too far"]
    assert problems_of(named) == ["item 3: too far"]
    other = RuntimeError("bug")
    assert as_item_numbers(other) is other and problems_of(other) == ["bug"]
