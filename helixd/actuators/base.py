"""The actuator sink interface: four scroll fractions in, PWM out on some channels.

Every backend (RC override, DO_SET_SERVO, dry run) implements :class:`ActuatorSink`:

* ``start()`` — take control (servo: neutral on every mapped channel first; rc: repeater on);
* ``command(fractions)`` — the latest four calibrated fractions in [-1, 1]; never blocks;
* ``stop()`` — neutral on every scroll channel, then release whatever we hold; bounded in
  time (``actuation.stop_timeout_s``), idempotent, never raises on a dead link (it logs);
* ``close()`` — stop() if needed, then free resources.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol, runtime_checkable

from helixd.link.services.command_client import CommandRejected

SCROLLS = 4


@runtime_checkable
class ActuatorSink(Protocol):
    @property
    def last_pwm_us(self) -> tuple[int, int, int, int]:
        """PWM (µs) last sent (or, for dry run, that would have been sent) per scroll 1..4."""
        ...

    @property
    def held_channels(self) -> frozenset[int]:
        """Channels currently overridden / latched away from neutral by us."""
        ...

    async def start(self) -> None: ...

    def command(self, fractions: Sequence[float]) -> None: ...

    async def stop(self) -> None: ...

    async def close(self) -> None: ...


class ActuatorError(Exception):
    """An actuator backend cannot do what it was asked."""


class ServoCommandRefused(CommandRejected, ActuatorError):
    """ArduPilot refused MAV_CMD_DO_SET_SERVO on a channel (SERVOn_FUNCTION not 0/1/22/23/51–66).

    A :class:`helixd.link.services.command_client.CommandError`, so the daemon treats it like any
    refusal.
    """

    def __init__(self, channel: int, pwm_us: int, refused: CommandRejected) -> None:
        self.channel = channel
        self.pwm_us = pwm_us
        super().__init__(
            refused.command_name,
            refused.result,
            refused.statustext,
            detail=(
                f"servo channel {channel} to {pwm_us} us; ArduPilot only accepts DO_SET_SERVO "
                f"when SERVO{channel}_FUNCTION is 0, 1, 22, 23 or 51..66"
            ),
        )


def checked_fractions(fractions: Sequence[float], clamp: float) -> tuple[float, ...]:
    """Exactly four fractions, non-finite → 0, limited to ±``clamp`` (last line of defence)."""
    if len(fractions) != SCROLLS:
        raise ValueError(f"expected {SCROLLS} scroll fractions, got {len(fractions)}")
    out = []
    for f in fractions:  # a plain loop: no generator frame at the control rate
        x = float(f)
        out.append(max(-clamp, min(clamp, x)) if math.isfinite(x) else 0.0)
    return tuple(out)
