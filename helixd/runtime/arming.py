"""The pilot's start gate, the autopilot's home, arming and the confirmations that a mode change
or an arm happened (a HEARTBEAT asked for until it shows them). A stop signal ends any wait
(:func:`helixd.runtime.setup.until_stopped`); a refusal is
:class:`helixd.runtime.setup.PreflightFailed`.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable

import structlog

from helixd.base.clock import now_s
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandError, CommandRejected
from helixd.link.vehicle import Change, VehicleState
from helixd.mav.arming import not_neutral_channel, rc_reading, throttle_must_read
from helixd.mav.constants import MAV_CMD_REQUEST_MESSAGE, MAVLINK_MSG_ID_HOME_POSITION
from helixd.report.notify import ServiceNotifier
from helixd.runtime.setup import (
    Held,
    PreflightFailed,
    until_stopped,
)
from helixd.runtime.signals import StopRequest

log = structlog.get_logger(__name__)
# how often a confirmation asks the autopilot for a HEARTBEAT (s): a few of its control
# periods, so an answer built before the change took effect is followed by one after it
HEARTBEAT_ASK_S = 0.1


async def start_gate(
    ap: Autopilot, cfg: HelixdConfig, stop: StopRequest, notifier: ServiceNotifier
) -> None:
    """Wait for the pilot's start switch (``startup.start_switch_channel``), if there is one."""
    ch = cfg.startup.start_switch_channel
    if ch is None:
        return
    threshold = cfg.startup.start_switch_threshold_us
    log.info("waiting_for_start_switch", channel=ch, threshold_us=threshold)
    notifier.status(f"waiting for the pilot: RC{ch} >= {threshold} us")
    deadline = now_s() + cfg.startup.start_gate_timeout_s
    while now_s() < deadline:
        ap.feed()
        notifier.watchdog()
        rc = ap.state.rc_inputs_us
        if len(rc) >= ch and rc[ch - 1] >= threshold:
            log.info("start_switch_on", channel=ch, pwm_us=rc[ch - 1])
            return
        await until_stopped(stop, ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.2))
    raise PreflightFailed(
        [f"start switch RC{ch} not flipped within {cfg.startup.start_gate_timeout_s} s"]
    )


async def wait_home(
    ap: Autopilot, cfg: HelixdConfig, on_status: Callable[[str], None]
) -> str | None:
    """Wait for the autopilot's home before arming, instead of forcing the arm; returns a
    warning when arming is forced without one.

    ArduPilot Rover sets home from the EKF's first position (``Rover::ahrs_update``),
    sends HOME_POSITION when it does, and until then refuses to arm ("PreArm: AHRS:
    waiting for home"). HOME_POSITION is asked for every ``startup.arm_retry_interval_s``
    (ArduPilot answers only once home is set) for at most ``startup.home_timeout_s``; then
    the run is refused (exit 3, nothing armed), or with ``startup.force_arm`` armed anyway.
    """
    startup = cfg.startup
    deadline = now_s() + startup.home_timeout_s
    waiting = False
    while ap.state.home is None:
        remaining = deadline - now_s()
        if remaining <= 0.0:
            text = (
                f"the autopilot reported no home (HOME_POSITION) within "
                f"startup.home_timeout_s = {startup.home_timeout_s:g} s; ArduPilot arms only "
                "once its EKF has a position (GPS fix, EKF origin)"
            )
            if not startup.force_arm:
                raise PreflightFailed([text])
            log.warning("home_unknown_forcing", problem=text)
            return f"{text}; arming forced (startup.force_arm)"
        if not waiting:
            waiting = True
            log.info("waiting_for_home", timeout_s=startup.home_timeout_s)
            on_status("arm (waiting for the autopilot's home)")
        try:
            await ap.action.command_long(MAV_CMD_REQUEST_MESSAGE, (MAVLINK_MSG_ID_HOME_POSITION,))
        except CommandError as exc:  # it also sends HOME_POSITION by itself once set
            log.info("home_request_failed", error=str(exc))
        await ap.telemetry.wait_for(
            lambda st: st.home is not None,
            Change.HOME,
            min(remaining, startup.arm_retry_interval_s),
        )
    home = ap.state.home
    if home is not None:
        log.info(
            "home_known",
            lat_deg=round(home.lat_deg, 7),
            lon_deg=round(home.lon_deg, 7),
            waited=waiting,
        )
    return None


async def explain_arm_refusal(ap: Autopilot, exc: CommandRejected) -> CommandRejected:
    """An "Arm: Throttle (RCn) is not neutral" refusal names what RCn must read (its
    RCn_TRIM ± RCn_DZ, read now) and what it reads; any other refusal as it came."""
    channel = not_neutral_channel(exc.statustext)
    if channel is None:
        return exc
    trim, dz = await asyncio.gather(
        ap.param.get(f"RC{channel}_TRIM"), ap.param.get(f"RC{channel}_DZ")
    )
    reading = rc_reading(ap.state.rc_inputs_us, channel)
    hint = throttle_must_read(channel, trim, dz, reading)
    return CommandRejected(exc.command_name, exc.result, exc.statustext, hint)


async def arm(
    ap: Autopilot, cfg: HelixdConfig, held: Held, on_status: Callable[[str], None]
) -> str | None:
    """Arm once the autopilot has a home, re-trying while PreArm checks refuse; returns the
    warning of an arm forced without a home."""
    if ap.state.armed_now:
        return None
    warning = await wait_home(ap, cfg, on_status)
    startup = cfg.startup
    deadline = now_s() + startup.arm_timeout_s
    while True:
        try:
            await ap.action.arm(force=startup.force_arm)
            held.armed_by_us = True
            await confirm_armed(ap, cfg)
            return warning
        except CommandRejected as refused:
            exc = await explain_arm_refusal(ap, refused)
            if now_s() + startup.arm_retry_interval_s > deadline:
                raise exc from None
            log.warning(
                "arm_refused_retrying", reason=str(exc), retry_in_s=startup.arm_retry_interval_s
            )
            on_status(f"arm (autopilot says: {exc.statustext or exc.result_name})")
            await asyncio.sleep(startup.arm_retry_interval_s)


async def confirm_mode(ap: Autopilot, cfg: HelixdConfig, mode: str) -> None:
    """The ACK says 'accepted'; the HEARTBEAT's mode says it happened. Without this wait
    a vehicle still armed in HOLD (left by a faulted run) would show its last HOLD
    heartbeat to the flight loop, which reads it as a pilot takeover."""
    await heartbeat_shows(
        ap,
        cfg,
        lambda st: st.mode == mode,
        lambda st: f"mode {mode} was accepted but HEARTBEAT still shows {st.mode}",
    )


async def confirm_armed(ap: Autopilot, cfg: HelixdConfig) -> None:
    """The ACK says 'accepted'; the HEARTBEAT's armed flag says it happened."""
    await heartbeat_shows(
        ap,
        cfg,
        lambda st: st.armed_now,
        lambda _: "arming was accepted but HEARTBEAT never showed armed",
    )


async def heartbeat_shows(
    ap: Autopilot,
    cfg: HelixdConfig,
    holds: Callable[[VehicleState], bool],
    refusal: Callable[[VehicleState], str],
) -> None:
    """Until a HEARTBEAT shows what was just acknowledged, asked for every
    :data:`HEARTBEAT_ASK_S` (the autopilot's own come at 1 Hz: a start would wait up to a
    second for one); PreflightFailed with ``refusal`` after two HEARTBEAT timeouts."""
    deadline = now_s() + cfg.safety.heartbeat_timeout_s * 2
    asked_s = -math.inf
    while not holds(ap.state):
        now = now_s()
        if now > deadline:
            raise PreflightFailed([refusal(ap.state)])
        if now - asked_s >= HEARTBEAT_ASK_S:
            ap.request_heartbeat()
            asked_s = now
        await ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.05)
