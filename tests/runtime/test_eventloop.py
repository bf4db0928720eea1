"""The daemon's event loop: uvloop when installed, the standard loop otherwise or when asked."""

from __future__ import annotations

import asyncio

import pytest

from helixd.config import LinkConfig
from helixd.runtime import eventloop


async def _loop_module() -> str:
    return type(asyncio.get_running_loop()).__module__


def test_asyncio_choice_runs_on_the_standard_loop() -> None:
    assert eventloop.run(_loop_module(), "asyncio").startswith("asyncio")


def test_auto_is_uvloop_when_installed(monkeypatch: pytest.MonkeyPatch) -> None:
    module = eventloop.run(_loop_module(), "auto")
    assert module.startswith("uvloop") is eventloop.uvloop_available()
    monkeypatch.setattr(eventloop, "uvloop_available", lambda: False)  # not installed: fallback
    assert eventloop.run(_loop_module(), "auto").startswith("asyncio")
    assert eventloop.loop_factory("auto")[1] == "asyncio"


def test_the_config_default_is_auto_and_the_value_returns() -> None:
    assert LinkConfig().event_loop == "auto"
    assert eventloop.run(asyncio.sleep(0, result=42), LinkConfig().event_loop) == 42
