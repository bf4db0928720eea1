"""MAV_CMD_DO_SET_SERVO sink. READ THIS BEFORE USING IT.

DO_SET_SERVO outputs are LATCHED in ArduPilot: there is no timeout. If helixd is killed
(SIGKILL, power loss of the companion, a hung process, a cut cable), every scroll output stays
at the last value it was given — the rover keeps driving — until something else commands that
output. Neither HOLD nor disarm stops these outputs (docs/ardupilot.md). helixd sends neutral at
start and at stop, but it cannot do so once dead. That something else is helixd-guard, the Lua
dead-man switch on the autopilot (``helixd autopilot install-guard``; preflight refuses this
backend without it unless ``safety.servo_guard: warn``): it holds the outputs at trim and asks
for HOLD when helixd's HEARTBEATs stop for HXG_TIMEOUT (0.5 s). Keep a hardware means to cut
the scroll motors (motor-controller kill switch / E-stop) within reach all the same.

ArduPilot only accepts DO_SET_SERVO on an output whose SERVOn_FUNCTION is 0, 1, 22, 23 or
51–66; anything else is refused (FAILED). A refusal is surfaced as
:class:`helixd.actuators.base.ServoCommandRefused`: raised from ``start()``, and kept in
``fault`` and raised from the next ``command()`` when it happens while driving.

Sending policy: on change, coalesced, and refreshed. Each DO_SET_SERVO is an acknowledged
COMMAND_LONG, so re-sending every tick would only load the link (4 channels × 40 Hz × 45 bytes
is more than a 57600-baud telemetry radio carries) and ArduPilot's command queue. A sender task
sends, channel by channel, the *latest* desired PWM of every channel whose acknowledged value
differs; intermediate values are skipped, so the rate is bounded by the acknowledgement round
trip. An ACK is no proof that the value is on the output, though: while helixd-guard holds an
output (``set_output_pwm_chan_timeout``) a DO_SET_SERVO is ACCEPTED and dropped, and the output
keeps the guard's trim afterwards. So every channel is sent again once its last send is
``actuation.servo_refresh_s`` (1 s) old, even when unchanged.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Sequence
from typing import Protocol

import structlog

from helixd.actuators.base import ServoCommandRefused, checked_fractions
from helixd.actuators.mapping import ChannelSink
from helixd.base.clock import now_s
from helixd.config.vehicle import ActuationConfig, VehicleConfig
from helixd.link.services.command_client import CommandRejected, CommandTimeout
from helixd.mav.constants import MAV_CMD_DO_SET_SERVO

log = structlog.get_logger(__name__)

SERVO_REFUSAL_TEXT_PREFIX = "ServoRelayEvent"  # ArduPilot's ServoRelayEvents::do_set_servo


class ServoCommandSender(Protocol):
    async def command_long(
        self,
        command: int,
        params: Sequence[float],
        timeout_s: float | None = ...,
        retries: int | None = ...,
    ) -> int: ...

    async def refusal_text(self, since_s: float, prefix: str = ...) -> str | None: ...


def _four(values: Sequence[int]) -> tuple[int, int, int, int]:
    return (values[0], values[1], values[2], values[3])


class ServoSink(ChannelSink[ServoCommandSender]):
    def __init__(
        self, actuation: ActuationConfig, vehicle: VehicleConfig, ap: ServoCommandSender
    ) -> None:
        super().__init__(actuation, vehicle, ap)
        self._desired: list[int] = list(self._neutral)
        self._acked: list[int | None] = [None] * len(self._channels)
        self._sent_s: list[float] = [-float("inf")] * len(self._channels)  # monotonic
        self.fault: ServoCommandRefused | None = None
        self._wake = asyncio.Event()
        self._task: asyncio.Task[None] | None = None

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
            since_s = now_s()
            try:
                await self._set_one(i, self._neutral[i])
            except ServoCommandRefused as exc:
                if exc.statustext:
                    raise
                # preflight, not the flight: worth a moment for ArduPilot's explanation
                # ("ServoRelayEvent: Channel N is already in use"), sent after its ACK
                text = await self._ap.refusal_text(since_s, SERVO_REFUSAL_TEXT_PREFIX)
                if text is None:
                    raise
                raise ServoCommandRefused(
                    exc.channel,
                    exc.pwm_us,
                    CommandRejected(exc.command_name, exc.result, text),
                ) from None
        self._desired = list(self._neutral)
        self._task = asyncio.get_running_loop().create_task(self._sender(), name="servo_sender")
        log.info("servo_sink_started", channels=[c.channel for c in self._channels])

    def command(self, fractions: Sequence[float]) -> None:
        if self.fault is not None:
            raise self.fault
        f = checked_fractions(fractions, self._clamp)
        if self._task is None:
            if self._first_idle():
                log.warning("servo_sink_not_started", fractions=f)
            return
        self._desired = list(self._pwm_for(f))
        self._wake.set()

    async def _set_one(self, i: int, pwm_us: int) -> None:
        channel = self._channels[i].channel
        pwm = list(self.last_pwm_us)
        pwm[i] = pwm_us
        self.last_pwm_us = _four(pwm)
        self._acked[i] = None  # unknown until acknowledged
        self._sent_s[i] = now_s()
        try:
            await self._ap.command_long(MAV_CMD_DO_SET_SERVO, (channel, pwm_us))
        except CommandRejected as exc:
            raise ServoCommandRefused(channel, pwm_us, exc) from None
        self._acked[i] = pwm_us

    def _due(self, i: int, now_s: float) -> bool:
        """Channel ``i`` needs a DO_SET_SERVO: changed, or its last one is refresh-old."""
        return (
            self._desired[i] != self._acked[i]
            or now_s - self._sent_s[i] >= self._cfg.servo_refresh_s
        )

    async def _wait_for_work(self) -> None:
        """Until a new command arrives or the oldest send is due for its refresh."""
        next_refresh_s = min(self._sent_s) + self._cfg.servo_refresh_s
        wait_s = next_refresh_s - now_s()
        if wait_s > 0:
            with contextlib.suppress(TimeoutError):
                async with asyncio.timeout(wait_s):
                    await self._wake.wait()
        self._wake.clear()

    async def _sender(self) -> None:
        while True:
            await self._wait_for_work()
            for i in range(len(self._channels)):
                if not self._due(i, now_s()):
                    continue
                want = self._desired[i]
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
