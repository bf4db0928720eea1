"""The payload-command queue: in order, one at a time, off the loop; every outcome recorded
(a refusal too), the mission going on; closing lets what is queued go out, bounded."""

from __future__ import annotations

import asyncio

import pytest
from structlog.testing import capture_logs

from helixd.base.plan import ActionKind, MissionAction
from helixd.link.services.command_client import CommandRejected, CommandTimeout
from helixd.runtime.mission_commands import CommandOutcome, MissionCommands


def action(item: int, command: int = 183) -> MissionAction:
    return MissionAction(item, command, ActionKind.SEND, params=(9.0, 1900.0, 0, 0, 0, 0, 0))


class Autopilot:
    def __init__(self, answers: dict[int, object], delay_s: float = 0.0) -> None:
        self.answers = answers
        self.delay_s = delay_s
        self.sent: list[tuple[int, tuple[float, ...]]] = []
        self.busy = 0
        self.max_busy = 0

    async def command_long(
        self, command: int, params: tuple[float, ...], timeout_s: float | None = None,
        retries: int | None = None,
    ) -> int:  # fmt: skip
        self.busy += 1
        self.max_busy = max(self.max_busy, self.busy)
        try:
            await asyncio.sleep(self.delay_s)
            self.sent.append((command, params))
            answer = self.answers.get(command, 0)
            if isinstance(answer, Exception):
                raise answer
            return int(str(answer))
        finally:
            self.busy -= 1


def test_commands_go_out_in_order_one_at_a_time_and_every_outcome_is_recorded() -> None:
    ap = Autopilot({181: CommandRejected("DO_SET_RELAY", 4), 206: CommandTimeout("X", 4, 0.5)},
                   delay_s=0.01)  # fmt: skip
    seen: list[CommandOutcome] = []

    async def go() -> None:
        mc = MissionCommands(ap, seen.append)
        mc.start()
        for a in (action(2), action(4, 181), action(6, 206), action(8)):
            mc.submit(a)  # never blocks the loop
        assert mc.pending >= 3
        await mc.close(2.0)

    with capture_logs() as logs:
        asyncio.run(go())
    assert [c for c, _ in ap.sent] == [183, 181, 206, 183] and ap.max_busy == 1
    assert [o.accepted for o in seen] == [True, False, False, True]
    assert "refused by the autopilot: FAILED" in seen[1].result and "no answer" in seen[2].result
    events = [e for e in logs if e["event"] == "mission_command"]
    assert [(e["item"], e["command"], e["accepted"]) for e in events] == [
        (2, "DO_SET_SERVO", True),
        (4, "DO_SET_RELAY", False),
        (6, "DO_SET_CAM_TRIGG_DIST", False),
        (8, "DO_SET_SERVO", True),
    ]
    assert events[1]["log_level"] == "warning"


def test_close_is_bounded_when_the_autopilot_is_slow() -> None:
    ap = Autopilot({}, delay_s=5.0)

    async def go() -> float:
        mc = MissionCommands(ap)
        mc.start()
        mc.submit(action(2))
        t0 = asyncio.get_running_loop().time()
        with capture_logs() as logs:
            await mc.close(0.1)
        assert any(e["event"] == "mission_commands_unsent" for e in logs)
        return asyncio.get_running_loop().time() - t0

    assert asyncio.run(go()) == pytest.approx(0.1, abs=0.2)
