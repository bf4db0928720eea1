"""``helixd status``: what the autopilot says right now — once, or live with ``--watch``.

Read-only: it never sends overrides, commands or mode changes (it only requests streams),
and it speaks as ``link.observer_system`` without a HEARTBEAT, so the autopilot never takes it
for its GCS (whose silence after ``status`` exits would fire the GCS failsafe).
"""

from __future__ import annotations

import asyncio
import contextlib
import io
import math
from collections.abc import Mapping

from helixd.base.clock import now_s
from helixd.base.frames import ne_to_latlon
from helixd.config.link import LinkConfig
from helixd.config.safety import SafetyConfig
from helixd.link.connection import Autopilot
from helixd.link.services.command_client import CommandError
from helixd.link.vehicle import Change, VehicleState
from helixd.mav.constants import MAV_CMD_REQUEST_MESSAGE, MAVLINK_MSG_ID_GPS_RAW_INT
from helixd.mav.guard_script import (
    HXG_CHANS,
    HXG_ENABLE,
    HXG_VERSION,
    SCR_ENABLE,
    VERSION,
    GuardParams,
)
from helixd.safety.watchdogs import GPS_FIX_NAMES


class HeldLog(io.StringIO):
    """Where ``status`` sends its log lines (the text stream given to
    :func:`helixd.recorder.logging_setup.configure_logging`): held, then printed with the
    report as its own ``log`` lines (:func:`log_lines`) instead of landing between them."""

    def drain(self) -> list[str]:
        """The whole lines written so far (then forgotten; a partial line is kept)."""
        done, sep, rest = self.getvalue().rpartition("\n")
        if not sep:
            return []
        self.seek(0)
        self.truncate()
        self.write(rest)
        return [line for line in done.split("\n") if line.strip()]


def log_lines(lines: list[str]) -> list[str]:
    """The held log lines as report lines (pure)."""
    return [f"log       : {line.strip()}" for line in lines]


FIRST_REPORT_S = 2.0  # wait this long for the first pose, then for the slower streams (s)
GUARD_PARAMS = (SCR_ENABLE, HXG_VERSION, HXG_ENABLE, *HXG_CHANS)
GUARD_PARAM_RETRIES = 1  # a missing parameter is never answered: ask it once more, not more
INSTALL_HINT = "helixd autopilot install-guard --reboot"


def _has_every_report(st: VehicleState) -> bool:
    return st.ekf is not None and bool(st.rc_inputs_us) and bool(st.servo_outputs_us)


def observer_line(link: LinkConfig) -> str:
    """Who we are on the link (``status`` says it, so nobody wonders about the failsafe)."""
    return (
        f"us        : MAVLink system {link.observer_system} (link.observer_system), no "
        f"HEARTBEAT: not the GCS id {link.source_system}, so the GCS failsafe never counts on us"
    )


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
    if p is not None and st.gps_origin is not None:
        lat, lon = ne_to_latlon(p.ned.north_m, p.ned.east_m, *st.gps_origin)
        lines.append(f"position  : {lat:.7f}°, {lon:.7f}° (the EKF pose through its origin)")
    lines.append("ekf       : " + ("no EKF_STATUS_REPORT" if st.ekf is None else st.ekf.describe()))
    if st.gps_origin is not None:
        lines.append(f"origin    : {st.gps_origin[0]:.7f}°, {st.gps_origin[1]:.7f}°")
    else:
        lines.append("origin    : none reported (no GPS_GLOBAL_ORIGIN: no GPS fix yet?)")
    lines.append(f"gps       : {gps_text(st)}")
    lines.append(f"battery   : {battery_text(st)}")
    rc = " ".join(f"{v:4d}" for v in st.rc_inputs_us[:8]) or "none"
    rx = {None: "not reported", True: "healthy", False: "UNHEALTHY"}[st.rc_receiver_healthy]
    lines.append(f"rc in µs  : {rc}  (receiver {rx})")
    servo = " ".join(f"{v:4d}" for v in st.servo_outputs_us[:8]) or "none"
    lines.append(f"servo µs  : {servo}")
    return lines


def guard_text(params: Mapping[str, float | None]) -> str:
    """Whether helixd-guard runs on the autopilot and is enabled, from SCR_ENABLE and the
    HXG_* parameters it adds when it runs (pure)."""
    version = params.get(HXG_VERSION)
    if version is None:
        scr = params.get(SCR_ENABLE)
        if scr is None:
            return "helixd-guard cannot run: no SCR_ENABLE (the firmware has no Lua scripting)"
        if round(scr) != 1:
            return f"helixd-guard not running (SCR_ENABLE = {scr:g}): {INSTALL_HINT}"
        return (
            "helixd-guard not running (SCR_ENABLE = 1, no HXG_VERSION: not installed, or "
            f"installed since the last boot): {INSTALL_HINT}"
        )
    guard = GuardParams.from_params({n: v for n, v in params.items() if v is not None})
    text = f"helixd-guard v{round(version)} runs"
    if round(version) != VERSION:
        text += f" (this helixd needs v{VERSION}: {INSTALL_HINT})"
    if not guard.enabled:
        return f"{text}, DISABLED (HXG_ENABLE = {guard.enable:g}): it holds nothing"
    outputs = ", ".join(str(n) for n in guard.outputs) or "none"
    return f"{text}, enabled (HXG_ENABLE = 1), holds outputs {outputs}"


async def read_guard(ap: Autopilot) -> str:
    """:func:`guard_text` from the parameters read now."""
    values = await asyncio.gather(
        *(ap.param.get(n, retries=GUARD_PARAM_RETRIES) for n in GUARD_PARAMS)
    )
    return guard_text(dict(zip(GUARD_PARAMS, values, strict=True)))


def gps_text(st: VehicleState) -> str:
    """``3D fix, 12 satellites`` from GPS_RAW_INT."""
    if st.gps_fix_type is None:
        return "no GPS_RAW_INT"
    sats = "satellites unknown" if st.gps_satellites is None else f"{st.gps_satellites} satellites"
    return f"{GPS_FIX_NAMES.get(st.gps_fix_type, str(st.gps_fix_type))}, {sats}"


def battery_text(st: VehicleState) -> str:
    """``12.40 V, 80 %`` from SYS_STATUS."""
    if st.battery_voltage_v is None and st.battery_remaining_pct is None:
        return "not reported"
    volts = "voltage unknown" if st.battery_voltage_v is None else f"{st.battery_voltage_v:.2f} V"
    pct = "" if st.battery_remaining_pct is None else f", {st.battery_remaining_pct} %"
    return volts + pct


async def _ask_for(ap: Autopilot, timeout_s: float, origin: bool = False) -> None:
    """GPS_RAW_INT (and with ``origin`` GPS_GLOBAL_ORIGIN) once: not streamed to us."""
    with contextlib.suppress(CommandError, TimeoutError):
        async with asyncio.timeout(timeout_s):
            await ap.action.command_long(MAV_CMD_REQUEST_MESSAGE, (MAVLINK_MSG_ID_GPS_RAW_INT,))
    if origin and ap.state.gps_origin is None:
        await ap.action.request_gps_origin(timeout_s)


async def read_status(
    link: LinkConfig,
    safety: SafetyConfig,
    connect_timeout_s: float,
    watch: bool,
    interval_s: float,
    emit: object,
    held: HeldLog | None = None,
) -> int:
    """Connect, wait for a heartbeat and the streams, print. Returns a process exit code.
    ``held``: the log lines of this read, printed after each report as ``log`` lines."""
    assert callable(emit)

    def held_lines() -> None:
        for line in log_lines([] if held is None else held.drain()):
            emit(line)

    emit(
        f"status    : waiting up to {connect_timeout_s:g} s "
        f"(startup.connect_timeout_s) for the autopilot's HEARTBEAT on {link.url} …"
    )
    ap = await Autopilot.connect(link, safety, observer=True)
    try:
        await ap.wait_heartbeat(connect_timeout_s)
        await ap.request_streams()
        await _ask_for(ap, link.command_timeout_s, origin=True)
        await ap.telemetry.next_pose(after_rx_s=None, timeout_s=FIRST_REPORT_S)
        # the slower streams (EKF, RC, servo at link.telemetry_rate_hz) trail the first pose
        await ap.telemetry.wait_for(
            _has_every_report, Change.EKF | Change.RC | Change.SERVO, FIRST_REPORT_S
        )
        emit(observer_line(link))
        emit(f"guard     : {await read_guard(ap)}")
        while True:
            for line in format_status(ap.state, now_s()):
                emit(line)
            held_lines()
            if not watch:
                return 0
            emit("")
            await asyncio.sleep(interval_s)
            await _ask_for(ap, min(interval_s, link.command_timeout_s))
    finally:
        await ap.close()
