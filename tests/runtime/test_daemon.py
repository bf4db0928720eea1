"""The daemon's exception → exit-code table (pure) and its bounded close."""

from __future__ import annotations

import asyncio

import pytest

from helixd.actuators.base import ServoCommandRefused
from helixd.base.exitcodes import ExitCode
from helixd.link.services.command_client import CommandRejected, CommandTimeout
from helixd.mav.url import LinkError
from helixd.mission.resolve import PlanError
from helixd.runtime.daemon import disarm_after
from helixd.runtime.ending import (
    EXIT_RULES,
    Ending,
    Stage,
    ending_after_fallback,
    ending_for,
    exit_rule,
)
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


def test_close_is_bounded(tmp_path: object) -> None:
    """A link whose close() hangs does not hang the exit: bounded by fallback_deadline_s."""
    from pathlib import Path

    from helixd.config.root import HelixdConfig
    from helixd.mission.model import Mission
    from helixd.runtime.daemon import MissionRunner, RunOptions

    cfg = HelixdConfig()
    mission = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": [{"x": 1, "y": 0}]}
    )
    runner = MissionRunner(RunOptions(cfg, mission, "", "udpin:127.0.0.1:0", Path("."), False))
    released = asyncio.Event()

    async def hang() -> None:
        try:
            await asyncio.Event().wait()
        finally:
            released.set()

    async def main() -> float:
        loop = asyncio.get_running_loop()
        t0 = loop.time()
        await runner._bounded_close("link", hang())
        assert released.is_set()  # the hanging close was cancelled, not left behind
        return loop.time() - t0

    took_s = asyncio.run(main())
    assert cfg.safety.fallback_deadline_s <= took_s < cfg.safety.fallback_deadline_s + 0.5


@pytest.mark.parametrize(
    ("armed_by_us", "ending", "disarm"),
    [
        (True, Ending(None, ExitCode.OK), True),
        # Ctrl-C / SIGTERM, in flight or while arming: nobody drives it, disarm what we armed
        (True, Ending(Fault(FaultCause.SIGNAL, "SIGINT received"), ExitCode.OPERATOR_STOP), True),
        # the pilot took over and may be driving: the config decides (disarm_on_fault)
        (True, Ending(Fault(FaultCause.PILOT_TAKEOVER, "HOLD"), ExitCode.OPERATOR_STOP), None),
        (True, Ending(Fault(FaultCause.GEOFENCE, "out"), ExitCode.FAULT), None),
        # armed before we came (a resume in HOLD): never ours to disarm by default
        (False, Ending(Fault(FaultCause.SIGNAL, "SIGINT received"), ExitCode.OPERATOR_STOP), None),
        # a completed mission ends disarmed even when a ground station armed it (exit 0
        # means disarmed): the next start after a takeover found it armed in HOLD
        (False, Ending(None, ExitCode.OK), True),
        # the crew released a flight of AUTO to the pilot (MANUAL): the pilot drives it
        (False, Ending(Fault(FaultCause.RELEASED, "MANUAL"), ExitCode.OPERATOR_STOP), False),
    ],
)
def test_disarm_after(armed_by_us: bool, ending: Ending, disarm: bool | None) -> None:
    assert disarm_after(armed_by_us, ending) is disarm


def test_a_stop_during_preflight_acts_at_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C while preflight waited on the autopilot (the EKF origin request: 3 s) took
    that long to act: the whole preflight is raced against the stop request now."""
    from pathlib import Path
    from types import SimpleNamespace
    from typing import Any

    from helixd.config.root import HelixdConfig
    from helixd.mission.model import Mission
    from helixd.runtime.daemon import MissionRunner, RunOptions
    from helixd.runtime.setup import Held

    cfg = HelixdConfig()
    mission = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": [{"x": 1, "y": 0}]}
    )
    runner = MissionRunner(RunOptions(cfg, mission, "", "udpin:127.0.0.1:0", Path("."), False))
    waiting = asyncio.Event()
    abandoned = asyncio.Event()

    async def open_link(*_: Any) -> object:
        return SimpleNamespace(tlog=None)  # no tlog attached

    async def slow_preflight(_: object) -> None:
        waiting.set()
        try:
            await asyncio.Event().wait()  # an answer that never comes
        finally:
            abandoned.set()

    monkeypatch.setattr(runner.host, "open", open_link)
    monkeypatch.setattr(runner, "_preflight", slow_preflight)

    async def main() -> None:
        startup = asyncio.create_task(runner.startup(Held()))
        await waiting.wait()
        runner.stop.trigger("SIGINT")
        async with asyncio.timeout(0.5):  # at once, not after the wait's own timeout
            with pytest.raises(StopBeforeFlight):
                await startup
        assert abandoned.is_set()

    asyncio.run(main())


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


def test_serve_may_leave_a_completed_mission_armed_in_hold() -> None:
    """serve.disarm_when_complete false: no disarm asked, and armed is then no fault."""
    done = Ending(None, ExitCode.OK)
    assert disarm_after(False, done, when_complete=False) is False
    assert disarm_after(True, done) is True
    armed = FallbackReport("completed", "", hold_acked=True)
    assert ending_after_fallback(done, armed, disarm_asked=False) is done
    assert ending_after_fallback(done, armed).code is ExitCode.FAULT
