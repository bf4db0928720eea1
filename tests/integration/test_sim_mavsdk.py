"""MAVSDK as an independent client on a second simulator link.

mavsdk ≥ 4 is the native binding (libcmavsdk, no separate mavsdk_server process):
``Mavsdk(Configuration...)`` + ``add_any_connection("udpin://HOST:PORT")`` +
``first_autopilot()``; telemetry through ``mavsdk.asyncio.plugins.telemetry.TelemetryAsync``.
The simulator's second link is ``udpout:127.0.0.1:PORT`` towards MAVSDK's udpin socket,
while a pymavlink GCS on the first link force-arms and drives by RC override.
"""

from __future__ import annotations

import asyncio
from typing import Any

import pytest
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.telemetry import FlightMode, TelemetryAsync

from tests.support.harness import (
    FORCE_ARM,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_RESULT_ACCEPTED,
    MODE_HOLD,
    MavClient,
    OverrideStreamer,
    first_matching,
    free_udp_port,
    running_sim_links,
)

pytestmark = pytest.mark.integration

# ROLL forward (eq. 2 with v_x > 0): scrolls 1, 2 forward, 3, 4 backward
ROLL_FORWARD = (1800, 1800, 1200, 1200)


async def test_mavsdk_reads_armed_mode_and_position_while_pymavlink_drives() -> None:
    port = free_udp_port()
    links = ["udpin:127.0.0.1:0", f"udpout:127.0.0.1:{port}"]
    with running_sim_links(links) as srv:
        config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
        async with Mavsdk(config) as mavsdk:
            await mavsdk.add_any_connection(f"udpin://127.0.0.1:{port}")
            system = await mavsdk.first_autopilot(timeout_s=15.0)
            assert system is not None, "MAVSDK saw no autopilot on the second link"
            telemetry = TelemetryAsync(system)
            mode = await first_matching(
                telemetry.subscribe_flight_mode(), lambda m: m == FlightMode.MANUAL, 15.0
            )
            assert mode == FlightMode.MANUAL
            assert not await first_matching(telemetry.subscribe_armed(), lambda a: True, 10.0)
            start = await first_matching(
                telemetry.subscribe_position_velocity_ned(), lambda p: True, 15.0
            )

            gcs = MavClient(f"udpout:127.0.0.1:{srv.local_ports[0]}")
            try:
                result = await asyncio.to_thread(
                    gcs.command, MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM
                )
                assert result == MAV_RESULT_ACCEPTED
                assert await first_matching(telemetry.subscribe_armed(), bool, 10.0)
                with OverrideStreamer(gcs, ROLL_FORWARD):

                    def moved(p: Any) -> bool:
                        return float(p.position.north_m) > float(start.position.north_m) + 1.0

                    moving = await first_matching(
                        telemetry.subscribe_position_velocity_ned(), moved, 20.0
                    )
                assert abs(float(moving.position.east_m)) < 0.5  # facing North: straight N
                result = await asyncio.to_thread(gcs.command, MAV_CMD_DO_SET_MODE, 1, MODE_HOLD)
                assert result == MAV_RESULT_ACCEPTED
                held = await first_matching(
                    telemetry.subscribe_flight_mode(), lambda m: m == FlightMode.HOLD, 10.0
                )
                assert held == FlightMode.HOLD
            finally:
                gcs.close()
            del telemetry
        snap = srv.snapshot()
        assert snap.armed and snap.mode == "HOLD"
        assert snap.north_m > 1.0
