"""RC_CHANNELS_OVERRIDE sink (the default backend).

Each scroll drives one RC channel; the autopilot passes it to a servo output set to
RCIN<n> passthrough. ArduPilot accepts overrides only from ``MAV_GCS_SYSID`` and drops each
channel's override ``RC_OVERRIDE_TIME`` (default 3 s) after its last update — so a dead
helixd hands the scrolls back to the pilot's radio by itself. While healthy, the latest
frame is re-sent at ``repeat_rate_hz`` (≥ 10 Hz) so that timeout never fires; a new
command is sent at once (the repeater only fills the gaps). The repeat is one loop timer,
due one repeat period after the last send: when it fires after a newer send it is moved to
one period after that send, so while commands flow faster than the repeat rate it wakes at
the repeat rate and sends nothing, and a command costs no timer of its own (a sleeping
repeater task woke the loop ~25 times a second at 50 Hz for nothing: +0.3× the pymavlink
floor per step; a timer cancelled and re-armed by every command cost a heap push per step,
tools/bench_control_loop.py).

Channels we do not drive are sent as "leave unchanged" (65535 on 1–8, 0 on 9–18). Stopping
sends neutral, holds it for ``neutral_hold_s`` (if the release is lost, the last override is
neutral and expires), then the release (0 on 1–8, 65534 on 9–18) ``release_repeats`` times.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Sequence
from typing import Protocol

import structlog

from helixd.actuators.base import checked_fractions
from helixd.actuators.mapping import (
    ChannelSink,
    frame_at,
    override_slots,
    release_frame,
)
from helixd.base.clock import now_s
from helixd.config.vehicle import ActuationConfig, VehicleConfig

log = structlog.get_logger(__name__)


class OverrideSender(Protocol):
    def send_rc_override(self, channels_us: Sequence[int]) -> None: ...


class RcOverrideSink(ChannelSink[OverrideSender]):
    def __init__(
        self, actuation: ActuationConfig, vehicle: VehicleConfig, ap: OverrideSender
    ) -> None:
        super().__init__(actuation, vehicle, ap)
        self._slots = override_slots(c.channel for c in self._channels)  # checked once
        self.held_channels: frozenset[int] = frozenset()
        self.frames_sent = 0
        self._frame: tuple[int, ...] | None = None
        self._last_send_s = -math.inf
        self._repeat_s = 1.0 / actuation.repeat_rate_hz
        self._started = False
        self._loop: asyncio.AbstractEventLoop | None = None
        self._timer: asyncio.TimerHandle | None = None

    async def start(self) -> None:
        if self._started:
            return
        self._loop = asyncio.get_running_loop()
        self._started = True
        self._set(self._neutral)
        self.held_channels = frozenset(c.channel for c in self._channels)
        log.info(
            "rc_override_started",
            channels=sorted(self.held_channels),
            repeat_rate_hz=self._cfg.repeat_rate_hz,
        )

    def command(self, fractions: Sequence[float]) -> None:
        f = checked_fractions(fractions, self._clamp)
        if not self._started:
            if self._first_idle():
                log.warning("rc_override_not_started", fractions=f)
            return
        self._set(self._pwm_for(f))

    def _set(self, pwm: tuple[int, int, int, int]) -> None:
        self.last_pwm_us = pwm
        self._frame = frame_at(self._slots, pwm)
        self._send(self._frame)

    def _send(self, frame: tuple[int, ...]) -> None:
        self._ap.send_rc_override(frame)
        self._last_send_s = now_s()
        self.frames_sent += 1
        if self._timer is None and self._started and self._loop is not None:
            self._timer = self._loop.call_later(self._repeat_s, self._refresh)

    def _refresh(self) -> None:
        """The repeat is due: send the latest frame again if nothing was sent for one repeat
        period, else wait until one period after the last send."""
        self._timer = None
        if not self._started or self._frame is None or self._loop is None:
            return
        wait_s = self._last_send_s + self._repeat_s - now_s()
        if wait_s > 0:
            self._timer = self._loop.call_later(wait_s, self._refresh)
        else:
            self._send(self._frame)

    async def stop(self) -> None:
        self._started = False
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        held = self.held_channels
        if not held:
            return
        cfg = self._cfg
        try:
            async with asyncio.timeout(cfg.stop_timeout_s):
                self._set(self._neutral)
                await asyncio.sleep(cfg.neutral_hold_s)
                release = release_frame(held)
                for i in range(cfg.release_repeats):
                    if i:
                        await asyncio.sleep(cfg.release_spacing_s)
                    self._send(release)
            log.info("rc_override_released", channels=sorted(held), repeats=cfg.release_repeats)
        except TimeoutError:
            log.error(
                "rc_override_release_late", channels=sorted(held), timeout_s=cfg.stop_timeout_s
            )
        except Exception:
            log.exception("rc_override_release_failed", channels=sorted(held))
        finally:
            self._frame = None
            self.held_channels = frozenset()

    async def close(self) -> None:
        await self.stop()
