"""A QGroundControl-like ground station for flights on the simulated clock: what
:mod:`tests.support.gcs` and the helpers of :mod:`tests.support.serve` do with a blocking
client, done with a :class:`~tests.support.loop_mav.LoopMav` in the loop (mission upload by
the mission protocol, commands to helixd and to the autopilot, the message pane)."""

from __future__ import annotations

import signal
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.mav.constants import (
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
)
from tests.support.gcs import (
    HELIXD,
    QGC_SYSID,
    UPLOAD_REPLIES,
    set_mode_command,
    shows_armed,
    shows_mode,
    upload_reply,
    waypoint,
)
from tests.support.harness import overrides_released
from tests.support.loop_mav import LoopMav
from tests.support.simulated import SimulatedService, Steer, moving, simulated_serve

UploadStep = Callable[[], Awaitable[None]]
Crew = Callable[[Steer, LoopMav], Awaitable[Any]]
# The crew's service: no start switch, the crew uses the ground station. In the field the
# service has been up for minutes when the crew presses Start; here seconds: the preflight's
# listening window for another sender on helixd's id (link.own_id_watch_s, from helixd's first
# message) is shortened so that it is over by then, as it is in the field.
CREW_CONFIG: dict[str, Any] = {
    "startup": {"start_switch_channel": None},
    "link": {"own_id_watch_s": 0.5},
}


def simulated_crew(
    tmp_path: Path, config: dict[str, Any] | None, crew: Crew, **sim: Any
) -> SimulatedService:
    """``helixd serve`` on the simulated clock with a QGroundControl-like ground station on
    the simulator's second link, driven by ``crew(st, gcs)``; then the service is stopped as
    systemd stops it (SIGTERM). What ``crew`` returned is the service's ``steered[0]``."""

    async def day(st: Steer) -> Any:
        result = await crew(st, st.ground_station(1, QGC_SYSID))
        st.signal(signal.SIGTERM)
        return result

    return simulated_serve(tmp_path, day, config, **sim)


async def upload_typed(
    gcs: LoopMav, items: list[Any], mission_type: int, what: str, timeout_s: float = 20.0
) -> None:
    """Upload ``items`` of ``mission_type`` by the mission protocol
    (:func:`tests.support.gcs.upload_reply`); AssertionError unless MISSION_ACK ACCEPTED
    (``what`` names the list)."""
    gcs.drain()
    gcs.mav.mission_count_send(1, 1, len(items), mission_type)
    deadline = now_s() + timeout_s
    while (remaining := deadline - now_s()) > 0:
        msg = await gcs.recv_any(UPLOAD_REPLIES, remaining)
        if upload_reply(gcs.mav, items, msg, what):
            return
    raise AssertionError(f"{what} upload: no MISSION_ACK")


async def upload_items(gcs: LoopMav, items: list[Any], timeout_s: float = 20.0) -> None:
    await upload_typed(gcs, items, mavlink.MAV_MISSION_TYPE_MISSION, "mission", timeout_s)


async def upload(
    gcs: LoopMav,
    points_ne_m: list[tuple[float, float]],
    timeout_s: float = 20.0,
    commands: dict[int, int] | None = None,
) -> None:
    """Upload home + one NAV_WAYPOINT per point (``commands``: item number → another
    navigation command at that point)."""
    cmds = commands or {}
    items = [
        waypoint(0, 0.0, 0.0),
        *(
            waypoint(i + 1, n, e, cmds.get(i + 1, mavlink.MAV_CMD_NAV_WAYPOINT))
            for i, (n, e) in enumerate(points_ne_m)
        ),
    ]
    await upload_items(gcs, items, timeout_s)


async def upload_fence(gcs: LoopMav, items: list[Any], timeout_s: float = 20.0) -> None:
    await upload_typed(gcs, items, mavlink.MAV_MISSION_TYPE_FENCE, "fence", timeout_s)


async def command(gcs: LoopMav, cmd: int, *params: float, timeout_s: float = 10.0) -> int:
    """COMMAND_LONG to helixd; the result of helixd's COMMAND_ACK for it."""
    gcs.heartbeat()  # a GCS heartbeats all the time: the autopilot knows its route
    return await gcs.command(cmd, *params, target=HELIXD, timeout_s=timeout_s)


async def set_mode(gcs: LoopMav, name: str) -> float:
    """QGroundControl's Vehicle::setFlightMode for ArduPilot: MAV_CMD_DO_SET_MODE to the
    autopilot with the custom mode; returns the (simulated) time it was sent."""
    sent = now_s()
    result = await gcs.command(*set_mode_command(name))
    assert result == MAV_RESULT_ACCEPTED, (name, result)
    return sent


async def heartbeat_shows(gcs: LoopMav, condition: Callable[[Any], bool]) -> None:
    """The autopilot's HEARTBEAT on the ground station's own link showing the change."""
    await gcs.expect("HEARTBEAT", 10.0, lambda m: m.get_srcSystem() == 1 and condition(m))


PREARM_CHECK = 0x10000000  # SYS_STATUS sensor bit: the autopilot's PreArm checks pass


async def booted(st: Steer, gcs: LoopMav) -> None:
    """Until the autopilot is ready to arm, as QGroundControl shows it (SYS_STATUS's PreArm
    bit healthy): a crew presses nothing before (on the simulated clock helixd may be ready
    sooner than that)."""
    await st.until(lambda s: not s.booting, 60.0)
    await gcs.expect(
        "SYS_STATUS",
        60.0,
        lambda m: m.get_srcSystem() == 1 and bool(m.onboard_control_sensors_health & PREARM_CHECK),
    )


async def armed_in_guided(gcs: LoopMav, wait_armed: bool = True) -> None:
    """The first half of QGroundControl's Start Mission on a disarmed rover
    (APMFirmwarePlugin::startMission): _setFlightModeAndValidate(Guided), then a normal arm
    (with ``wait_armed``, _armVehicleAndValidate: until the HEARTBEAT shows it armed)."""
    await set_mode(gcs, "GUIDED")
    await heartbeat_shows(gcs, shows_mode("GUIDED"))
    assert await gcs.command(MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    if wait_armed:
        await heartbeat_shows(gcs, shows_armed)


async def start_mission(gcs: LoopMav) -> None:
    """QGroundControl's Start Mission on a disarmed rover (APMFirmwarePlugin::startMission):
    GUIDED, arm (:func:`armed_in_guided`), then MAV_CMD_MISSION_START to the autopilot (which
    enters AUTO)."""
    await armed_in_guided(gcs)
    assert await gcs.command(MAV_CMD_MISSION_START, 0, 0) == MAV_RESULT_ACCEPTED


async def uploaded_and_ready(st: Steer, gcs: LoopMav, upload_mission: UploadStep) -> None:
    """QGroundControl's Plan view Upload (``upload_mission``) once ``helixd serve`` finds no
    mission, until helixd is ready and the autopilot has booted (:func:`booted`)."""
    await st.line("no mission on the autopilot", 60.0)
    await upload_mission()
    await st.line("event=serve_state state=ready", 30.0)
    await booted(st, gcs)


async def upload_and_start(st: Steer, gcs: LoopMav, upload_mission: UploadStep) -> None:
    """:func:`uploaded_and_ready`, then Start Mission on the disarmed rover (GUIDED, arm,
    MAV_CMD_MISSION_START to the autopilot): until helixd starts driving in AUTO."""
    await uploaded_and_ready(st, gcs, upload_mission)
    await start_mission(gcs)
    await st.line("event=auto_start", 10.0)  # item 0 or 1: MISSION_CURRENT may lag the start
    await st.until(moving, 20.0)


async def let_go_in_manual(st: Steer, gcs: LoopMav) -> None:
    """The crew picks MANUAL: helixd releases its overrides within 5 s and pauses."""
    mark = st.mark()
    await set_mode(gcs, "MANUAL")
    await st.until(overrides_released, 5.0)
    await st.line("event=serve_state state=paused", 30.0, after=mark)


async def said(gcs: LoopMav, sentence: str, timeout_s: float) -> None:
    """Until helixd's texts, its lines joined as a ground station's pane reads them (each line
    starts with ``helixd: ``), contain ``sentence``."""
    deadline = now_s() + timeout_s
    while True:
        joined = " ".join(t.removeprefix("helixd: ") for t in gcs.texts if t.startswith("helixd: "))
        if sentence in joined:
            return
        remaining = deadline - now_s()
        if remaining <= 0:
            raise AssertionError(f"helixd never said {sentence!r}; saw {gcs.texts}")
        await gcs.recv("STATUSTEXT", remaining)
