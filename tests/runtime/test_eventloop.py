"""The daemon's event loop: the standard loop by default, uvloop when asked and installed."""

from __future__ import annotations

import asyncio
import gc

import pytest

from helixd.config.link import LinkConfig
from helixd.runtime import eventloop


async def _loop_module() -> str:
    return type(asyncio.get_running_loop()).__module__


def test_asyncio_is_the_default_and_the_standard_loop() -> None:
    assert LinkConfig().event_loop == "asyncio"
    assert eventloop.run(_loop_module(), LinkConfig().event_loop).startswith("asyncio")
    assert eventloop.run(asyncio.sleep(0, result=42)) == 42


def test_uvloop_when_installed_else_the_standard_loop(monkeypatch: pytest.MonkeyPatch) -> None:
    module = eventloop.run(_loop_module(), "uvloop")
    assert module.startswith("uvloop") is eventloop.uvloop_available()
    monkeypatch.setattr(eventloop, "uvloop_available", lambda: False)  # not installed: fallback
    assert eventloop.run(_loop_module(), "uvloop").startswith("asyncio")
    assert eventloop.loop_factory("uvloop")[1] == "asyncio"


def test_settle_collector_puts_the_startup_heap_out_of_the_collectors_reach() -> None:
    """What is alive when the daemon starts (modules, the dialect, the config) is frozen: the
    collector's full passes in flight scan only what the flight allocates."""
    gc.unfreeze()
    alive = [object.__new__(type("Startup", (), {})) for _ in range(1000)]
    try:
        eventloop.settle_collector()
        assert gc.get_freeze_count() >= len(alive)
        assert all(gc.is_tracked(x) for x in alive)  # tracked objects, now frozen
    finally:
        gc.unfreeze()
        gc.freeze()  # as the test session had it (tests/conftest.py)
