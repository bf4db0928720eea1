"""``helixd status``: what the autopilot says right now — once, or live with ``--watch``.

Read-only: it never sends overrides, commands or mode changes (it only requests streams).
"""

from __future__ import annotations

import asyncio
import math
import time

from helixd.config import LinkConfig, SafetyConfig
from helixd.link.connection import Autopilot
from helixd.link.vehicle import VehicleState


def format_status(st: VehicleState, now_s: float) -> list[str]:
    """Human lines with units; pure so it can be tested without a link."""
    lines = [f"mode      : {st.mode}  ({'ARMED' if st.armed else 'disarmed'})"]
    hb = "never" if st.last_heartbeat_s is None else f"{now_s - st.last_heartbeat_s:.1f} s ago"
    lines.append(
        f"link      : heartbeat {hb}, lost {st.link_lost_count}×, reboots {st.reboot_count}"
    )
    p = st.pose
    if p is None:
        lines.append("pose      : none yet")
    else:
        lines.append(
            f"pose      : N {p.ned.north_m:.2f} m  E {p.ned.east_m:.2f} m  "
            f"yaw {math.degrees(p.ned.yaw_ned_rad) % 360:.1f}° (NED, clockwise from North)  "
            f"speed {math.hypot(p.vn_mps, p.ve_mps):.2f} m/s  age {now_s - p.rx_monotonic_s:.2f} s"
        )
    lines.append("ekf       : " + ("no EKF_STATUS_REPORT" if st.ekf is None else st.ekf.describe()))
    if st.gps_origin is not None:
        lines.append(f"origin    : {st.gps_origin[0]:.7f}°, {st.gps_origin[1]:.7f}°")
    rc = " ".join(f"{v:4d}" for v in st.rc_inputs_us[:8]) or "none"
    rx = {None: "not reported", True: "healthy", False: "UNHEALTHY"}[st.rc_receiver_healthy]
    lines.append(f"rc in µs  : {rc}  (receiver {rx})")
    servo = " ".join(f"{v:4d}" for v in st.servo_outputs_us[:8]) or "none"
    lines.append(f"servo µs  : {servo}")
    return lines


async def read_status(
    link: LinkConfig, safety: SafetyConfig, watch: bool, interval_s: float, emit: object
) -> int:
    """Connect, wait for a heartbeat and the streams, print. Returns a process exit code."""
    assert callable(emit)
    ap = await Autopilot.connect(link, safety)
    try:
        await ap.wait_heartbeat(safety.connect_timeout_s)
        await ap.request_streams()
        await ap.telemetry.next_pose(after_rx_s=None, timeout_s=2.0)
        while True:
            for line in format_status(ap.state, time.monotonic()):
                emit(line)
            if not watch:
                return 0
            emit("")
            await asyncio.sleep(interval_s)
    finally:
        await ap.close()
