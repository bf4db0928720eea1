"""asyncio's private names the simulated clock reads (helixd.base.asyncio_internals): each
still exists on the running interpreter with the meaning the clock relies on."""

from __future__ import annotations

import ast
import asyncio
import sys
import time
from pathlib import Path

from helixd.base import asyncio_internals
from helixd.base.asyncio_internals import (
    CHECKED_PYTHON,
    clock_resolution_s,
    running_loop,
    scheduled_timers,
)
from helixd.base.clock import SimulatedClockLoop
from tests.support.paths import REPO_ROOT

PRIVATE_NAMES = {"_get_running_loop", "_scheduled", "_clock_resolution"}


def test_the_checked_versions_are_named_and_include_the_oldest_supported() -> None:
    assert (3, 11) in CHECKED_PYTHON  # pyproject's requires-python floor
    assert all(major == 3 and minor >= 11 for major, minor in CHECKED_PYTHON)


def test_running_loop_is_none_outside_a_loop_and_the_loop_inside() -> None:
    async def inside() -> bool:
        return running_loop() is asyncio.get_running_loop()

    assert running_loop() is None
    assert asyncio.run(inside())


def test_a_timer_made_by_call_later_is_among_the_scheduled_and_leaves_when_run() -> None:
    async def main() -> tuple[bool, bool, float]:
        loop = asyncio.get_running_loop()
        assert hasattr(loop, "_scheduled"), f"asyncio on {sys.version_info[:2]} renamed _scheduled"
        handle = loop.call_later(3.0, lambda: None)
        held = handle in scheduled_timers(loop)
        when_s = handle.when() - loop.time()
        handle.cancel()
        await asyncio.sleep(0)
        fired = asyncio.Event()
        loop.call_soon(fired.set)
        await fired.wait()
        return held, all(isinstance(h, asyncio.TimerHandle) for h in scheduled_timers(loop)), when_s

    held, all_timers, when_s = asyncio.run(main())
    assert held and all_timers
    assert 2.9 < when_s <= 3.0


def test_the_scheduled_timers_are_a_heap_by_their_time() -> None:
    """The simulated clock walks only the top of ``_scheduled`` (helixd.base.clock.
    latest_due_s): every timer is due no earlier than its parent in the heap, cancelled ones
    and ones set out of order included."""

    async def main() -> list[float]:
        loop = asyncio.get_running_loop()
        handles = [loop.call_later(d, lambda: None) for d in (5.0, 1.0, 3.0, 1.0, 4.0, 2.0, 0.5)]
        for handle in handles[1::3]:
            handle.cancel()
        whens = [h.when() for h in scheduled_timers(loop)]
        for handle in handles:
            handle.cancel()
        return whens

    whens = asyncio.run(main())
    assert len(whens) == 7
    assert all(whens[(i - 1) // 2] <= whens[i] for i in range(1, len(whens)))


def test_the_clock_resolution_is_the_monotonic_clocks() -> None:
    async def main() -> tuple[bool, float]:
        loop = asyncio.get_running_loop()
        return hasattr(loop, "_clock_resolution"), clock_resolution_s(loop)

    present, resolution_s = asyncio.run(main())
    assert present, f"asyncio on {sys.version_info[:2]} renamed _clock_resolution"
    assert resolution_s == time.get_clock_info("monotonic").resolution
    assert 0.0 < resolution_s < 1e-3


def test_the_simulated_clock_loop_has_them_too() -> None:
    loop = SimulatedClockLoop()
    try:
        handle = loop.call_later(1.0, lambda: None)
        assert handle in scheduled_timers(loop)
        assert clock_resolution_s(loop) > 0.0
    finally:
        loop.close()


def test_no_other_module_reads_asyncio_private_names() -> None:
    here = Path(asyncio_internals.__file__).resolve()
    readers = []
    for path in sorted((REPO_ROOT / "helixd").rglob("*.py")):
        if path.resolve() == here:
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Attribute) and node.attr in PRIVATE_NAMES:
                readers.append(f"{path.relative_to(REPO_ROOT)}:{node.lineno} {node.attr}")
            if isinstance(node, ast.Constant) and node.value in PRIVATE_NAMES:
                readers.append(f"{path.relative_to(REPO_ROOT)}:{node.lineno} {node.value!r}")
    assert readers == []
