"""Ending a background task the caller owns.

Every shutdown path that owns a task (the GCS report loop, the queue of mission commands, the
setup feeder, the service's idle work) ends it the same way: cancel it, then wait until it has
really ended, so nothing it does runs after the owner has moved on. The task's cancellation is
its normal end and is not raised; any other error it ended with is. A cancellation of the
caller that lands while it waits here is absorbed as well: these waits sit in shutdown paths
that must go on to the steps after them (the sink's neutral, the link's close), so the wait
never cuts them short.
"""

from __future__ import annotations

import asyncio
import contextlib
from typing import Any

__all__ = ["stop_task"]


async def stop_task(task: asyncio.Future[Any] | None) -> None:
    """Cancel ``task`` (None: nothing to stop) and wait until it has ended."""
    if task is None:
        return
    task.cancel()
    with contextlib.suppress(asyncio.CancelledError):
        await task
