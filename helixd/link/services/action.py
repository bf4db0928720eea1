"""The action plugin (MAVSDK's shape): arm, disarm, flight mode, RC override, servo, and any
COMMAND_LONG — the commands the daemon sends to the autopilot. Acknowledgements, re-sends and
refusal texts are :class:`helixd.link.services.command_client.CommandClient`'s; nothing here
decides to stop the rover.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable, Sequence

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.config.link import LinkConfig
from helixd.link.services.command_client import CommandClient, CommandError, CommandRejected
from helixd.link.telemetry import ChangeWaiters
from helixd.link.vehicle import Change, HomePosition, VehicleState, mode_number
from helixd.link.wire.codec import MavlinkConnection
from helixd.mav.arming import (
    FORCE_ARM_MAGIC,
    K_SCRIPTING1,
    NO_OUTPUTS_TEXT,
    not_neutral_channel,
    rc_reading,
    throttle_must_read,
)
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MISSION_CURRENT,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_REQUEST_MESSAGE,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAVLINK_MSG_ID_HOME_POSITION,
    UINT16_MAX,
)

log = structlog.get_logger(__name__)

RC_OVERRIDE_CHANNELS = 18
ARM_TEXT_PREFIXES = ("PreArm", "Arm")
# "PreArm: " + the text is 51 characters: a receiver that does not join STATUSTEXT chunks
# sees the first 50
STATUSTEXT_FIRST_PIECE = 50 - len("PreArm: ")


class Action:
    def __init__(
        self,
        cfg: LinkConfig,
        state: VehicleState,
        commands: CommandClient,
        waiters: ChangeWaiters,
        conn: MavlinkConnection,
    ) -> None:
        self._cfg = cfg
        self._state = state
        self._waiters = waiters
        self._conn = conn
        # COMMAND_LONG with its retries: the MAV_RESULT (one of ``ok_results``), else
        # CommandRejected / CommandTimeout (:meth:`CommandClient.exchange`)
        self.command_long = commands.exchange

    async def arm(self, force: bool = False) -> None:
        """Arm with every PreArm check. ``force`` (``startup.force_arm``) is the explicit
        exception: still a normal arm first; only when the autopilot refuses it, a forced one
        (param2 21196: ArduPilot then skips *every* PreArm check — GPS, EKF, battery, fence),
        logged as a WARNING naming the PreArm text it overrides."""
        try:
            await self._arm_once(forced=False)
        except CommandRejected as exc:
            if not force:
                raise
            log.warning(
                "arm_forced",
                overrides=exc.statustext or exc.result_name,
                why="startup.force_arm: the autopilot refused a normal arm; forcing it skips "
                "every PreArm check",
            )
            await self._arm_once(forced=True)
            log.info("armed", force=True)
            return
        log.info("armed", force=False)

    async def _arm_once(self, forced: bool) -> None:
        since = now_s()
        try:
            await self.command_long(
                MAV_CMD_COMPONENT_ARM_DISARM, (1, FORCE_ARM_MAGIC if forced else 0)
            )
        except CommandRejected as exc:
            text = await self._arm_text(since) or exc.statustext
            hint = "" if forced else "startup.force_arm forces it"
            if (channel := not_neutral_channel(text)) is not None:
                # the pilot's stick or switch, not a check to skip: what the channel must read
                # (runtime.setup adds RCn_TRIM and RCn_DZ's values)
                reading = rc_reading(self._state.rc_inputs_us, channel)
                hint = throttle_must_read(channel, None, None, reading)
            elif text and NO_OUTPUTS_TEXT[:STATUSTEXT_FIRST_PIECE] in text:  # 1st chunk
                hint = (
                    f"a Helix needs one spare output with SERVOn_FUNCTION = {K_SCRIPTING1} "
                    "(Script1) to arm normally: `helixd autopilot check` names it"
                )
            raise CommandRejected(exc.command_name, exc.result, text, hint) from None

    async def refusal_text(self, since_s: float, prefix: str = "") -> str | None:
        """The STATUSTEXT (starting with ``prefix``) that explains a refusal, read after
        ``since_s``. ArduPilot queues such texts (GCS::send_text) and sends them after the
        COMMAND_ACK, so one may trail the ack by a scheduler tick: waits at most
        ``link.statustext_grace_s``."""
        deadline = now_s() + self._cfg.statustext_grace_s
        while True:
            text = self._state.latest_statustext(prefix, since_s)
            if text:
                return text
            if not await self._waiters.wait(Change.STATUSTEXT, deadline - now_s()):
                return None

    async def _arm_text(self, since_s: float) -> str | None:
        """The 'PreArm: …' STATUSTEXT explaining a refusal (it may trail the ack a little)."""
        deadline = now_s() + self._cfg.statustext_grace_s
        while True:
            for prefix in ARM_TEXT_PREFIXES:
                text = self._state.latest_statustext(prefix, since_s)
                if text:
                    return text
            if not await self._waiters.wait(Change.STATUSTEXT, deadline - now_s()):
                return None

    async def disarm(
        self, force: bool = False, timeout_s: float | None = None, retries: int | None = None
    ) -> None:
        await self.command_long(
            MAV_CMD_COMPONENT_ARM_DISARM, (0, FORCE_ARM_MAGIC if force else 0), timeout_s, retries
        )
        self._state.disarm_acked_s = now_s()
        log.info("disarmed", force=force)

    async def set_mode(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> None:
        """MAV_CMD_DO_SET_MODE with a Rover custom mode by name (ValueError if unknown).

        ``timeout_s``/``retries`` override the link's per-try timeout and re-sends (a caller
        with a deadline, e.g. the fall-back's HOLD request, can keep each call short).
        """
        number = mode_number(name)
        await self.command_long(
            MAV_CMD_DO_SET_MODE, (MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, number), timeout_s, retries
        )
        log.info("mode_set", mode=name.upper(), custom_mode=number)

    async def set_mission_current(self, seq: int) -> None:
        """MAV_CMD_DO_SET_MISSION_CURRENT (param1 ``seq``, param2 0: no reset): make ``seq``
        the autopilot's current mission item (ValueError outside 0..65535).

        ArduPilot (handle_command_do_set_mission_current, AP_Mission::set_current_cmd) moves
        its current item to the first NAV command at or after ``seq`` (0 means 1) and answers
        DENIED for an index past the end, FAILED when no NAV command follows: both raise
        :class:`CommandRejected`. The item it chose arrives as MISSION_CURRENT
        (``VehicleState.mission_current``, :attr:`Change.MISSION_CURRENT`).
        """
        if isinstance(seq, bool) or not isinstance(seq, int) or not 0 <= seq <= UINT16_MAX:
            raise ValueError(f"mission item must be an integer 0..{UINT16_MAX}, got {seq!r}")
        await self.command_long(MAV_CMD_DO_SET_MISSION_CURRENT, (seq, 0))
        log.info("mission_current_set", seq=seq)

    async def request_gps_origin(self, timeout_s: float) -> tuple[float, float] | None:
        """(lat_deg, lon_deg) of the EKF origin via MAV_CMD_REQUEST_MESSAGE; None if none."""
        msg_id = int(mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN)

        def rx_s(st: VehicleState) -> float | None:
            return st.gps_origin_rx_s

        got = await self._requested(msg_id, Change.GPS_ORIGIN, rx_s, timeout_s, "gps_origin")
        return None if got is None else self._state.gps_origin

    async def request_home(self, timeout_s: float) -> HomePosition | None:
        """The autopilot's home (HOME_POSITION) via MAV_CMD_REQUEST_MESSAGE, fresher than the
        request; None if it sent none in time (ArduPilot refuses while home is not set)."""

        def rx_s(st: VehicleState) -> float | None:
            return st.home_rx_s

        msg_id = MAVLINK_MSG_ID_HOME_POSITION
        got = await self._requested(msg_id, Change.HOME, rx_s, timeout_s, "home_position")
        return None if got is None else self._state.home

    async def _requested(
        self,
        msg_id: int,
        change: int,
        rx_of: Callable[[VehicleState], float | None],
        timeout_s: float,
        what: str,
    ) -> float | None:
        """Ask for message ``msg_id`` (MAV_CMD_REQUEST_MESSAGE) and wait for one received after
        the request (``change`` of the vehicle state; ``rx_of``: when the last arrived): when
        it arrived, None if none came in time (logged ``{what}_unavailable``)."""
        since = now_s()
        try:
            async with asyncio.timeout(timeout_s):
                await self.command_long(MAV_CMD_REQUEST_MESSAGE, (msg_id,))
                while (rx_s := rx_of(self._state)) is None or rx_s < since:
                    await self._waiters.wait(change, timeout_s)
                return rx_s
        except (TimeoutError, CommandError) as exc:
            log.warning(f"{what}_unavailable", error=str(exc) or "timeout")
            return None

    def send_rc_override(self, channels_us: Sequence[int]) -> None:
        """RC_CHANNELS_OVERRIDE with 18 raw values (0/65535/65534 semantics are the caller's)."""
        if len(channels_us) != RC_OVERRIDE_CHANNELS:
            raise ValueError(
                f"RC override needs {RC_OVERRIDE_CHANNELS} values, got {len(channels_us)}"
            )
        values = tuple(map(int, channels_us))
        if min(values) < 0 or max(values) > UINT16_MAX:
            raise ValueError(f"RC override values must be 0..{UINT16_MAX}, got {list(values)}")
        self._conn.send_rc_override(self._cfg.target_system, self._cfg.target_component, values)
