"""A long-lived link keeps the parameters it read or was sent: a missing one is remembered,
a PARAM_VALUE refreshes a value, and a start reads nothing again."""

from __future__ import annotations

import asyncio
import math
from typing import Any, cast

from helixd.link.services.command_client import CommandClient
from helixd.link.services.param import Param, ParamCache
from helixd.link.vehicle import VehicleState


class FakeCommands:
    """get_param answers from ``values`` (None: the autopilot has no such parameter)."""

    def __init__(self, values: dict[str, float | None]) -> None:
        self.values = values
        self.reads: list[str] = []
        self.param_seen: Any = None

    async def get_param(self, name: str, timeout_s: Any = None, retries: Any = None) -> Any:
        self.reads.append(name)
        return self.values.get(name)

    async def set_param(self, name: str, value: float) -> float:
        return value


def test_values_and_missing_parameters_are_read_once() -> None:
    fake = FakeCommands({"FS_GCS_ENABLE": 1.0})
    param = Param(cast(CommandClient, fake))
    cache = param.keep_cache()

    async def main() -> list[float | None]:
        return [await param.get(n) for n in ("FS_GCS_ENABLE", "HXG_VERSION") * 3]

    assert asyncio.run(main()) == [1.0, None] * 3
    assert fake.reads == ["FS_GCS_ENABLE", "HXG_VERSION"]  # a missing one costs one timeout
    fake.param_seen("FS_GCS_ENABLE", 0.0)  # a ground station set it: ArduPilot tells all links
    fake.param_seen("HXG_VERSION", 3.0)  # the guard installed since
    assert asyncio.run(main()) == [0.0, 3.0] * 3 and len(fake.reads) == 2
    cache.forget()  # the link lost: read again
    asyncio.run(main())
    assert len(fake.reads) == 4


def test_without_a_cache_every_get_reads() -> None:
    fake = FakeCommands({"A": 1.0})
    param = Param(cast(CommandClient, fake))
    asyncio.run(param.get("A"))
    asyncio.run(param.get("A"))
    assert fake.reads == ["A", "A"]


def test_a_non_finite_value_is_not_kept() -> None:
    cache = ParamCache()
    cache.seen("A", math.nan)
    assert not cache.knows("A")
    cache.answered("B", None)
    assert cache.knows("B") and cache.value("B") is None


def test_a_heartbeat_before_our_disarm_is_no_armed_now() -> None:
    """The last flight's disarm acknowledged, its HEARTBEAT not yet in: a start must arm
    again and wait for a HEARTBEAT saying so, not take the old one's armed."""
    st = VehicleState()
    st.armed, st.last_heartbeat_s = True, 10.0
    assert st.armed_now
    st.disarm_acked_s = 10.5
    assert not st.armed_now  # the heartbeat at 10.0 was before the disarm
    st.last_heartbeat_s = 11.0  # a later one still armed (armed again since)
    assert st.armed_now
