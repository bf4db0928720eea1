"""The param plugin (MAVSDK's shape): read and write autopilot parameters by name.

PARAM_REQUEST_READ / PARAM_SET with their answers matched and re-sent by
:class:`helixd.link.services.command_client.CommandClient`.

A long-lived link (``helixd serve``) keeps a :class:`ParamCache`: every value read, and every
PARAM_VALUE the autopilot sends (ArduPilot sends one to every link when anyone sets a
parameter), is kept, and a parameter the autopilot does not answer for is remembered as
missing, so a flight's preflight judges what was read while the service was idle instead of
reading it all again (and waiting out a missing one's timeout) at each start. The service
forgets it when the link is lost or the autopilot reboots.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from helixd.link.services.command_client import CommandClient


@dataclass(slots=True)
class ParamCache:
    """Parameter values as last seen, and the names the autopilot did not answer for (pure)."""

    values: dict[str, float] = field(default_factory=dict)
    missing: set[str] = field(default_factory=set)

    def knows(self, name: str) -> bool:
        return name in self.values or name in self.missing

    def value(self, name: str) -> float | None:
        return self.values.get(name)

    def seen(self, name: str, value: float) -> None:
        """A PARAM_VALUE (or a read's answer): the value now; a non-finite one is unreadable."""
        self.missing.discard(name)
        if math.isfinite(value):
            self.values[name] = value
        else:
            self.values.pop(name, None)

    def answered(self, name: str, value: float | None) -> None:
        """A read's result: the value, or None (no answer: the autopilot lacks it)."""
        if value is None:
            self.values.pop(name, None)
            self.missing.add(name)
        else:
            self.seen(name, value)

    def forget(self) -> None:
        self.values.clear()
        self.missing.clear()


class Param:
    def __init__(self, commands: CommandClient) -> None:
        self._commands = commands
        self.cache: ParamCache | None = None  # kept by a long-lived link (keep_cache)

    def keep_cache(self) -> ParamCache:
        """From now on every value read or sent by the autopilot is kept (and missing
        parameters remembered); :meth:`get` answers from it."""
        if self.cache is None:
            self.cache = ParamCache()
            self._commands.param_seen = self.cache.seen
        return self.cache

    async def get(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> float | None:
        """The value, or None when the autopilot does not answer (no such parameter); from
        the cache when one is kept and knows the name."""
        cache = self.cache
        if cache is not None and cache.knows(name):
            return cache.value(name)
        value = await self._commands.get_param(name, timeout_s, retries)
        if cache is not None:
            cache.answered(name, value)
        return value

    async def set(self, name: str, value: float) -> float:
        """Set and return the value the autopilot confirmed."""
        got = await self._commands.set_param(name, value)
        if self.cache is not None:
            self.cache.seen(name, got)
        return got
