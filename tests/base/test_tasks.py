"""Ending a background task (helixd.base.tasks.stop_task): cancelled, waited for, its own
cancellation not raised, any other error it ended with raised."""

from __future__ import annotations

import asyncio

import pytest

from helixd.base.tasks import stop_task


async def test_nothing_to_stop() -> None:
    await stop_task(None)


async def test_the_task_has_ended_and_run_its_cleanup_when_stop_returns() -> None:
    started = asyncio.Event()
    cleaned: list[str] = []

    async def worker() -> None:
        started.set()
        try:
            await asyncio.Event().wait()  # until cancelled
        finally:
            await asyncio.sleep(0)  # the cleanup itself awaits
            cleaned.append("done")

    task = asyncio.create_task(worker())
    await asyncio.wait_for(started.wait(), timeout=5.0)
    await stop_task(task)
    assert task.cancelled()
    assert cleaned == ["done"]


async def test_an_error_the_task_ended_with_is_raised() -> None:
    async def broken() -> None:
        raise RuntimeError("report loop broke")

    task = asyncio.create_task(broken())
    await asyncio.wait({task}, timeout=5.0)
    with pytest.raises(RuntimeError, match="report loop broke"):
        await stop_task(task)


async def test_a_task_that_finished_is_left_as_it_was() -> None:
    async def quick() -> int:
        return 7

    task = asyncio.create_task(quick())
    await asyncio.wait({task}, timeout=5.0)
    await stop_task(task)
    assert task.result() == 7
