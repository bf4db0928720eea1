"""A third-party client (MAVSDK) on a second link sees a correct autopilot during a helixd run:
armed while helixd flies, MANUAL then HOLD, and the rover's position moving."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.telemetry import FlightMode, TelemetryAsync

from helixd.base.exitcodes import ExitCode
from tests.support.harness import (
    SPEEDUP,
    daemon,
    first_matching,
    free_udp_port,
    running_sim_links,
)

pytestmark = pytest.mark.integration


async def test_mavsdk_watches_a_helixd_mission(tmp_path: Path) -> None:
    port = free_udp_port()
    links = ["udpin:127.0.0.1:0", f"udpout:127.0.0.1:{port}"]
    with running_sim_links(links, speedup=SPEEDUP, terrain="mud") as srv:
        url = f"udpout:127.0.0.1:{srv.local_ports[0]}"
        config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
        async with Mavsdk(config) as mavsdk:
            await mavsdk.add_any_connection(f"udpin://127.0.0.1:{port}")
            system = await mavsdk.first_autopilot(timeout_s=15.0)
            assert system is not None
            telemetry = TelemetryAsync(system)
            with daemon(tmp_path, url, "hexagon") as d:
                assert await first_matching(telemetry.subscribe_armed(), bool, 60.0)
                mode = await first_matching(telemetry.subscribe_flight_mode(), lambda m: True, 5.0)
                assert mode == FlightMode.MANUAL  # helixd drives in MANUAL by override

                def away(p: Any) -> bool:
                    n, e = float(p.position.north_m), float(p.position.east_m)
                    return bool((n * n + e * e) ** 0.5 > 1.0)

                await first_matching(telemetry.subscribe_position_velocity_ned(), away, 60.0)
                held = await first_matching(
                    telemetry.subscribe_flight_mode(), lambda m: m == FlightMode.HOLD, 120.0
                )
                assert held == FlightMode.HOLD  # helixd's end: HOLD …
                disarmed = await first_matching(telemetry.subscribe_armed(), lambda a: not a, 30.0)
                assert disarmed is False  # … then disarm
                code = d.wait_exit(30.0)
            del telemetry
    assert code == ExitCode.OK
