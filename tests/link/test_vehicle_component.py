"""helixd is also a component of the vehicle's system (``link.vehicle_component``): a second
HEARTBEAT from (the autopilot's system, our component) lets ArduPilot route to helixd the
commands a ground station addresses to that component of the vehicle (QGroundControl's
MAVLink Actions); those commands are heard, the autopilot's own are not."""

from __future__ import annotations

import time
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.support.peer import HELIXD_SYSID, AutopilotPeer, linked, stays, until

ONBOARD = mavlink.MAV_TYPE_ONBOARD_CONTROLLER


def beats_from(peer: AutopilotPeer, sysid: int) -> list[tuple[float, int, int]]:
    return [h for h in list(peer.records.gcs_heartbeats) if h[1] == sysid]


def change_speed_to(system: int, component: int) -> Any:
    def build(c: Any) -> Any:
        return c.command_long_encode(system, component, 178, 0, 1, 0.3, -1, 0, 0, 0, 0)

    return build


async def test_a_second_heartbeat_as_a_component_of_the_vehicle() -> None:
    async with linked(heartbeat_rate_hz=10.0) as (ap, peer):
        ap.start_heartbeat()
        await until(lambda: len(beats_from(peer, 1)) >= 2, 2.0, "vehicle-component beats")
        assert all(b[2] == ONBOARD for b in beats_from(peer, 1))
        assert all(b[2] == mavlink.MAV_TYPE_GCS for b in beats_from(peer, HELIXD_SYSID))
        ap.stop_heartbeat()
        t_stop = time.monotonic() + 0.15
        await stays(lambda: [b for b in beats_from(peer, 1) if b[0] > t_stop] == [], 0.4, "quiet")


async def test_off_there_is_one_heartbeat_only() -> None:
    async with linked(heartbeat_rate_hz=10.0, vehicle_component=False) as (ap, peer):
        ap.start_heartbeat()
        await until(lambda: len(beats_from(peer, HELIXD_SYSID)) >= 3, 2.0, "our beats")
        assert beats_from(peer, 1) == []
        ap.stop_heartbeat()


async def test_commands_to_our_component_of_the_vehicle_are_heard() -> None:
    async with linked() as (ap, peer):
        got: list[tuple[int, int]] = []
        ap.add_command_listener(lambda m, _t: got.append((m.target_system, m.target_component)))
        # a ground station's commands, as the autopilot forwards them
        for target in ((1, 191), (1, 1), (1, 0), (1, 154), (HELIXD_SYSID, 191), (7, 191)):
            peer.send_as(255, 190, change_speed_to(*target))
        await until(lambda: len(got) >= 2, 2.0, "two commands heard")
        await stays(lambda: len(got) == 2, 0.3, "no more")
        assert sorted(got) == [(1, 191), (HELIXD_SYSID, 191)]


async def test_off_only_our_own_system_is_addressed() -> None:
    async with linked(vehicle_component=False) as (ap, peer):
        got: list[tuple[int, int]] = []
        ap.add_command_listener(lambda m, _t: got.append((m.target_system, m.target_component)))
        peer.send_as(255, 190, change_speed_to(1, 191))
        peer.send_as(255, 190, change_speed_to(HELIXD_SYSID, 191))
        await until(lambda: len(got) >= 1, 2.0, "one command heard")
        await stays(lambda: len(got) == 1, 0.3, "no more")
        assert got == [(HELIXD_SYSID, 191)]
