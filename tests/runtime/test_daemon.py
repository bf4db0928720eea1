"""The runner's bounded close, its stop during preflight, and whether the fall-back disarms."""

from __future__ import annotations

import asyncio

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.runtime.daemon import disarm_after
from helixd.runtime.ending import (
    Ending,
    ending_after_fallback,
)
from helixd.runtime.setup import StopBeforeFlight
from helixd.safety.supervisor import FallbackReport
from helixd.safety.watchdogs import Fault, FaultCause


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
        # the crew handed the flight to the next (a new place, another item): nobody disarms
        (True, Ending(Fault(FaultCause.HANDOVER, "GUIDED"), ExitCode.OPERATOR_STOP), False),
        (True, Ending(Fault(FaultCause.ITEM_SET, "item 3"), ExitCode.OPERATOR_STOP), False),
        # the crew's pause of what we armed: disarmed, as a stop signal
        (True, Ending(Fault(FaultCause.PAUSED, "switch"), ExitCode.OPERATOR_STOP), True),
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


def test_serve_may_leave_a_completed_mission_armed_in_hold() -> None:
    """serve.disarm_when_complete false: no disarm asked, and armed is then no fault."""
    done = Ending(None, ExitCode.OK)
    assert disarm_after(False, done, when_complete=False) is False
    assert disarm_after(True, done) is True
    armed = FallbackReport("completed", "", hold_acked=True)
    assert ending_after_fallback(done, armed, disarm_asked=False) is done
    assert ending_after_fallback(done, armed).code is ExitCode.FAULT
