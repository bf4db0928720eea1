"""Our HEARTBEAT, sent only while the daemon's loop feeds it (a hung daemon goes silent, and
ArduPilot's GCS failsafe notices)."""

from __future__ import annotations

import asyncio

import structlog
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.config.link import LinkConfig
from helixd.link.wire.codec import MavlinkConnection

log = structlog.get_logger(__name__)


def heartbeat_due(last_feed_s: float | None, now_s: float, liveness_s: float) -> bool:
    """Send a HEARTBEAT only while the daemon's loop has fed us within ``liveness_s``."""
    return last_feed_s is not None and now_s - last_feed_s <= liveness_s


class HeartbeatSender:
    """Our HEARTBEAT at ``heartbeat_rate_hz``, withheld as soon as ``feed()`` stops.

    MAV_TYPE_GCS by default: we hold the GCS system id (MAV_GCS_SYSID) and its privileges
    (RC overrides), and ArduPilot's GCS failsafe counts heartbeats by *sysid only*
    (GCS_MAVLINK::handle_heartbeat), so the type buys nothing there either way; GCS tells
    QGroundControl/MAVProxy on the same network what we are instead of looking like a
    second vehicle component. ``link.heartbeat_type: onboard_controller`` is available.
    """

    def __init__(self, conn: MavlinkConnection, cfg: LinkConfig) -> None:
        self._conn = conn
        self._cfg = cfg
        self.last_feed_s: float | None = None
        self.sent = 0
        self._task: asyncio.Task[None] | None = None
        self._type = (
            int(mavlink.MAV_TYPE_GCS)
            if cfg.heartbeat_type == "gcs"
            else int(mavlink.MAV_TYPE_ONBOARD_CONTROLLER)
        )

    @property
    def running(self) -> bool:
        return self._task is not None and not self._task.done()

    def feed(self) -> None:
        self.last_feed_s = now_s()

    def start(self) -> None:
        self.feed()
        if not self.running:
            self._task = asyncio.get_running_loop().create_task(self._run())

    def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            self._task = None
            log.info("heartbeat_stopped", sent=self.sent)

    def send_now(self) -> None:
        msg = self._conn.mav.heartbeat_encode(
            self._type, int(mavlink.MAV_AUTOPILOT_INVALID), 0, 0, int(mavlink.MAV_STATE_ACTIVE)
        )
        if self._conn.send(msg):
            self.sent += 1
        if self._cfg.vehicle_component:
            # our component of the vehicle: ArduPilot learns the route (MAVLink_routing::
            # learn_route) and forwards what a ground station addresses to it
            self._conn.send_as_vehicle(
                self._conn.vehicle_mav.heartbeat_encode(
                    int(mavlink.MAV_TYPE_ONBOARD_CONTROLLER),
                    int(mavlink.MAV_AUTOPILOT_INVALID),
                    0,
                    0,
                    int(mavlink.MAV_STATE_ACTIVE),
                )
            )

    async def _run(self) -> None:
        period_s = 1.0 / self._cfg.heartbeat_rate_hz
        withheld = False
        while True:
            now = now_s()
            if heartbeat_due(self.last_feed_s, now, self._cfg.heartbeat_liveness_s):
                self.send_now()
                if withheld:
                    log.info("heartbeat_resumed")
                    withheld = False
            elif not withheld:
                withheld = True
                since = None if self.last_feed_s is None else round(now - self.last_feed_s, 2)
                log.warning(
                    "heartbeat_withheld",
                    since_feed_s=since,
                    liveness_s=self._cfg.heartbeat_liveness_s,
                )
            await asyncio.sleep(period_s)
