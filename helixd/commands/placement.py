"""Placing a ``local_ned``/``start`` mission on the Earth through what the autopilot knows:
its EKF origin (GPS_GLOBAL_ORIGIN) and, for a ``start`` mission, the rover's pose now — for
``helixd mission upload`` of a mission without lat/lon (:mod:`helixd.mission.placed`)."""

from __future__ import annotations

import contextlib

from helixd.base.clock import now_s
from helixd.base.plan import MissionFrameKind
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandError
from helixd.mav.constants import (
    MAV_CMD_REQUEST_MESSAGE,
    MAVLINK_MSG_ID_ATTITUDE,
    MAVLINK_MSG_ID_LOCAL_POSITION_NED,
)
from helixd.mission.formats.items import mission_to_items
from helixd.mission.formats.wire import WireMission, gcs_to_wire
from helixd.mission.model import Mission
from helixd.mission.placed import PlacementError, placed_globally


async def place_on_autopilot(ap: Autopilot, mission: Mission, timeout_s: float) -> WireMission:
    """``mission`` in lat/lon through the autopilot's EKF origin (a ``start`` mission at the
    rover's pose now), as the mission protocol sends it. Raises :class:`PlacementError`."""
    origin = await ap.action.request_gps_origin(timeout_s)
    if origin is None:
        raise PlacementError(
            f"{mission.name!r} is in the '{mission.frame.value}' frame and the autopilot reported "
            "no EKF origin (GPS_GLOBAL_ORIGIN): give it with --origin LAT,LON"
        )
    start = None
    if mission.frame is MissionFrameKind.START:
        asked_s = now_s()  # a pose read after this answers (it may beat the wait)
        for msg_id in (MAVLINK_MSG_ID_ATTITUDE, MAVLINK_MSG_ID_LOCAL_POSITION_NED):
            with contextlib.suppress(CommandError):  # streamed anyway on most links
                await ap.action.command_long(MAV_CMD_REQUEST_MESSAGE, (msg_id,))
        sample = await ap.telemetry.next_pose(after_rx_s=asked_s, timeout_s=timeout_s)
        if sample is None:
            raise PlacementError(
                f"{mission.name!r} is in the 'start' frame and the autopilot sent no pose to "
                "place it at: give --origin LAT,LON and --start-heading-deg"
            )
        start = sample.ned
    return gcs_to_wire(mission_to_items(placed_globally(mission, origin, start)))


__all__ = ["place_on_autopilot"]
