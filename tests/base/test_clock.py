"""The one clock (helixd.base.clock): now_s follows the running loop, and the simulated
clock loop skips waits but never a byte that is ready."""

from __future__ import annotations

import ast
import asyncio
import contextlib
import heapq
import random
import socket
import time
from pathlib import Path

import pytest

from helixd.base import clock
from helixd.base.clock import SIMULATED_START_S, SimulatedClockLoop, now_s, unix_s
from tests.support.paths import REPO_ROOT
from tests.support.simclock import run_simulated

# modules allowed to read the process's clocks directly, and why
OWN_CLOCK_READERS = {
    "helixd/base/clock.py": "the clock itself",
    "helixd/sim/server.py": "wait_for/next_snapshot: called from other threads, in wall time",
    "helixd/plant/json_server.py": "the SITL plant: SITL's lockstep paces it, its stats are wall",
    "helixd/planning/route.py": "perf_counter: how long the planner computed, a measurement",
}
CLOCK_CALLS = {("time", "monotonic"), ("time", "perf_counter"), ("time", "monotonic_ns")}


def test_a_long_sleep_takes_no_wall_time_and_exactly_its_simulated_time() -> None:
    async def main() -> tuple[float, float]:
        t0 = now_s()
        await asyncio.sleep(3600.0)
        return t0, now_s()

    wall0 = time.monotonic()
    t0, t1 = run_simulated(main)
    assert time.monotonic() - wall0 < 5.0  # an hour of simulated waiting
    assert t0 == SIMULATED_START_S
    assert t1 - t0 == pytest.approx(3600.0, abs=1e-6)


def test_timeouts_fire_in_simulated_time_in_order() -> None:
    async def main() -> list[tuple[str, float]]:
        seen: list[tuple[str, float]] = []

        async def after(name: str, s: float) -> None:
            await asyncio.sleep(s)
            seen.append((name, now_s() - SIMULATED_START_S))

        never = asyncio.Event()
        await asyncio.gather(after("b", 2.5), after("a", 0.5))
        with pytest.raises(TimeoutError):
            await asyncio.wait_for(never.wait(), 10.0)
        seen.append(("timeout", now_s() - SIMULATED_START_S))
        return seen

    seen = run_simulated(main)
    assert [n for n, _ in seen] == ["a", "b", "timeout"]
    assert [t for _, t in seen] == pytest.approx([0.5, 2.5, 12.5], abs=1e-6)


def test_waiting_out_a_remainder_in_steps_reaches_the_deadline() -> None:
    """A task waiting ``deadline - now_s()`` in steps while another task is always ready (so
    the loop never sleeps, it polls): asyncio runs a timer due within its clock resolution
    slightly early, and a clock that stood still there would leave a remainder of 1e-14 s
    for ever (seen: a wait at 1030.2099999999725 for 1030.21 spun). The clock reaches every
    timer it runs."""

    async def main() -> tuple[int, float]:
        for _ in range(21):  # sums of 0.01 s: the clock picks up rounding (1000.2099999…)
            await asyncio.sleep(0.01)
        deadline = SIMULATED_START_S + 0.21
        assert now_s() != deadline  # the case that spun
        done = asyncio.Event()

        async def busy() -> int:
            polls = 0
            while not done.is_set():
                polls += 1
                assert polls < 10_000, f"stuck at {now_s()!r}, deadline {deadline!r}"
                await asyncio.sleep(0)
            return polls

        poller = asyncio.create_task(busy())
        steps = 0
        never = asyncio.Event()
        while (remaining := deadline - now_s()) > 0:
            steps += 1
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(never.wait(), remaining)
        done.set()
        await poller
        return steps, now_s()

    steps, end_s = run_simulated(main)
    assert steps <= 2 and end_s >= SIMULATED_START_S + 0.21


def test_a_clock_held_at_one_instant_by_a_spinning_task_is_an_error(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A task that never waits holds simulated time still: the run ends with an error naming
    it instead of hanging (the limit shortened here from 30 s of wall time)."""
    monkeypatch.setattr(clock, "STUCK_WALL_S", 0.2)

    async def main() -> None:
        while True:  # noqa: ASYNC110 - the spin under test
            await asyncio.sleep(0)

    with pytest.raises(RuntimeError, match=r"stood still at 1000\.0 s"):
        run_simulated(main)


def test_a_ready_datagram_is_read_before_the_clock_jumps() -> None:
    """The jump happens only when no socket has anything: a datagram already sent is handed
    over at the same simulated instant, not after the reader's timeout."""

    async def main() -> tuple[bytes, float]:
        loop = asyncio.get_running_loop()
        rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        rx.bind(("127.0.0.1", 0))
        rx.setblocking(False)
        tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        got: asyncio.Future[bytes] = loop.create_future()
        loop.add_reader(rx.fileno(), lambda: got.set_result(rx.recv(100)))
        try:
            await asyncio.sleep(1.0)
            t_sent = now_s()
            tx.sendto(b"pose", rx.getsockname())
            data = await asyncio.wait_for(got, 30.0)
            return data, now_s() - t_sent
        finally:
            loop.remove_reader(rx.fileno())
            rx.close()
            tx.close()

    data, waited_s = run_simulated(main)
    assert data == b"pose"
    assert waited_s == 0.0


def test_now_s_is_the_running_loops_time_and_monotonic_outside() -> None:
    before = time.monotonic()
    assert before <= now_s() <= time.monotonic()

    async def main() -> tuple[float, float]:
        return now_s(), asyncio.get_running_loop().time()

    mine, loops = run_simulated(main)
    assert mine == loops == SIMULATED_START_S


def test_thread_work_is_refused_on_the_simulated_clock() -> None:
    async def main() -> None:
        await asyncio.get_running_loop().run_in_executor(None, time.sleep, 0.0)

    with pytest.raises(RuntimeError, match="executor"):
        run_simulated(main)


def test_the_clock_loop_counts_its_jumps() -> None:
    loop = SimulatedClockLoop()
    try:
        loop.run_until_complete(asyncio.sleep(2.0))
        assert loop.jumps >= 1
        assert loop.time() == pytest.approx(SIMULATED_START_S + 2.0)
    finally:
        loop.close()


def _own_clock_reads(path: Path) -> list[int]:
    lines = []
    for node in ast.walk(ast.parse(path.read_text())):
        if (
            isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and isinstance(node.func.value, ast.Name)
            and (node.func.value.id, node.func.attr) in CLOCK_CALLS
        ):
            lines.append(node.lineno)
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and (node.value.id, node.attr) in CLOCK_CALLS
        ):
            lines.append(node.lineno)  # also passed along as a clock, e.g. clock=time.monotonic
        if (
            isinstance(node, ast.ImportFrom)
            and node.module == "time"
            and any(("time", a.name) in CLOCK_CALLS for a in node.names)
        ):
            lines.append(node.lineno)
    return sorted(set(lines))


def test_no_module_reads_the_monotonic_clock_on_its_own() -> None:
    """Timing goes through helixd.base.clock.now_s, so a simulated clock times everything."""
    offenders = []
    for path in sorted((REPO_ROOT / "helixd").rglob("*.py")):
        rel = path.relative_to(REPO_ROOT).as_posix()
        if rel in OWN_CLOCK_READERS:
            continue
        offenders += [f"{rel}:{n}" for n in _own_clock_reads(path)]
    assert offenders == []


def test_calendar_time_follows_the_simulated_clock() -> None:
    """A record stamped in calendar time replays at the pace it was flown."""

    async def main() -> tuple[float, float]:
        first = unix_s()
        await asyncio.sleep(600.0)
        return first, unix_s()

    wall = time.time()
    first, later = run_simulated(main)
    assert abs(first - wall) < 5.0  # starts at the wall's date
    assert later - first == pytest.approx(600.0, abs=1e-6)
    assert abs(unix_s() - time.time()) < 1e-3  # outside a simulated loop: the wall


def test_the_latest_due_timer_is_found_in_the_heap_as_by_looking_at_every_timer() -> None:
    """``latest_due_s`` walks only the top of the loop's heap: the same answer as a look at
    every timer, cancelled ones and ties included."""
    rnd = random.Random(54)
    loop = asyncio.new_event_loop()
    try:
        for _ in range(300):
            timers: list[asyncio.TimerHandle] = []
            for _ in range(rnd.randrange(0, 40)):
                when_s = 1000.0 + rnd.choice([rnd.random(), round(rnd.random(), 1)])
                heapq.heappush(timers, asyncio.TimerHandle(when_s, print, (), loop))
            for timer in rnd.sample(timers, len(timers) // 3):
                timer.cancel()
            after_s = 1000.0 + rnd.random()
            before_s = after_s + rnd.choice([1e-9, 0.05, 0.3])
            due = [t.when() for t in timers if after_s < t.when() < before_s and not t.cancelled()]
            assert clock.latest_due_s(timers, after_s, before_s) == (max(due) if due else None)
    finally:
        loop.close()
