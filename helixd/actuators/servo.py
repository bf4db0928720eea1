"""MAV_CMD_DO_SET_SERVO sink. READ THIS BEFORE USING IT.

DO_SET_SERVO outputs are LATCHED in ArduPilot: there is no timeout. If helixd is killed
(SIGKILL, power loss of the companion, a hung process, a cut cable), every scroll output stays
at the last value it was given — the rover keeps driving — until something else commands that
output: helixd's next start (which sends neutral to every mapped channel first), a GCS, or a
reboot of the autopilot. Neither HOLD nor disarm stops these outputs (DESIGN §3). helixd sends
neutral at start and at stop, but it cannot do so once dead. The pilot must keep a hardware
means to cut the scroll motors (motor-controller kill switch / E-stop) within reach, and should
prefer the ``rc_override`` backend, whose overrides expire after RC_OVERRIDE_TIME.

ArduPilot only accepts DO_SET_SERVO on an output whose SERVOn_FUNCTION is 0, 1, 22, 23 or
51–66; anything else is refused (FAILED). A refusal is surfaced as
:class:`helixd.actuators.base.ServoCommandRefused`: raised from ``start()``, and kept in
``fault`` and raised from the next ``command()`` when it happens while driving.

Sending policy: on change, coalesced. Each DO_SET_SERVO is an acknowledged COMMAND_LONG and a
latched value needs no refresh, so re-sending every tick would only load the link (4 channels
× 40 Hz × 45 bytes is more than a 57600-baud telemetry radio carries) and ArduPilot's command
queue. A sender task sends, channel by channel, the *latest* desired PWM of every channel whose
acknowledged value differs; intermediate values are skipped, so the rate is bounded by the
acknowledgement round trip.
"""

from __future__ import annotations

import asyncio
from collections.abc import Sequence
from typing import Protocol

import structlog

from helixd.actuators.base import ServoCommandRefused, checked_fractions
from helixd.actuators.mapping import fraction_to_pwm, neutral_pwm
from helixd.config import ActuationConfig, VehicleConfig
from helixd.link.commands import CommandRejected, CommandTimeout
from helixd.mav.constants import MAV_CMD_DO_SET_SERVO

log = structlog.get_logger(__name__)


class CommandSender(Protocol):
    async def command_long(
        self,
        command: int,
        params: Sequence[float],
        timeout_s: float | None = ...,
        retries: int | None = ...,
    ) -> int: ...


def _four(values: Sequence[int]) -> tuple[int, int, int, int]:
    return (values[0], values[1], values[2], values[3])


class ServoSink:
    def __init__(
        self, actuation: ActuationConfig, vehicle: VehicleConfig, ap: CommandSender
    ) -> None:
        self._cfg = actuation
        self._clamp = vehicle.output_clamp
        self._ap = ap
        self._channels = tuple(actuation.channels)
        self._neutral = _four([neutral_pwm(c) for c in self._channels])
        self._desired: list[int] = list(self._neutral)
        self._acked: list[int | None] = [None] * len(self._channels)
        self.last_pwm_us: tuple[int, int, int, int] = self._neutral
        self.fault: ServoCommandRefused | None = None
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None
        self._warned_idle = False

    @property
    def held_channels(self) -> frozenset[int]:
        """Channels latched (or possibly latched) away from neutral by us."""
        return frozenset(
            ch.channel
            for ch, acked, sent, neutral in zip(
                self._channels, self._acked, self.last_pwm_us, self._neutral, strict=True
            )
            if acked != neutral or sent != neutral
        )

    async def start(self) -> None:
        """Neutral on every mapped channel FIRST (a killed run may have left them latched)."""
        if self._task is not None:
            return
        self.fault = None
        for i in range(len(self._channels)):
            await self._set_one(i, self._neutral[i])
        self._desired = list(self._neutral)
        self._task = asyncio.get_running_loop().create_task(self._sender(), name="servo_sender")
        log.info("servo_sink_started", channels=[c.channel for c in self._channels])

    def command(self, fractions: Sequence[float]) -> None:
        if self.fault is not None:
            raise self.fault
        f = checked_fractions(fractions, self._clamp)
        if self._task is None:
            if not self._warned_idle:
                log.warning("servo_sink_not_started", fractions=f)
                self._warned_idle = True
            return
        self._desired = [fraction_to_pwm(x, ch) for x, ch in zip(f, self._channels, strict=True)]
        self._wake.set()

    async def _set_one(self, i: int, pwm_us: int) -> None:
        channel = self._channels[i].channel
        pwm = list(self.last_pwm_us)
        pwm[i] = pwm_us
        self.last_pwm_us = _four(pwm)
        self._acked[i] = None  # unknown until acknowledged
        try:
            await self._ap.command_long(MAV_CMD_DO_SET_SERVO, (channel, pwm_us))
        except CommandRejected as exc:
            raise ServoCommandRefused(channel, pwm_us, exc) from None
        self._acked[i] = pwm_us

    async def _sender(self) -> None:
        while True:
            await self._wake.wait()
            self._wake.clear()
            for i, want in enumerate(self._desired):
                if want == self._acked[i]:
                    continue
                try:
                    await self._set_one(i, want)
                except ServoCommandRefused as exc:
                    self.fault = exc
                    log.error(
                        "servo_refused",
                        channel=exc.channel,
                        pwm_us=exc.pwm_us,
                        result=exc.result_name,
                        statustext=exc.statustext,
                    )
                    return
                except CommandTimeout as exc:
                    log.warning(
                        "servo_command_timeout", channel=self._channels[i].channel, error=str(exc)
                    )
                    self._wake.set()  # try again with whatever is desired by then

    async def stop(self) -> None:
        """Neutral on every channel, acknowledged, within ``stop_timeout_s``; never raises."""
        task, self._task = self._task, None
        if task is not None:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
        self._desired = list(self._neutral)
        pending = [i for i in range(len(self._channels)) if self._acked[i] != self._neutral[i]]
        if not pending:
            return
        failed: list[int] = []
        try:
            async with asyncio.timeout(self._cfg.stop_timeout_s):
                for i in pending:
                    try:
                        await self._set_one(i, self._neutral[i])
                    except (CommandRejected, CommandTimeout) as exc:
                        failed.append(self._channels[i].channel)
                        log.error(
                            "servo_neutral_failed",
                            channel=self._channels[i].channel,
                            error=str(exc),
                        )
        except TimeoutError:
            log.error(
                "servo_neutral_unconfirmed",
                timeout_s=self._cfg.stop_timeout_s,
                channels=sorted(self.held_channels),
            )
            return
        if not failed:
            log.info("servo_neutral", channels=[self._channels[i].channel for i in pending])

    async def close(self) -> None:
        await self.stop()
