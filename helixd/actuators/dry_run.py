"""Dry-run sink: computes the PWM exactly like the real backends and only logs it."""

from __future__ import annotations

from collections.abc import Sequence

import structlog

from helixd.actuators.base import checked_fractions
from helixd.actuators.mapping import fraction_to_pwm, neutral_pwm
from helixd.config.vehicle import ActuationConfig, VehicleConfig

log = structlog.get_logger(__name__)


class DryRunSink:
    def __init__(self, actuation: ActuationConfig, vehicle: VehicleConfig) -> None:
        self._clamp = vehicle.output_clamp
        self._channels = tuple(actuation.channels)
        self._backend = actuation.backend.value
        n = [neutral_pwm(c) for c in self._channels]
        self._neutral: tuple[int, int, int, int] = (n[0], n[1], n[2], n[3])
        self.last_pwm_us: tuple[int, int, int, int] = self._neutral
        self.held_channels: frozenset[int] = frozenset()  # nothing is ever sent
        self.commands = 0
        self._started = False

    def _channel_map(self, pwm: Sequence[int]) -> dict[str, int]:
        return {f"ch{c.channel}": p for c, p in zip(self._channels, pwm, strict=True)}

    async def start(self) -> None:
        self._started = True
        self.last_pwm_us = self._neutral
        log.info("dry_run_start", would_send=self._channel_map(self._neutral))

    def command(self, fractions: Sequence[float]) -> None:
        f = checked_fractions(fractions, self._clamp)
        pwm = [fraction_to_pwm(x, ch) for x, ch in zip(f, self._channels, strict=True)]
        new = (pwm[0], pwm[1], pwm[2], pwm[3])
        self.commands += 1
        if new != self.last_pwm_us:
            log.info("dry_run_command", would_send=self._channel_map(new), fractions=f)
        self.last_pwm_us = new

    async def stop(self) -> None:
        if self._started:
            log.info(
                "dry_run_stop",
                would_send=self._channel_map(self._neutral),
                then="release" if self._backend != "servo" else "stay at neutral",
            )
        self._started = False
        self.last_pwm_us = self._neutral

    async def close(self) -> None:
        await self.stop()
