#!/usr/bin/env python3
"""Control-loop benchmark: pose-in → command-out latency, loop jitter and CPU at 50 Hz.

The quality bar (docs/measurements.md): pose-in → command-out latency p99 < 1 ms, 50 Hz loop
jitter p99 < 2 ms, CPU < 5 % of one core at 50 Hz telemetry — printed by a benchmark, not
asserted by a test.

Real parts on both sides of a loopback UDP link:

* the *autopilot* is a separate process (so it shares no GIL with the daemon) speaking MAVLink
  2 with pymavlink's codec: HEARTBEAT 1 Hz (MANUAL, armed once asked), ATTITUDE +
  LOCAL_POSITION_NED at ``--rate-hz``, EKF_STATUS_REPORT, SYS_STATUS, RC_CHANNELS,
  SERVO_OUTPUT_RAW and GPS_RAW_INT (a 3D fix, its time moving: the daemon's GPS checks) at
  5 Hz; it ACCEPTs every COMMAND_LONG (SET_MESSAGE_INTERVAL included, as an ArduPilot whose
  SCHED_LOOP_RATE grants 20 ms would), answers PARAM_REQUEST_READ from a
  correctly set-up Helix parameter table, and integrates the RC overrides it receives through
  the no-slip kinematics (eq. 1) so the pose moves and the mission progresses;
* the *daemon* side, in this process, is what ``helixd run`` flies with:
  :class:`helixd.link.connection.Autopilot` (reader, heartbeat, stream monitor),
  :class:`helixd.runtime.flight.FlightLoop` (safety monitor, navigator, kinematics),
  :class:`helixd.actuators.rc_override.RcOverrideSink` (with its 20 Hz repeater), the run recorder
  (flight.csv, events.jsonl), the summary builder and the progress display, with structlog
  configured as the daemon configures it (info level, logfmt to a file instead of stderr).

Measured over a ``--seconds`` window after a warm-up:

* latency = from the autopilot process's ``time.monotonic()`` just before the
  LOCAL_POSITION_NED ``sendto`` (CLOCK_MONOTONIC is system-wide) to the return of
  ``sink.command()`` in the control step that used that pose — by then the
  RC_CHANNELS_OVERRIDE datagram has been handed to the kernel (``sendto`` returned). The
  pose's ``time_boot_ms`` pairs the two. Split into wire (send → the link's ``rx_monotonic_s``
  stamp) and in-daemon (stamp → override sent). ``autopilot rtt`` is the same seen from the
  autopilot: pose sent → that step's override read back from its socket.
* jitter = |interval between consecutive control steps − 1/rate| (the autopilot's own send
  jitter is printed next to it: the loop cannot be steadier than its input).
* CPU = ``getrusage(RUSAGE_SELF)`` user+sys of this process over the window ÷ wall time.
* two floors, each against a fresh autopilot process at the same rate, over the same window:
  a bare pymavlink echo loop with blocking reads (:func:`floor_loop`) and the same echo as
  the least asyncio program (:func:`asyncio_floor_loop`); per floor its CPU, its CPU per step,
  the daemon's CPU per step over it, and its autopilot rtt.

Usage::

    .venv/bin/python tools/bench_control_loop.py [--seconds 30] [--rate-hz 50 --rate-hz 200]
    make bench-loop LOOP_ARGS="--seconds 10 --rate-hz 50"   # the control loop alone, quickly
    .venv/bin/python tools/bench_control_loop.py --seconds 10 --profile 25   # cProfile top 25
"""

from __future__ import annotations

import asyncio
import bisect
import itertools
import math
import multiprocessing
import os
import resource
import select
import socket
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from multiprocessing.connection import Connection
from pathlib import Path
from typing import Any

os.environ.setdefault("MAVLINK20", "1")

import typer
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.config.link import LinkConfig

TELEMETRY_RATE_HZ = 5.0
HEARTBEAT_RATE_HZ = 1.0
SPIN_S = 0.0005  # the autopilot busy-waits the last 0.5 ms before a send (precise timing)
POSE_START_DELAY_S = 0.05
SQUARE_SIDE_M = 20.0
LAP_ESTIMATE_S = 150.0  # one lap of the 20 m square at 0.6 m/s, turns included (roughly)
SETUP_TIMEOUT_S = 15.0
RECORD_TIMEOUT_S = 10.0
LABEL_WIDTH = 37
TARGET_LATENCY_P99_MS = 0.5
TARGET_JITTER_P99_MS = 2.0
# CPU of one core: < 2 % at 50 Hz and < 6 % at 200 Hz (the original targets); linear in between
TARGET_CPU_POINTS = ((50.0, 2.0), (200.0, 6.0))
TARGET_RATIO_TO_FLOOR = 2.0  # daemon CPU per step over a bare pymavlink echo loop's
ASYNCIO_PREFIX = "asyncio_"  # figures of the same echo loop written as an asyncio program
MAX_RATE_HZ = 200.0
POSE_RATE_REQUEST_MAX_HZ = 100.0  # link.pose_rate_hz's bound; the fake autopilot sends anyway
MANUAL = 0
# GPS_RAW_INT: what the daemon's GPS checks want (safety.gps_min_fix_type, gps_min_satellites)
GPS_FIX_TYPE_3D = 3
GPS_SATELLITES = 12
GPS_EPH_CM = 80  # HDOP x 100
GPS_ORIGIN_DEG = (52.0, 5.0)
EARTH_RADIUS_M = 6_378_137.0
# A Helix set up as the README says: helixd is the GCS, overrides drive RCIN1..4 passthrough.
AUTOPILOT_PARAMS: dict[str, float] = {
    "MAV_GCS_SYSID": float(LinkConfig().source_system),
    "FS_GCS_ENABLE": 1.0,
    "FS_ACTION": 2.0,
    "RC_OVERRIDE_TIME": 3.0,
    "RC_OPTIONS": 0.0,
    "MODE_CH": 8.0,
    "SCHED_LOOP_RATE": 100.0,
    **{f"RC{n}_OPTION": 0.0 for n in range(1, 17)},
    **{f"SERVO{n}_FUNCTION": float(50 + n) for n in range(1, 5)},
}


# -- pure helpers -----------------------------------------------------------------------------


@dataclass(frozen=True)
class Stats:
    n: int
    p50: float
    p99: float
    max: float


def percentile(sorted_values: Sequence[float], q: float) -> float:
    """Nearest-rank percentile (0 < q ≤ 100) of an ascending, non-empty sequence."""
    if not sorted_values:
        raise ValueError("no values")
    rank = max(1, math.ceil(q / 100.0 * len(sorted_values)))
    return sorted_values[min(rank, len(sorted_values)) - 1]


def stats(values: Sequence[float]) -> Stats | None:
    if not values:
        return None
    s = sorted(values)
    return Stats(len(s), percentile(s, 50), percentile(s, 99), s[-1])


def interval_deviations(times_s: Sequence[float], period_s: float) -> list[float]:
    """|t[i+1] − t[i] − period| for consecutive times (s)."""
    return [abs(b - a - period_s) for a, b in itertools.pairwise(times_s)]


@dataclass(frozen=True)
class Step:
    """One control step: the pose it used and when its command left."""

    time_boot_ms: int
    rx_s: float  # the link's receive stamp of that LOCAL_POSITION_NED
    cmd_s: float  # sink.command() was called (safety check, navigator, kinematics done)
    out_s: float  # sink.command() returned (override handed to the kernel)


@dataclass
class Latencies:
    total_s: list[float] = field(default_factory=list)
    wire_s: list[float] = field(default_factory=list)
    inside_s: list[float] = field(default_factory=list)
    compute_s: list[float] = field(default_factory=list)
    send_s: list[float] = field(default_factory=list)
    unmatched: int = 0


def match_latencies(sent_s_by_tboot: dict[int, float], steps: Sequence[Step]) -> Latencies:
    """Pair each step with the autopilot's send time of its pose (by ``time_boot_ms``)."""
    out = Latencies()
    for st in steps:
        sent = sent_s_by_tboot.get(st.time_boot_ms)
        if sent is None:
            out.unmatched += 1
            continue
        out.total_s.append(st.out_s - sent)
        out.wire_s.append(st.rx_s - sent)
        out.inside_s.append(st.out_s - st.rx_s)
        out.compute_s.append(st.cmd_s - st.rx_s)
        out.send_s.append(st.out_s - st.cmd_s)
    return out


def first_responses(sends_s: Sequence[float], arrivals_s: Sequence[float]) -> list[float | None]:
    """Per send (ascending): delay to the first arrival before the next send, else None."""
    out: list[float | None] = []
    for i, t in enumerate(sends_s):
        j = bisect.bisect_left(arrivals_s, t)
        nxt = sends_s[i + 1] if i + 1 < len(sends_s) else math.inf
        out.append(arrivals_s[j] - t if j < len(arrivals_s) and arrivals_s[j] < nxt else None)
    return out


def in_window(times: Sequence[float], t0: float, t1: float) -> list[float]:
    return [t for t in times if t0 <= t < t1]


def square_laps(side_m: float, laps: int) -> list[tuple[float, float]]:
    """Counter-clockwise square waypoints (start frame), ``laps`` times round."""
    corners = [(side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]
    return corners * laps


def format_stats_ms(name: str, s: Stats | None, target: str = "") -> str:
    if s is None:
        return f"{name:<{LABEL_WIDTH}} no samples"
    return (
        f"{name:<{LABEL_WIDTH}} p50 {s.p50 * 1e3:7.3f}  p99 {s.p99 * 1e3:7.3f}  "
        f"max {s.max * 1e3:7.3f} ms"
        f"  (n={s.n}){'  ' + target if target else ''}"
    )


def cpu_target_percent(rate_hz: float) -> float:
    """The CPU target at ``rate_hz``: the two target points, linear between, flat outside."""
    (r0, c0), (r1, c1) = TARGET_CPU_POINTS
    if rate_hz <= r0:
        return c0
    if rate_hz >= r1:
        return c1
    return c0 + (c1 - c0) * (rate_hz - r0) / (r1 - r0)


def verdict(ok: bool) -> str:
    return "ok" if ok else "MISSED"


# -- the autopilot process --------------------------------------------------------------------


@dataclass
class AutopilotRecord:
    pose_sends: list[tuple[int, float]] = field(default_factory=list)  # (time_boot_ms, t)
    override_arrivals: list[float] = field(default_factory=list)
    cpu_s: float = 0.0
    wall_s: float = 0.0
    overrides: int = 0
    send_errors: int = 0


class FakeAutopilot:
    """The autopilot's state and replies (no sockets here; ``out`` collects packed bytes)."""

    def __init__(self, rate_hz: float, boot_s: float) -> None:
        from helixd.config.vehicle import ActuationConfig, VehicleConfig

        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.mav.robust_parsing = True
        self.boot_s = boot_s
        self.period_s = 1.0 / rate_hz
        self.armed = False
        self.mode = MANUAL
        self.pwm_us = [1500] * 16
        self.north_m = 0.0
        self.east_m = 0.0
        self.yaw_ned_rad = 0.0
        self.vn_mps = 0.0
        self.ve_mps = 0.0
        self.last_plant_s = boot_s
        self.vehicle = VehicleConfig()
        self.channels = ActuationConfig().channels
        self.out: list[bytes] = []

    def tboot_ms(self, now_s: float) -> int:
        return int((now_s - self.boot_s) * 1000.0)

    def _pack(self, msg: Any) -> None:
        self.out.append(bytes(msg.pack(self.mav)))
        self.mav.seq = (self.mav.seq + 1) % 256

    # replies
    def handle(self, msg: Any, now_s: float, rec: AutopilotRecord) -> None:
        mtype = msg.get_type()
        if mtype == "RC_CHANNELS_OVERRIDE":
            rec.override_arrivals.append(now_s)
            rec.overrides += 1
            for n in range(1, 5):
                v = int(getattr(msg, f"chan{n}_raw"))
                if v == 0:
                    self.pwm_us[n - 1] = 1500  # released to the (centred) radio
                elif v != 65535:
                    self.pwm_us[n - 1] = v
        elif mtype == "COMMAND_LONG":
            cmd = int(msg.command)
            if cmd == mavlink.MAV_CMD_COMPONENT_ARM_DISARM:
                self.armed = float(msg.param1) == 1.0
            elif cmd == mavlink.MAV_CMD_DO_SET_MODE:
                self.mode = int(msg.param2)
            self._pack(
                self.mav.command_ack_encode(
                    cmd,
                    mavlink.MAV_RESULT_ACCEPTED,
                    0,
                    0,
                    msg.get_srcSystem(),
                    msg.get_srcComponent(),
                )
            )
        elif mtype == "PARAM_REQUEST_READ":
            name = str(msg.param_id).rstrip("\x00")
            if name in AUTOPILOT_PARAMS:
                names = list(AUTOPILOT_PARAMS)
                self._pack(
                    self.mav.param_value_encode(
                        name.encode(),
                        AUTOPILOT_PARAMS[name],
                        mavlink.MAV_PARAM_TYPE_REAL32,
                        len(names),
                        names.index(name),
                    )
                )

    # the plant: ideal no-slip kinematics of the overridden scroll speeds
    def advance(self, now_s: float) -> None:
        import numpy as np

        from helixd.actuators.mapping import pwm_to_fraction
        from helixd.control.kinematics import fraction_to_radps, scroll_radps_to_body

        dt = now_s - self.last_plant_s
        self.last_plant_s = now_s
        fractions = np.array(
            [pwm_to_fraction(self.pwm_us[i], ch) for i, ch in enumerate(self.channels)]
        )
        body = scroll_radps_to_body(
            fraction_to_radps(fractions, self.vehicle.max_rpm), self.vehicle
        )
        yaw = self.yaw_ned_rad - 0.5 * body.wz_radps * dt
        c, s = math.cos(yaw), math.sin(yaw)
        self.vn_mps = body.vx_mps * c + body.vy_mps * s
        self.ve_mps = body.vx_mps * s - body.vy_mps * c
        self.north_m += self.vn_mps * dt
        self.east_m += self.ve_mps * dt
        self.yaw_ned_rad = math.remainder(self.yaw_ned_rad - body.wz_radps * dt, math.tau)

    # streams
    def attitude(self, t_ms: int) -> Any:
        return self.mav.attitude_encode(t_ms, 0.0, 0.0, self.yaw_ned_rad, 0.0, 0.0, 0.0)

    def local_position(self, t_ms: int) -> Any:
        return self.mav.local_position_ned_encode(
            t_ms, self.north_m, self.east_m, 0.0, self.vn_mps, self.ve_mps, 0.0
        )

    def heartbeat(self) -> None:
        base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
            mavlink.MAV_MODE_FLAG_SAFETY_ARMED if self.armed else 0
        )
        self._pack(
            self.mav.heartbeat_encode(
                mavlink.MAV_TYPE_GROUND_ROVER,
                mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                base,
                self.mode,
                mavlink.MAV_STATE_ACTIVE,
            )
        )

    def telemetry(self, now_s: float) -> None:
        t_ms = self.tboot_ms(now_s)
        flags = 0x1 | 0x2 | 0x4 | 0x8 | 0x10 | 0x20  # attitude, velocities, positions
        self._pack(self.mav.ekf_status_report_encode(flags, 0.1, 0.1, 0.1, 0.05, 0.0))
        rc_bit = 0x10000
        self._pack(
            self.mav.sys_status_encode(rc_bit, rc_bit, rc_bit, 300, 24000, -1, -1, 0, 0, 0, 0, 0, 0)
        )
        rc = self.pwm_us[:4] + [1500] * 14
        self._pack(self.mav.rc_channels_encode(t_ms, 16, *rc, 255))
        self._pack(self.mav.servo_output_raw_encode(int(t_ms * 1000) & 0xFFFFFFFF, 0, *self.pwm_us))
        self._pack(self.gps_raw_int(t_ms))

    def gps_raw_int(self, t_ms: int) -> Any:
        """A 3D fix with 12 satellites, as ArduPilot streams GPS_RAW_INT (AP_GPS::
        send_mavlink_gps_raw; helixd/sim/firmware/messages.py): ``time_usec`` is the fix's time,
        so it moves with every report (a frozen one is a receiver that stopped: gps_lost); position
        as latitude/longitude near an arbitrary origin, speed and course from the plant."""
        lat_deg = GPS_ORIGIN_DEG[0] + math.degrees(self.north_m / EARTH_RADIUS_M)
        lon_deg = GPS_ORIGIN_DEG[1] + math.degrees(
            self.east_m / (EARTH_RADIUS_M * math.cos(math.radians(GPS_ORIGIN_DEG[0])))
        )
        course_cdeg = round(math.degrees(math.atan2(self.ve_mps, self.vn_mps)) * 100.0) % 36000
        return self.mav.gps_raw_int_encode(
            t_ms * 1000,
            GPS_FIX_TYPE_3D,
            round(lat_deg * 1e7),
            round(lon_deg * 1e7),
            0,
            GPS_EPH_CM,
            2 * GPS_EPH_CM,
            round(math.hypot(self.vn_mps, self.ve_mps) * 100.0),
            course_cdeg,
            GPS_SATELLITES,
        )


def autopilot_main(port: int, rate_hz: float, ctrl: Connection) -> None:
    """Play ArduPilot on UDP until ``ctrl`` says stop; send the record back on ``ctrl``."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setblocking(False)
    dest = ("127.0.0.1", port)
    boot = time.monotonic()
    ap = FakeAutopilot(rate_hz, boot)
    rec = AutopilotRecord()
    cpu0 = time.process_time()
    next_pose = boot + POSE_START_DELAY_S
    next_tel = boot
    next_hb = boot
    tel_period, hb_period = 1.0 / TELEMETRY_RATE_HZ, 1.0 / HEARTBEAT_RATE_HZ

    def flush() -> None:
        for data in ap.out:
            try:
                sock.sendto(data, dest)
            except OSError:  # the daemon's port is not up yet / gone: UDP is lossy anyway
                rec.send_errors += 1
        ap.out.clear()

    def drain() -> None:
        while True:
            try:
                data = sock.recv(65536)
            except (BlockingIOError, ConnectionRefusedError):
                return
            now = time.monotonic()
            for msg in ap.mav.parse_buffer(data) or []:
                ap.handle(msg, now, rec)
            flush()

    while True:
        now = time.monotonic()
        due = min(next_pose, next_tel, next_hb)
        wait = due - now
        if wait > SPIN_S:
            ready, _, _ = select.select([sock.fileno(), ctrl.fileno()], [], [], wait - SPIN_S)
            if sock.fileno() in ready:
                drain()
            if ctrl.fileno() in ready and ctrl.recv() == "stop":
                break
            continue
        if wait > 0:
            continue  # spin: sends leave on time
        if now >= next_pose:
            ap.advance(now)
            t_ms = ap.tboot_ms(now)
            sock.sendto(bytes(ap.attitude(t_ms).pack(ap.mav)), dest)
            ap.mav.seq = (ap.mav.seq + 1) % 256
            buf = bytes(ap.local_position(t_ms).pack(ap.mav))
            ap.mav.seq = (ap.mav.seq + 1) % 256
            t_send = time.monotonic()
            sock.sendto(buf, dest)
            rec.pose_sends.append((t_ms, t_send))
            next_pose += ap.period_s
            if next_pose < now:  # fell behind (scheduler): do not burst to catch up
                next_pose = now + ap.period_s
        if now >= next_tel:
            ap.telemetry(now)
            next_tel += tel_period
        if now >= next_hb:
            ap.heartbeat()
            next_hb += hb_period
        flush()
    rec.cpu_s = time.process_time() - cpu0
    rec.wall_s = time.monotonic() - boot
    sock.close()
    ctrl.send(rec)
    ctrl.close()


# -- the daemon side --------------------------------------------------------------------------


class ProbeSink:
    """The real RC-override sink, stamping when each command has left.

    FlightLoop reads a pose and calls ``command`` without awaiting in between, so at that
    moment ``autopilot.state.pose`` is the pose the step used.
    """

    def __init__(self, inner: Any, autopilot: Any) -> None:
        self.inner = inner
        self.ap = autopilot
        self.steps: list[Step] = []

    @property
    def last_pwm_us(self) -> tuple[int, int, int, int]:
        pwm: tuple[int, int, int, int] = self.inner.last_pwm_us
        return pwm

    @property
    def held_channels(self) -> frozenset[int]:
        held: frozenset[int] = self.inner.held_channels
        return held

    async def start(self) -> None:
        await self.inner.start()

    def command(self, fractions: Sequence[float]) -> None:
        cmd_s = time.monotonic()
        self.inner.command(fractions)
        out_s = time.monotonic()
        pose = self.ap.state.pose
        if pose is not None:
            self.steps.append(Step(pose.time_boot_ms, pose.rx_monotonic_s, cmd_s, out_s))

    async def stop(self) -> None:
        await self.inner.stop()

    async def close(self) -> None:
        await self.inner.close()


@dataclass
class DaemonRecord:
    steps: list[Step]
    window: tuple[float, float]
    cpu_s: float
    granted_hz: dict[str, float]
    preflight: list[str]
    control_rate_max_hz: float
    fault: str | None
    waypoints_reached: int
    rx_messages: int
    loop_ended_early: bool


def _cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


async def _until(predicate: Any, ap: Any, timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise RuntimeError(f"setup: {what} not seen within {timeout_s} s")
        await ap.telemetry.next_pose(after_rx_s=None, timeout_s=0.05)


async def run_daemon_side(
    rate_hz: float,
    seconds: float,
    warmup_s: float,
    control_rate_max_hz: float | None,
    work: Path,
    spawn_autopilot: Any,
    profiler: Any = None,
) -> DaemonRecord:
    import yaml

    from helixd.actuators.rc_override import RcOverrideSink
    from helixd.base.frames import MissionFrame
    from helixd.base.plan import Numbering
    from helixd.config.load import config_to_yaml
    from helixd.config.root import HelixdConfig
    from helixd.link.connection import Autopilot
    from helixd.link.services.preflight import check_obedience
    from helixd.mission.model import Mission
    from helixd.mission.resolve import resolve_plan
    from helixd.recorder.rows import FlightRow
    from helixd.recorder.rundir import RunRecorder
    from helixd.recorder.summary import SummaryBuilder
    from helixd.report.display import ProgressDisplay
    from helixd.runtime.flight import FlightHooks, FlightLoop, PoseRejectedReport, StepReport
    from helixd.runtime.flight_report import StepJournal, rejected_progress, step_progress
    from helixd.runtime.mode_gate import MANUAL_MODE
    from helixd.runtime.signals import StopRequest

    cfg = HelixdConfig.model_validate(
        {
            "link": {
                "url": "udpin:127.0.0.1:0",
                "pose_rate_hz": min(rate_hz, POSE_RATE_REQUEST_MAX_HZ),
                "telemetry_rate_hz": TELEMETRY_RATE_HZ,
            },
            "recorder": {"run_root": str(work / "runs")},
        }
    )
    if control_rate_max_hz is None and rate_hz > cfg.control.control_rate_max_hz:
        control_rate_max_hz = rate_hz  # step on every pose, as the floor answers every pose
    if control_rate_max_hz is not None:
        control = cfg.control.model_copy(update={"control_rate_max_hz": control_rate_max_hz})
        cfg = cfg.model_copy(update={"control": control})
    laps = max(1, math.ceil((seconds + warmup_s) / LAP_ESTIMATE_S) + 1)
    mission_dict = {
        "name": "bench-square",
        "mode": "roll",
        "frame": "start",
        "waypoints": [{"x": x, "y": y} for x, y in square_laps(SQUARE_SIDE_M, laps)],
    }
    mission = Mission.model_validate(mission_dict)
    plan = resolve_plan(mission, cfg.control, cfg.mission, None)
    ap = await Autopilot.connect(cfg.link, cfg.safety)
    address = ap.local_address
    assert address is not None
    spawn_autopilot(address[1])
    recorder: RunRecorder | None = None
    try:
        await ap.wait_heartbeat(SETUP_TIMEOUT_S)
        ap.start_heartbeat()
        granted = await ap.request_streams()
        preflight = [str(p) for p in await check_obedience(ap, cfg.actuation, cfg.link)]
        await ap.action.set_mode(MANUAL_MODE)
        await ap.action.arm(force=True)
        await _until(lambda: ap.state.armed, ap, SETUP_TIMEOUT_S, "armed HEARTBEAT")
        await _until(lambda: ap.state.pose is not None, ap, SETUP_TIMEOUT_S, "a pose")
        assert ap.state.pose is not None
        start_ned = ap.state.pose.ned
        sink = ProbeSink(RcOverrideSink(cfg.actuation, cfg.vehicle, ap.action), ap)
        await sink.start()
        recorder = RunRecorder.create(
            run_root=work / "runs",
            mission_name=mission.name,
            config_yaml=config_to_yaml(cfg),
            mission_yaml=yaml.safe_dump(mission_dict),
            cfg=cfg.recorder,
            now_utc=datetime.now(UTC),
        )
        rec = recorder
        last = plan.waypoints[-1]
        summary = SummaryBuilder(final_xy_m=(last.x_m, last.y_m))
        display = ProgressDisplay(tty=False)

        def on_row(row: FlightRow) -> None:  # as the daemon's
            summary.add(row)
            display.autopilot_time(row.t_boot_s)
            rec.record(row)

        journal = StepJournal(plan, on_row, cfg.recorder.batch_interval_s)
        numbering = Numbering.of([w.via for w in mission.waypoints])  # as the daemon's

        def on_step(report: StepReport) -> None:  # as the daemon's, after the send
            journal.add(report)
            display.update(lambda: step_progress(report, numbering))

        def on_pose_rejected(report: PoseRejectedReport) -> None:
            display.update(rejected_progress(report, numbering))

        def on_arrival(index: int, t_boot_s: float, error_m: float) -> None:
            journal.drain()
            summary.arrival(index, t_boot_s, error_m)

        def on_tick() -> None:
            ap.feed()
            journal.maybe_drain(time.monotonic())
            rec.maybe_flush()

        stop = StopRequest()
        flight = FlightLoop(
            cfg=cfg,
            plan=plan,
            frame=MissionFrame.start_at(start_ned),
            autopilot=ap,
            sink=sink,
            stop=stop,
            start_ned=start_ned,
            hooks=FlightHooks(on_step, on_pose_rejected, on_arrival, on_tick),
        )
        task = asyncio.create_task(flight.run(), name="flight")
        await asyncio.wait({task}, timeout=warmup_s)  # warm-up: a timed wait, not a sync
        t0, cpu0 = time.monotonic(), _cpu_s()
        if profiler is not None:
            profiler.enable()
        await asyncio.wait({task}, timeout=seconds)
        if profiler is not None:
            profiler.disable()
        t1, cpu1 = time.monotonic(), _cpu_s()
        ended_early = task.done()
        stop.trigger("benchmark end")
        result = await task
        journal.drain()
        await sink.stop()
        fault = None
        if ended_early and result.fault is not None:  # a watchdog ended the loop, not we
            fault = f"{result.fault.cause.value}: {result.fault.detail}"
        recorder.finish(
            summary.build(
                completed=False,
                fault="benchmark end",
                exit_code=0,
                mission_name=mission.name,
                mode=mission.mode.value,
                waypoints_total=len(plan.waypoints),
            )
        )
        recorder = None
        return DaemonRecord(
            steps=sink.steps,
            window=(t0, t1),
            cpu_s=cpu1 - cpu0,
            granted_hz=granted,
            preflight=preflight,
            control_rate_max_hz=cfg.control.control_rate_max_hz,
            fault=fault,
            waypoints_reached=summary.waypoints_reached,
            rx_messages=ap.link_stats.rx_messages,
            loop_ended_early=ended_early,
        )
    finally:
        if recorder is not None:
            recorder.close()
        ap.stop_heartbeat()
        await ap.close()


# -- the floor: a bare pymavlink echo loop ------------------------------------------------------


@dataclass
class FloorRecord:
    """CPU of the least a Python daemon must do per step, measured against the same autopilot:
    read every datagram, decode it with pymavlink, and for each LOCAL_POSITION_NED encode one
    RC_CHANNELS_OVERRIDE and ``sendto`` it. No safety, no navigation, no recorder."""

    cpu_s: float
    wall_s: float
    steps: int
    t0_s: float = math.nan  # monotonic start of the window
    # autopilot rtt (pose sent -> that pose's override read back), the window's poses
    rtt_s: list[float] = field(default_factory=list)


FLOOR_OVERRIDE_US = (1500, 1500, 1500, 1500, 65535, 65535, 65535, 65535) + (0,) * 10


def floor_mav() -> Any:
    """pymavlink's codec as both floors use it (helixd's system id, robust parsing)."""
    mav = mavlink.MAVLink(None, srcSystem=LinkConfig().source_system, srcComponent=190)
    mav.robust_parsing = True
    return mav


def echo_poses(mav: Any, data: bytes, sock: socket.socket, peer: Any) -> int:
    """Decode one datagram; send one override per LOCAL_POSITION_NED in it. How many sent."""
    sent = 0
    for msg in mav.parse_buffer(data) or []:
        if msg.get_msgId() == mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED:
            out = mav.rc_channels_override_encode(1, 1, *FLOOR_OVERRIDE_US)
            sock.sendto(out.pack(mav), peer)
            sent += 1
    return sent


def floor_loop(sock: socket.socket, seconds: float, warmup_s: float) -> FloorRecord:
    """Echo an override for every pose on ``sock`` (blocking reads) for ``warmup_s`` then a
    ``seconds`` window, measured with the process CPU clock (getrusage)."""
    mav = floor_mav()
    sock.settimeout(1.0)
    peer: Any = None
    t_start = time.monotonic()
    t0 = t_start + warmup_s
    t1 = t0 + seconds
    cpu0, steps = 0.0, 0
    measuring = False
    while True:
        now = time.monotonic()
        if not measuring and now >= t0:
            measuring, cpu0, steps = True, _cpu_s(), 0
            t0 = now
        if now >= t1:
            break
        try:
            data, peer = sock.recvfrom(65536)
        except TimeoutError:
            continue
        steps += echo_poses(mav, data, sock, peer)
    return FloorRecord(cpu_s=_cpu_s() - cpu0, wall_s=time.monotonic() - t0, steps=steps, t0_s=t0)


def asyncio_floor_loop(sock: socket.socket, seconds: float, warmup_s: float) -> FloorRecord:
    """The same echo as the least asyncio program can do it: the socket watched with
    ``loop.add_reader``, every datagram decoded with pymavlink in the reader callback and the
    override sent from there (no task, no future, no timer per step). What an event loop costs
    over blocking reads on this machine, before any of helixd's own work."""

    async def echo() -> FloorRecord:
        mav = floor_mav()
        sock.setblocking(False)
        steps = [0]

        def readable() -> None:
            while True:
                try:
                    data, peer = sock.recvfrom(65536)
                except BlockingIOError:
                    return
                except ConnectionRefusedError:
                    continue
                steps[0] += echo_poses(mav, data, sock, peer)

        loop = asyncio.get_running_loop()
        loop.add_reader(sock.fileno(), readable)
        try:
            await asyncio.sleep(warmup_s)  # the window is timed, not synchronised
            t0, cpu0, steps0 = time.monotonic(), _cpu_s(), steps[0]
            await asyncio.sleep(seconds)
            return FloorRecord(
                cpu_s=_cpu_s() - cpu0,
                wall_s=time.monotonic() - t0,
                steps=steps[0] - steps0,
                t0_s=t0,
            )
        finally:
            loop.remove_reader(sock.fileno())

    return asyncio.run(echo())


def run_floor(
    rate_hz: float, seconds: float, warmup_s: float, echo: Any = floor_loop
) -> FloorRecord:
    """A floor (``echo``: :func:`floor_loop` or :func:`asyncio_floor_loop`) against a fresh
    autopilot process at ``rate_hz``."""
    ctx = multiprocessing.get_context("spawn")
    parent, child = ctx.Pipe()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    proc = ctx.Process(
        target=autopilot_main, args=(sock.getsockname()[1], rate_hz, child), daemon=True
    )
    proc.start()
    a: AutopilotRecord | None = None
    try:
        result: FloorRecord = echo(sock, seconds, warmup_s)
    finally:
        parent.send("stop")
        if parent.poll(RECORD_TIMEOUT_S):
            a = parent.recv()
        proc.join(timeout=RECORD_TIMEOUT_S)
        sock.close()
    if a is None:
        return result
    t0, t1 = result.t0_s, result.t0_s + result.wall_s
    sends = [t for _, t in a.pose_sends if t0 <= t < t1]
    rtt = first_responses(sends, in_window(a.override_arrivals, t0, t1 + 1.0))
    return replace(result, rtt_s=[dt for dt in rtt if dt is not None])


def floor_figures(
    d_cpu_s: float, d_steps: int, wall_s: float, floor: FloorRecord | None, prefix: str = ""
) -> dict[str, float | None]:
    """CPU % of the floor and the daemon's CPU per step over the floor's (same run)."""
    p = prefix
    if floor is None or floor.wall_s <= 0 or floor.steps == 0 or floor.cpu_s <= 0:
        return {
            f"{p}floor_cpu_percent": None,
            f"ratio_to_{p}floor": None,
            f"{p}floor_us_per_step": None,
        }
    per_step = floor.cpu_s / floor.steps
    daemon_per_step = d_cpu_s / d_steps if d_steps else math.nan
    return {
        f"{p}floor_cpu_percent": 100.0 * floor.cpu_s / floor.wall_s,
        f"{p}floor_us_per_step": 1e6 * per_step,
        "daemon_us_per_step": 1e6 * daemon_per_step if d_steps else None,
        f"ratio_to_{p}floor": daemon_per_step / per_step if d_steps else None,
    }


# -- report -----------------------------------------------------------------------------------


def report_lines(
    d: DaemonRecord,
    a: AutopilotRecord,
    rate_hz: float,
    floor: FloorRecord | None = None,
    afloor: FloorRecord | None = None,
) -> list[str]:
    t0, t1 = d.window
    wall = t1 - t0
    period = 1.0 / rate_hz
    steps = [s for s in d.steps if t0 <= s.out_s < t1]
    sends = [(tb, t) for tb, t in a.pose_sends if t0 <= t < t1]
    lat = match_latencies(dict(a.pose_sends), steps)
    jitter = stats(interval_deviations([s.out_s for s in steps], period))
    send_jitter = stats(interval_deviations([t for _, t in sends], period))
    rtt = stats(daemon_rtt_s(d, a))
    total = stats(lat.total_s)
    cpu_pct = 100.0 * d.cpu_s / wall if wall > 0 else math.nan
    cpu_target = cpu_target_percent(rate_hz)
    fl = floor_figures(d.cpu_s, len(steps), wall, floor)
    lines = [
        f"control-loop benchmark: {rate_hz:g} Hz poses, {wall:.1f} s window, "
        f"{len(sends)} poses sent, {len(steps)} control steps "
        f"({len(sends) - len(steps)} poses not stepped), {lat.unmatched} steps unmatched, "
        f"control.control_rate_max_hz {d.control_rate_max_hz:g}",
        "granted: " + ", ".join(f"{k} {v:g} Hz" for k, v in d.granted_hz.items()),
    ]
    if d.preflight:
        lines.append("preflight: " + "; ".join(d.preflight))
    if d.fault or d.loop_ended_early:
        lines.append(
            f"WARNING: the flight loop ended inside the window ({d.fault or 'mission done'})"
        )
    p99_ok = total is not None and total.p99 * 1e3 < TARGET_LATENCY_P99_MS
    jit_ok = jitter is not None and jitter.p99 * 1e3 < TARGET_JITTER_P99_MS
    lines += [
        "",
        format_stats_ms(
            "latency pose sent -> override sent",
            total,
            f"target p99 < {TARGET_LATENCY_P99_MS:g} ms: {verdict(p99_ok)}",
        ),
        format_stats_ms("  wire (sent -> link rx stamp)", stats(lat.wire_s)),
        format_stats_ms("  in daemon (rx stamp -> sent)", stats(lat.inside_s)),
        format_stats_ms("    wake + compute (safety, nav)", stats(lat.compute_s)),
        format_stats_ms("    sink.command incl. sendto", stats(lat.send_s)),
        format_stats_ms("  autopilot rtt (pose -> override)", rtt),
        format_stats_ms(
            f"loop jitter |step interval - {period * 1e3:g} ms|",
            jitter,
            f"target p99 < {TARGET_JITTER_P99_MS:g} ms: {verdict(jit_ok)}",
        ),
        format_stats_ms("  autopilot send jitter (reference)", send_jitter),
        format_stats_ms(
            "  added by the daemon |Δ latency|",
            stats([abs(b - a) for a, b in itertools.pairwise(lat.total_s)]),
        ),
        f"{'CPU (daemon side, user+sys)':<{LABEL_WIDTH}} {cpu_pct:6.2f} % of one core"
        f"  target < {cpu_target:g} %: {verdict(cpu_pct < cpu_target)}"
        f"   ({d.cpu_s:.3f} CPU s in {wall:.1f} s; autopilot process: "
        f"{100.0 * a.cpu_s / a.wall_s:.1f} %)",
    ]
    if fl["ratio_to_floor"] is not None and floor is not None:
        ratio = fl["ratio_to_floor"]
        lines += [
            f"{'floor: bare pymavlink echo loop':<{LABEL_WIDTH}} {fl['floor_cpu_percent']:6.2f} %"
            f" of one core ({floor.cpu_s:.3f} CPU s, {floor.steps} overrides in "
            f"{floor.wall_s:.1f} s: {fl['floor_us_per_step']:.0f} us/step)",
            format_stats_ms("  floor autopilot rtt (pose -> override)", stats(floor.rtt_s)),
            f"{'daemon CPU per step / floor':<{LABEL_WIDTH}} {ratio:6.2f} x"
            f"  ({fl['daemon_us_per_step']:.0f} us/step)"
            f"  target <= {TARGET_RATIO_TO_FLOOR:g} x: {verdict(ratio <= TARGET_RATIO_TO_FLOOR)}",
        ]
    afl = floor_figures(d.cpu_s, len(steps), wall, afloor, ASYNCIO_PREFIX)
    if afl[f"ratio_to_{ASYNCIO_PREFIX}floor"] is not None and afloor is not None:
        lines += [
            f"{'  same echo as an asyncio program':<{LABEL_WIDTH}}"
            f" {afl[f'{ASYNCIO_PREFIX}floor_cpu_percent']:6.2f} %"
            f" of one core ({afloor.cpu_s:.3f} CPU s, {afloor.steps} overrides in "
            f"{afloor.wall_s:.1f} s: {afl[f'{ASYNCIO_PREFIX}floor_us_per_step']:.0f} us/step)",
            format_stats_ms("    its autopilot rtt (pose -> override)", stats(afloor.rtt_s)),
            f"{'  daemon CPU per step / asyncio echo':<{LABEL_WIDTH}}"
            f" {afl[f'ratio_to_{ASYNCIO_PREFIX}floor']:6.2f} x",
        ]
    lines += [
        f"{'':<{LABEL_WIDTH}} {d.rx_messages} messages received, "
        f"{a.overrides} overrides at the autopilot, "
        f"{d.waypoints_reached} waypoints reached",
    ]
    return lines


def daemon_rtt_s(d: DaemonRecord, a: AutopilotRecord) -> list[float]:
    """Autopilot rtt of the window's stepped poses: pose sent -> its override read back (s)."""
    t0, t1 = d.window
    stepped = {s.time_boot_ms for s in d.steps if t0 <= s.out_s < t1}
    sends = [(tb, t) for tb, t in a.pose_sends if t0 <= t < t1]
    arrivals = in_window(a.override_arrivals, t0, t1 + 1.0)
    responses = first_responses([t for _, t in sends], arrivals)
    return [
        dt for (tb, _), dt in zip(sends, responses, strict=True) if dt is not None and tb in stepped
    ]


def _ms(s: Stats | None) -> dict[str, float | int | None]:
    if s is None:
        return {"n": 0, "p50": None, "p99": None, "max": None}
    return {"n": s.n, "p50": s.p50 * 1e3, "p99": s.p99 * 1e3, "max": s.max * 1e3}


def rate_figures(
    d: DaemonRecord,
    a: AutopilotRecord,
    rate_hz: float,
    floor: FloorRecord | None = None,
    afloor: FloorRecord | None = None,
) -> dict[str, Any]:
    """The figures :func:`report_lines` prints, as JSON-ready numbers (ms, %)."""
    t0, t1 = d.window
    wall = t1 - t0
    steps = [s for s in d.steps if t0 <= s.out_s < t1]
    sends = [(tb, t) for tb, t in a.pose_sends if t0 <= t < t1]
    lat = match_latencies(dict(a.pose_sends), steps)
    jitter = stats(interval_deviations([s.out_s for s in steps], 1.0 / rate_hz))
    return {
        "rate_hz": rate_hz,
        "window_s": wall,
        "latency_ms": _ms(stats(lat.total_s)),
        "latency_in_daemon_ms": _ms(stats(lat.inside_s)),
        "autopilot_rtt_ms": _ms(stats(daemon_rtt_s(d, a))),
        "jitter_ms": _ms(jitter),
        "cpu_percent": 100.0 * d.cpu_s / wall if wall > 0 else None,
        "cpu_s": d.cpu_s,
        **floor_figures(d.cpu_s, len(steps), wall, floor),
        **floor_figures(d.cpu_s, len(steps), wall, afloor, ASYNCIO_PREFIX),
        "floor_rtt_ms": _ms(stats(floor.rtt_s)) if floor else None,
        f"{ASYNCIO_PREFIX}floor_rtt_ms": _ms(stats(afloor.rtt_s)) if afloor else None,
        "cpu_target_percent": cpu_target_percent(rate_hz),
        "autopilot_cpu_percent": 100.0 * a.cpu_s / a.wall_s if a.wall_s > 0 else None,
        "poses_sent": len(sends),
        "control_steps": len(steps),
        "poses_not_stepped": len(sends) - len(steps),
        "control_rate_max_hz": d.control_rate_max_hz,
        "fault": d.fault,
        "loop_ended_early": d.loop_ended_early,
    }


def results_section(per_rate: dict[str, dict[str, Any]], seconds: float) -> dict[str, Any]:
    """The ``control_loop`` section of bench/results/latest.json: the headline figures keyed
    by what they are, then by rate (``latency_ms.p99["50"]``), and every figure per rate."""

    def by_rate(*path: str) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for rate, fig in per_rate.items():
            value: Any = fig
            for key in path:
                value = value.get(key) if isinstance(value, dict) else None
            out[rate] = value
        return out

    return {
        "latency_ms": {q: by_rate("latency_ms", q) for q in ("p50", "p99", "max")},
        "jitter_ms": {"p99": by_rate("jitter_ms", "p99")},
        "cpu_percent": by_rate("cpu_percent"),
        "floor_cpu_percent": by_rate("floor_cpu_percent"),
        "ratio_to_floor": by_rate("ratio_to_floor"),
        f"{ASYNCIO_PREFIX}floor_cpu_percent": by_rate(f"{ASYNCIO_PREFIX}floor_cpu_percent"),
        f"ratio_to_{ASYNCIO_PREFIX}floor": by_rate(f"ratio_to_{ASYNCIO_PREFIX}floor"),
        "per_rate": per_rate,
        "targets": {
            "latency_p99_ms": TARGET_LATENCY_P99_MS,
            "jitter_p99_ms": TARGET_JITTER_P99_MS,
            "cpu_percent": {rate_key(r): c for r, c in TARGET_CPU_POINTS},
            "ratio_to_floor": TARGET_RATIO_TO_FLOOR,
        },
        "meta": {
            "window_s": seconds,
            "finished_utc": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "cpu_count": os.cpu_count(),
            # the machine's load while measuring (other work shares the cores; CPU figures are
            # process CPU seconds, robust to that, latencies are not)
            "loadavg_1min": round(os.getloadavg()[0], 2),
        },
    }


def rate_key(rate_hz: float) -> str:
    return f"{rate_hz:g}"


def run_benchmark(
    rate_hz: float,
    seconds: float,
    warmup_s: float,
    control_rate_max_hz: float | None,
    floor: bool = True,
    profiler: Any = None,
    event_loop: str = "asyncio",
) -> tuple[list[str], dict[str, Any]]:
    from helixd.recorder.logging_setup import configure_logging
    from helixd.runtime import eventloop

    ctx = multiprocessing.get_context("spawn")
    parent, child = ctx.Pipe()
    procs: list[multiprocessing.process.BaseProcess] = []

    def spawn(port: int) -> None:
        proc = ctx.Process(target=autopilot_main, args=(port, rate_hz, child), daemon=True)
        proc.start()
        procs.append(proc)

    with tempfile.TemporaryDirectory(prefix="helixd-bench-loop-") as tmp:
        work = Path(tmp)
        with (work / "daemon.log").open("w", encoding="utf-8") as log_fh:
            configure_logging(tty=False, level="info", stream=log_fh)
            try:
                d = eventloop.run(
                    run_daemon_side(
                        rate_hz, seconds, warmup_s, control_rate_max_hz, work, spawn, profiler
                    ),
                    "uvloop" if event_loop == "uvloop" else "asyncio",
                )
            finally:
                if procs and procs[0].is_alive():
                    parent.send("stop")
            if not parent.poll(RECORD_TIMEOUT_S):
                raise RuntimeError("the autopilot process sent no record (did it crash?)")
            a: AutopilotRecord = parent.recv()
            for proc in procs:
                proc.join(timeout=RECORD_TIMEOUT_S)
    fl = run_floor(rate_hz, seconds, warmup_s) if floor else None
    afl = run_floor(rate_hz, seconds, warmup_s, asyncio_floor_loop) if floor else None
    figures = rate_figures(d, a, rate_hz, fl, afl)
    figures["event_loop"] = event_loop
    lines = [f"event loop: {event_loop}", *report_lines(d, a, rate_hz, fl, afl)]
    return lines, figures


def _pct(v: Any) -> str:
    return "-" if v is None else f"{v:.2f} %"


def _num(v: Any, spec: str = ".0f") -> str:
    return "-" if v is None else format(v, spec)


def event_loops(choices: list[str]) -> list[str]:
    """The loops to measure, in order: the given ones (uvloop only when installed), by default
    asyncio (the daemon's default: the headline) then uvloop (when installed), in one run."""
    from helixd.runtime.eventloop import uvloop_available

    wanted = choices or ["asyncio", "uvloop"]
    bad = [c for c in wanted if c not in ("uvloop", "asyncio")]
    if bad:
        raise ValueError(f"--event-loop {bad[0]!r}: expected uvloop or asyncio")
    return [c for c in dict.fromkeys(wanted) if c != "uvloop" or uvloop_available()]


def loop_comparison(per_loop: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per event loop, the figures the adoption decision reads: CPU %, CPU per step,
    autopilot round trip p99, poses not stepped."""
    out: dict[str, dict[str, Any]] = {}
    for loop, fig in per_loop.items():
        steps = fig.get("control_steps") or 0
        cpu_s = fig.get("cpu_s")
        out[loop] = {
            "cpu_percent": fig.get("cpu_percent"),
            "cpu_us_per_step": 1e6 * cpu_s / steps if steps and cpu_s is not None else None,
            "autopilot_rtt_p99_ms": (fig.get("autopilot_rtt_ms") or {}).get("p99"),
            "poses_not_stepped": fig.get("poses_not_stepped"),
        }
    return out


def main(
    seconds: float = typer.Option(30.0, min=1.0, max=3600.0, help="measurement window (s)"),
    rate_hz: list[float] = typer.Option(  # noqa: B008 - typer's idiom
        [50.0], min=5.0, max=MAX_RATE_HZ, help="pose rate = control rate (Hz); repeatable"
    ),
    warmup_s: float = typer.Option(3.0, min=0.0, max=60.0, help="flying before the window (s)"),
    control_rate_max_hz: float | None = typer.Option(
        None, help="override control.control_rate_max_hz (default: the daemon's default)"
    ),
    floor: bool = typer.Option(
        True,
        help="also measure the floor (a bare pymavlink echo loop, blocking and as an asyncio "
        "program) and the ratios to it",
    ),
    profile: int = typer.Option(
        0, min=0, help="run under cProfile and print the top N functions (inflates the figures)"
    ),
    results_dir: Path | None = typer.Option(  # noqa: B008 - typer's idiom
        None,
        help="where latest.json / latest.md are written (default bench/results; not written "
        "with --profile)",
    ),
    event_loop: list[str] = typer.Option(  # noqa: B008 - typer's idiom
        [],
        help="the daemon side's event loop, repeatable: asyncio, uvloop (default: both, asyncio "
        "first; uvloop when installed); the first one's figures are the headline",
    ),
) -> None:
    """Measure pose-in → command-out latency, loop jitter and CPU of helixd's control loop."""
    try:
        loops = event_loops(event_loop)
    except ValueError as exc:
        raise typer.BadParameter(str(exc)) from None
    per_rate: dict[str, dict[str, Any]] = {}
    for i, rate in enumerate(rate_hz):
        if i:
            typer.echo("")
        per_loop: dict[str, dict[str, Any]] = {}
        for loop in loops[1:] if not profile else []:  # the others first: the headline last
            lines, figures = run_benchmark(
                rate, seconds, warmup_s, control_rate_max_hz, False, None, loop
            )
            per_loop[loop] = figures
            for line in lines:
                typer.echo(line)
            typer.echo("")
        if profile:
            import cProfile
            import io
            import pstats

            # the measurement window only, timed by this thread's CPU clock (what the CPU
            # figure counts; a wall-clock profile charges the waits for a loaded core to
            # whatever ran when the scheduler preempted it)
            prof = cProfile.Profile(time.thread_time)
            lines, figures = run_benchmark(
                rate, seconds, warmup_s, control_rate_max_hz, False, prof, loops[0]
            )
            buf = io.StringIO()
            prof.dump_stats(Path(tempfile.gettempdir()) / "helixd-bench-loop.prof")
            pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(profile)
            lines += [
                "",
                "cProfile (daemon process, the measurement window, thread CPU time), by tottime"
                f" (all of it: {Path(tempfile.gettempdir()) / 'helixd-bench-loop.prof'}):",
                buf.getvalue(),
            ]
        else:
            lines, figures = run_benchmark(
                rate, seconds, warmup_s, control_rate_max_hz, floor, None, loops[0]
            )
        per_loop = {loops[0]: figures, **per_loop}
        figures["event_loops"] = loop_comparison(per_loop)
        if len(per_loop) > 1:
            lines.append(
                "event loops, same run: "
                + "; ".join(
                    f"{name} CPU {_pct(c['cpu_percent'])}, {_num(c['cpu_us_per_step'])} µs/step, "
                    f"rtt p99 {_num(c['autopilot_rtt_p99_ms'], '.2f')} ms"
                    for name, c in figures["event_loops"].items()
                )
            )
        per_rate[rate_key(rate)] = figures
        for line in lines:
            typer.echo(line)
    if profile:
        return
    import sys

    tools_dir = str(Path(__file__).resolve().parent)
    if tools_dir not in sys.path:
        sys.path.insert(0, tools_dir)
    from bench_results import RESULTS_DIR, write_section

    path = write_section(
        "control_loop", results_section(per_rate, seconds), results_dir or RESULTS_DIR
    )
    typer.echo(f"written to {path} and latest.md")
    unmeasured = measured_nothing(per_rate)
    if unmeasured:
        typer.echo("MEASURED NOTHING: " + "; ".join(unmeasured), err=True)
        raise typer.Exit(1)


def measured_nothing(per_rate: dict[str, dict[str, Any]]) -> list[str]:
    """Why a rate's figures measure nothing (no control step in the window, or the flight
    loop ended inside it): one line per such rate."""
    out: list[str] = []
    for rate, fig in per_rate.items():
        if not fig.get("control_steps"):
            out.append(f"{rate} Hz: no control step in the window")
        elif fig.get("loop_ended_early"):
            out.append(f"{rate} Hz: the flight loop ended inside the window ({fig.get('fault')})")
    return out


if __name__ == "__main__":
    typer.run(main)
