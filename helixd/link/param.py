"""The param plugin (MAVSDK's shape): read and write autopilot parameters by name.

PARAM_REQUEST_READ / PARAM_SET with their answers matched and re-sent by
:class:`helixd.link.command_client.CommandClient`.
"""

from __future__ import annotations

from helixd.link.command_client import CommandClient


class Param:
    def __init__(self, commands: CommandClient) -> None:
        self._commands = commands

    async def get(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> float | None:
        """The value, or None when the autopilot does not answer (no such parameter)."""
        return await self._commands.get_param(name, timeout_s, retries)

    async def set(self, name: str, value: float) -> float:
        """Set and return the value the autopilot confirmed."""
        return await self._commands.set_param(name, value)
