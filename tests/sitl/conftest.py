"""Fixtures for the opt-in real ArduPilot Rover SITL suite.

Set ``HELIXD_SITL_BIN`` to an ``ardurover`` SITL binary (``./waf configure --board sitl &&
./waf rover`` → ``build/sitl/bin/ardurover``); without it every test here is skipped with a
one-line reason. Per test, the ``sitl`` fixture starts

    ardurover --model rover-skid --defaults tests/sitl/helix-skid.parm -I <n> --speedup <s>
              --home <CMAC> --wipe

in the test's temp dir, with the real helixd-guard.lua in ``scripts/`` of that working
directory (helix-skid.parm sets ``SCR_ENABLE 1``, so ardurover loads it at boot), waits
(bounded) for SERIAL0 (tcp 5760+10·n) to accept and send its first HEARTBEAT, attaches an
*observer* on SERIAL1 (tcp 5762+10·n), waits until the EKF has a GPS position and checks that
the guard's HXG_VERSION parameter exists. The observer never sends a HEARTBEAT and uses system
id 250, so ArduPilot's GCS failsafe (keyed on MAV_GCS_SYSID 247 = helixd, set in
helix-skid.parm), its RC-override rule and helixd-guard see helixd alone; it reads HEARTBEAT /
SERVO_OUTPUT_RAW / LOCAL_POSITION_NED / ATTITUDE and can switch modes or set params.
The pilot's radio is SITL's RC-input UDP port (5501+10·n: 8 or 16 little-endian uint16 PWM,
0 = leave that channel unchanged).

Facts from ArduPilot's source that the suite relies on:

* libraries/SITL/SIM_Rover.cpp, skid model: motor1 = output 1 (left), motor2 = output 3
  (right), m = (pwm − 1500)/500; target speed = ½(m1+m2)·4 m/s, yaw rate = (m1−m2)·140 °/s,
  clockwise positive (body z down). Outputs 2 and 4 are not read.
* AP_HAL_SITL/SITL_cmdline.cpp: ``-I n`` adds 10·n to every port; SERIAL0 waits for a client
  before the vehicle boots; RC inputs start at 1500 on channels 1–4 for Rover.
* Helix eq. 2 with yaw CCW positive: ω1 = (vx + k·wz)/r is the *right-hand* side of a
  skid-steer (it speeds up for a left turn) and ω3 = −(vx − k·wz)/r the left-hand side turning
  the other way. So scroll 1 drives output 3 (right motor) and scroll 3, reversed, drives
  output 1 (left motor); scrolls 2 and 4 ride on outputs 4 and 2, which the model ignores.
  Mapping scroll 1 to output 1 instead inverts the yaw response (positive feedback).
"""

from __future__ import annotations

import functools
import itertools
import math
import os
import re
import signal
import socket
import struct
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import pytest
import yaml
from pymavlink.dialects.v20 import ardupilotmega as mavlink2  # MAVLink 2 framing

from helixd.mav.constants import EKF_POS_HORIZ_ABS
from helixd.mav.guard_script import (
    HXG_VERSION,
    POSIX_SCRIPTS_DIR,
    SCRIPT_NAME,
    VERSION,
    script_bytes,
)
from tests.support.daemon import DaemonProc, spawn_daemon
from tests.support.helix_sitl import SITL_GROUND
from tests.support.paths import REPO_ROOT
from tests.support.skid_setup import HELIXD_SYSID, helixd_sitl_config

T = TypeVar("T")

ROOT = REPO_ROOT
PARM_FILE = Path(__file__).resolve().parent / "helix-skid.parm"
# A real Helix's parameters, then what SITL itself needs (the Helix plant, --model JSON)
HELIX_PARM_FILES = (
    ROOT / "config" / "ardupilot" / "helix.parm",
    Path(__file__).resolve().parent / "helix-json.parm",
)
SQUARE_MISSION = ROOT / "config" / "missions" / "square.yaml"

SITL_BIN_ENV = "HELIXD_SITL_BIN"
SPEEDUP_ENV = "HELIXD_SITL_SPEEDUP"  # simulated seconds per wall second (default 1)
INSTANCE_BASE_ENV = "HELIXD_SITL_INSTANCE_BASE"  # first -I instance to try (default 0)
DEFAULT_SPEEDUP = 1.0
MAX_SPEEDUP = 10.0  # helixd's control loop runs on wall time; beyond this it falls behind

# SITL ports (AP_HAL_SITL/SITL_cmdline.cpp); every one moves by 10 per instance.
SERIAL0_PORT = 5760  # helixd's link; SITL waits here for a client before it boots
SERIAL1_PORT = 5762  # the observer (a second GCS link)
SERIAL2_PORT = 5763
RCIN_PORT = 5501  # UDP: the simulated pilot's radio
PORT_STRIDE = 10
INSTANCES_PER_WORKER = 5  # -I values rotate so a just-killed SITL's ports are not reused at once
RC_INPUT_CHANNELS = 16

HOME = "-35.363261,149.165230,584,0"  # CMAC (SITL's default field), facing north
# the built-in simulator's default origin (the thesis's field), where the example pond's media
# map (config/maps/pond-media.geojson) lies
POND_HOME = "53.52325,-113.52632,668,0"

AUTOPILOT_SYSID = 1
AUTOPILOT_COMPID = 1
OBSERVER_SYSID = 250  # not the GCS sysid: its commands work, its overrides and silence don't
OBSERVER_COMPID = 190

MODE_HOLD = 4
MAV_MODE_FLAG_SAFETY_ARMED = 128
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1
GPS_FIX_3D = 3

NEUTRAL_US = 1500
HELIX_THROTTLE_CHANNEL = 5  # config/ardupilot/helix.parm RCMAP_THROTTLE
OUTPUT_TOLERANCE_US = 5  # SERVO_OUTPUT_RAW vs an expected PWM
DRIVING_DEFLECTION_US = 30  # |output − 1500| that counts as "the scrolls are driving"

# Wall-clock bounds (s). Generous: a loaded 2-core box boots SITL slowly.
BOOT_TIMEOUT_S = 60.0  # process start → first HEARTBEAT on SERIAL0
READY_TIMEOUT_S = 180.0  # → GPS 3D fix and an EKF absolute position
CONNECT_TIMEOUT_S = 30.0  # a TCP port to accept
COMMAND_TIMEOUT_S = 3.0  # per COMMAND_ACK / PARAM_VALUE try
COMMAND_TRIES = 3
STREAM_RATE_HZ = 10.0  # observer message rates (accepted: ≥ 1.25 × the 50 Hz loop period)
FAST_STREAM_RATE_HZ = 20.0  # SERVO_OUTPUT_RAW and HEARTBEAT: when outputs and mode change
SITL_STOP_TIMEOUT_S = 10.0
DAEMON_STOP_TIMEOUT_S = 15.0

# ---------------------------------------------------------------------------------------------
# Skip without a binary


def sitl_skip_reason() -> str | None:
    value = os.environ.get(SITL_BIN_ENV, "")
    if not value:
        return f"real ArduPilot SITL tests need {SITL_BIN_ENV}=/path/to/ardurover (unset)"
    path = Path(value)
    if not path.is_file() or not os.access(path, os.X_OK):
        return f"{SITL_BIN_ENV}={value} is not an executable file"
    return None


@pytest.fixture(autouse=True)
def _require_sitl_binary() -> None:
    reason = sitl_skip_reason()
    if reason is not None:
        pytest.skip(reason)


def sitl_speedup() -> float:
    raw = os.environ.get(SPEEDUP_ENV, "")
    if not raw:
        return DEFAULT_SPEEDUP
    try:
        value = float(raw)
    except ValueError:
        raise pytest.UsageError(f"{SPEEDUP_ENV}={raw!r} is not a number") from None
    if not 0.1 <= value <= MAX_SPEEDUP:
        raise pytest.UsageError(f"{SPEEDUP_ENV}={raw} outside 0.1 .. {MAX_SPEEDUP:g}")
    return value


# ---------------------------------------------------------------------------------------------
# A MAVLink client on one SITL TCP port


@dataclass(frozen=True, slots=True)
class ServoSample:
    t_boot_s: float  # SERVO_OUTPUT_RAW.time_usec: autopilot (simulated) time
    wall_s: float  # time.monotonic() on receipt
    pwm_us: tuple[int, int, int, int]  # outputs 1..4


@dataclass(frozen=True, slots=True)
class PositionSample:
    t_boot_s: float
    north_m: float
    east_m: float


Sample = TypeVar("Sample", ServoSample, PositionSample)


@dataclass
class MavClient:
    """Reads one TCP link in a thread; keeps the autopilot's latest message of each type, the
    SERVO_OUTPUT_RAW and LOCAL_POSITION_NED histories, acks, params and STATUSTEXTs."""

    sock: socket.socket
    name: str
    mav: Any = field(init=False)
    latest: dict[str, Any] = field(default_factory=dict)
    servo: list[ServoSample] = field(default_factory=list)
    positions: list[PositionSample] = field(default_factory=list)
    attitudes: list[tuple[float, float]] = field(default_factory=list)  # (t_boot s, yaw NED rad)
    acks: list[tuple[int, int]] = field(default_factory=list)  # (command, result)
    params: dict[str, float] = field(default_factory=dict)
    statustexts: list[str] = field(default_factory=list)
    mode_changes: list[tuple[float, int]] = field(default_factory=list)  # (monotonic s, mode)
    helixd_heartbeat_wall_s: float | None = None
    gps_rx_wall_s: float | None = None  # time.monotonic() of the latest GPS_RAW_INT
    closed_reason: str | None = None
    _cond: threading.Condition = field(
        default_factory=lambda: threading.Condition(threading.RLock())
    )
    _send_lock: threading.Lock = field(default_factory=threading.Lock)
    _thread: threading.Thread | None = None

    def __post_init__(self) -> None:
        self.mav = mavlink2.MAVLink(None, srcSystem=OBSERVER_SYSID, srcComponent=OBSERVER_COMPID)
        self.mav.robust_parsing = True
        self._parser = mavlink2.MAVLink(None)
        self._parser.robust_parsing = True
        self.sock.settimeout(0.2)
        self._thread = threading.Thread(target=self._reader, name=f"mav-{self.name}", daemon=True)
        self._thread.start()

    @classmethod
    def connect(
        cls, port: int, name: str, timeout_s: float, alive: Callable[[], str | None]
    ) -> MavClient:
        return cls(connect_tcp(port, timeout_s, alive), name)

    # -- reading --------------------------------------------------------------------------

    def _reader(self) -> None:
        while True:
            try:
                data = self.sock.recv(65536)
            except TimeoutError:
                continue
            except OSError as exc:
                self._close(f"socket error: {exc}")
                return
            if not data:
                self._close("closed by SITL")
                return
            for msg in self._parser.parse_buffer(data) or ():
                self._handle(msg)

    def _close(self, reason: str) -> None:
        with self._cond:
            if self.closed_reason is None:
                self.closed_reason = reason
            self._cond.notify_all()

    def _handle(self, msg: Any) -> None:
        kind = str(msg.get_type())
        src = (int(msg.get_srcSystem()), int(msg.get_srcComponent()))
        with self._cond:
            if kind == "HEARTBEAT" and src[0] == HELIXD_SYSID:
                self.helixd_heartbeat_wall_s = time.monotonic()
            if src[0] != AUTOPILOT_SYSID:
                return  # ArduPilot forwards other systems' broadcasts (helixd's HEARTBEAT)
            if kind == "HEARTBEAT" and src[1] != AUTOPILOT_COMPID:
                return
            if kind == "HEARTBEAT":
                mode = int(msg.custom_mode)
                if not self.mode_changes or self.mode_changes[-1][1] != mode:
                    self.mode_changes.append((time.monotonic(), mode))
            self.latest[kind] = msg
            if kind == "SERVO_OUTPUT_RAW":
                self.servo.append(
                    ServoSample(
                        t_boot_s=int(msg.time_usec) / 1e6,
                        wall_s=time.monotonic(),
                        pwm_us=(
                            int(msg.servo1_raw),
                            int(msg.servo2_raw),
                            int(msg.servo3_raw),
                            int(msg.servo4_raw),
                        ),
                    )
                )
            elif kind == "LOCAL_POSITION_NED":
                self.positions.append(
                    PositionSample(int(msg.time_boot_ms) / 1e3, float(msg.x), float(msg.y))
                )
            elif kind == "GPS_RAW_INT":
                self.gps_rx_wall_s = time.monotonic()
            elif kind == "ATTITUDE":
                self.attitudes.append((int(msg.time_boot_ms) / 1e3, float(msg.yaw)))
            elif kind == "COMMAND_ACK":
                target = int(getattr(msg, "target_system", 0) or 0)
                if target in (0, OBSERVER_SYSID):
                    self.acks.append((int(msg.command), int(msg.result)))
            elif kind == "PARAM_VALUE":
                self.params[str(msg.param_id)] = float(msg.param_value)
            elif kind == "STATUSTEXT":
                self.statustexts.append(str(msg.text))
            self._cond.notify_all()

    # -- waiting --------------------------------------------------------------------------

    def wait_value(
        self,
        probe: Callable[[], T | None],
        timeout_s: float,
        what: str,
        abort: Callable[[], str | None] | None = None,
    ) -> T:
        """Block until ``probe()`` returns a value (not None); fail after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while True:
                value = probe()
                if value is not None:
                    return value
                reason = abort() if abort is not None else None
                if reason is None and self.closed_reason is not None:
                    reason = f"{self.name} link {self.closed_reason}"
                if reason is not None:
                    raise AssertionError(f"while waiting for {what}: {reason}; {self.describe()}")
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise AssertionError(
                        f"timed out after {timeout_s:g} s waiting for {what}; {self.describe()}"
                    )
                self._cond.wait(min(remaining, 0.2))

    def wait_until(
        self,
        condition: Callable[[], bool],
        timeout_s: float,
        what: str,
        abort: Callable[[], str | None] | None = None,
    ) -> None:
        self.wait_value(lambda: True if condition() else None, timeout_s, what, abort)

    # -- typed views ----------------------------------------------------------------------

    def mode(self) -> int | None:
        hb = self.latest.get("HEARTBEAT")
        return None if hb is None else int(hb.custom_mode)

    def armed(self) -> bool | None:
        hb = self.latest.get("HEARTBEAT")
        return None if hb is None else bool(int(hb.base_mode) & MAV_MODE_FLAG_SAFETY_ARMED)

    def _last(self, samples: list[Sample]) -> Sample | None:
        with self._cond:
            return samples[-1] if samples else None

    def _since(self, samples: list[Sample], t_boot_s: float) -> list[Sample]:
        """The samples stamped at or after ``t_boot_s`` (autopilot time)."""
        with self._cond:
            return [s for s in samples if s.t_boot_s >= t_boot_s]

    def servo_pwm(self) -> tuple[int, int, int, int] | None:
        last = self._last(self.servo)
        return None if last is None else last.pwm_us

    def last_servo(self) -> ServoSample | None:
        return self._last(self.servo)

    def servo_since(self, t_boot_s: float) -> list[ServoSample]:
        return self._since(self.servo, t_boot_s)

    def position(self) -> PositionSample | None:
        return self._last(self.positions)

    def positions_since(self, t_boot_s: float) -> list[PositionSample]:
        return self._since(self.positions, t_boot_s)

    def yaw_at(self, t_boot_s: float) -> float | None:
        """ATTITUDE yaw (NED, clockwise from North) last reported at or before ``t_boot_s``."""
        with self._cond:
            before = [yaw for t, yaw in self.attitudes if t <= t_boot_s]
            return before[-1] if before else None

    def ekf_has_position(self) -> bool:
        ekf = self.latest.get("EKF_STATUS_REPORT")
        gps = self.latest.get("GPS_RAW_INT")
        return (
            ekf is not None
            and gps is not None
            and bool(int(ekf.flags) & EKF_POS_HORIZ_ABS)
            and int(gps.fix_type) >= GPS_FIX_3D
            and "LOCAL_POSITION_NED" in self.latest
        )

    def describe(self) -> str:
        with self._cond:
            ekf = self.latest.get("EKF_STATUS_REPORT")
            gps = self.latest.get("GPS_RAW_INT")
            return (
                f"autopilot: mode={self.mode()} armed={self.armed()} "
                f"servo1..4={self.servo_pwm()} "
                f"ekf_flags={None if ekf is None else int(ekf.flags)} "
                f"gps_fix={None if gps is None else int(gps.fix_type)} "
                f"statustext={self.statustexts[-5:]}"
            )

    # -- sending --------------------------------------------------------------------------

    def send(self, msg: Any) -> None:
        data = msg.pack(self.mav)
        with self._send_lock:
            self.sock.sendall(data)

    def _ack_since(self, seen: int, command: int) -> int | None:
        return next((r for c, r in self.acks[seen:] if c == command), None)

    def command_long(self, command: int, params: tuple[float, ...]) -> int:
        """Send COMMAND_LONG (re-sent up to COMMAND_TRIES times); return the ack's result."""
        padded = (*params, *(0.0,) * (7 - len(params)))
        for attempt in range(COMMAND_TRIES):
            with self._cond:
                seen = len(self.acks)
            self.send(
                self.mav.command_long_encode(
                    AUTOPILOT_SYSID, AUTOPILOT_COMPID, command, attempt, *padded
                )
            )
            try:
                return self.wait_value(
                    functools.partial(self._ack_since, seen, command),
                    COMMAND_TIMEOUT_S,
                    f"COMMAND_ACK for command {command}",
                )
            except AssertionError:
                if attempt == COMMAND_TRIES - 1 or self.closed_reason is not None:
                    raise
        raise AssertionError("unreachable")

    def set_mode(self, mode: int) -> int:
        return self.command_long(
            mavlink2.MAV_CMD_DO_SET_MODE, (float(MAV_MODE_FLAG_CUSTOM_MODE_ENABLED), float(mode))
        )

    def set_message_interval(self, msg_id: int, rate_hz: float) -> None:
        result = self.command_long(
            mavlink2.MAV_CMD_SET_MESSAGE_INTERVAL, (float(msg_id), 1e6 / rate_hz)
        )
        assert result == mavlink2.MAV_RESULT_ACCEPTED, (
            f"SET_MESSAGE_INTERVAL({msg_id}, {rate_hz} Hz) refused: result {result}"
        )

    def get_param(self, name: str) -> float | None:
        """PARAM_REQUEST_READ by name; None when the autopilot does not answer (no such
        parameter: ArduPilot stays silent)."""
        for _ in range(COMMAND_TRIES):
            with self._cond:
                self.params.pop(name, None)
            self.send(
                self.mav.param_request_read_encode(
                    AUTOPILOT_SYSID, AUTOPILOT_COMPID, name.encode("ascii"), -1
                )
            )
            try:
                return self.wait_value(
                    lambda: self.params.get(name), COMMAND_TIMEOUT_S, f"PARAM_VALUE {name}"
                )
            except AssertionError:
                if self.closed_reason is not None:
                    raise
        return None

    def set_param(self, name: str, value: float) -> None:
        """PARAM_SET, confirmed by the PARAM_VALUE echo."""
        for attempt in range(COMMAND_TRIES):
            with self._cond:
                self.params.pop(name, None)
            self.send(
                self.mav.param_set_encode(
                    AUTOPILOT_SYSID,
                    AUTOPILOT_COMPID,
                    name.encode("ascii"),
                    value,
                    mavlink2.MAV_PARAM_TYPE_REAL32,
                )
            )
            try:
                echoed = self.wait_value(
                    lambda: self.params.get(name), COMMAND_TIMEOUT_S, f"PARAM_VALUE {name}"
                )
            except AssertionError:
                if attempt == COMMAND_TRIES - 1 or self.closed_reason is not None:
                    raise
                continue
            assert math.isclose(echoed, value, abs_tol=1e-3), f"{name} = {echoed}, wanted {value}"
            return

    def close(self) -> None:
        try:
            self.sock.close()
        except OSError as exc:
            print(f"closing {self.name}: {exc}")
        if self._thread is not None:
            self._thread.join(timeout=2.0)


def connect_tcp(port: int, timeout_s: float, alive: Callable[[], str | None]) -> socket.socket:
    """Connect to 127.0.0.1:port, retrying until SITL listens (or ``alive`` says it died)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return socket.create_connection(("127.0.0.1", port), timeout=1.0)
        except OSError as exc:
            dead = alive()
            if dead is not None:
                raise AssertionError(f"SITL {dead} before tcp:{port} accepted") from exc
            if time.monotonic() > deadline:
                raise AssertionError(
                    f"tcp:127.0.0.1:{port} not accepting after {timeout_s} s"
                ) from exc
            time.sleep(0.2)  # retry interval of the connect poll, bounded by the deadline


# ---------------------------------------------------------------------------------------------
# The SITL process


def _worker_index() -> int:
    digits = re.sub(r"\D", "", os.environ.get("PYTEST_XDIST_WORKER", ""))
    return int(digits) if digits else 0


_instance_counter = itertools.count()


def _ports_free(instance: int) -> bool:
    offset = PORT_STRIDE * instance
    checks = [(socket.SOCK_STREAM, p + offset) for p in (SERIAL0_PORT, SERIAL1_PORT, SERIAL2_PORT)]
    checks.append((socket.SOCK_DGRAM, RCIN_PORT + offset))
    for kind, port in checks:
        with socket.socket(socket.AF_INET, kind) as s:
            if kind == socket.SOCK_STREAM:
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as SITL binds
            try:
                s.bind(("0.0.0.0", port))
            except OSError:
                return False
    return True


def pick_instance() -> int:
    """A -I value whose ports are free, distinct per pytest-xdist worker and rotating per test."""
    base = int(os.environ.get(INSTANCE_BASE_ENV, "0"))
    first = base + _worker_index() * INSTANCES_PER_WORKER
    for _ in range(INSTANCES_PER_WORKER):
        instance = first + next(_instance_counter) % INSTANCES_PER_WORKER
        if _ports_free(instance):
            return instance
    pytest.fail(f"no free SITL instance in {first}..{first + INSTANCES_PER_WORKER - 1}")


@dataclass
class SitlVehicle:
    """One running ``ardurover`` SITL and the observer attached to it."""

    proc: subprocess.Popen[bytes]
    instance: int
    speedup: float
    workdir: Path
    log_path: Path
    observer: MavClient | None = None
    start_ne_m: tuple[float, float] = (0.0, 0.0)
    start_t_boot_s: float = 0.0
    plant: HelixPlantProc | None = None  # the Helix physics (--model JSON), None: rover-skid

    @property
    def helixd_port(self) -> int:
        return SERIAL0_PORT + PORT_STRIDE * self.instance

    @property
    def helixd_url(self) -> str:
        return f"tcp:127.0.0.1:{self.helixd_port}"

    @property
    def obs(self) -> MavClient:
        assert self.observer is not None, "observer not attached"
        return self.observer

    def dead(self) -> str | None:
        code = self.proc.poll()
        return (
            None if code is None else f"ardurover exited with {code}; log tail:\n{self.log_tail()}"
        )

    def log_tail(self, lines: int = 30) -> str:
        return log_tail(self.log_path, lines, "SITL")

    def guard_version(self) -> int | None:
        """HXG_VERSION as the autopilot reports it: the helixd-guard that runs (None: none)."""
        value = self.obs.get_param(HXG_VERSION)
        return None if value is None else round(value)

    def pilot_rc(self, values_us: dict[int, int]) -> None:
        """The pilot's radio: set RC inputs (channel → µs); other channels keep their value."""
        pwm = [0] * RC_INPUT_CHANNELS
        for channel, value in values_us.items():
            pwm[channel - 1] = value
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.sendto(
                struct.pack(f"<{RC_INPUT_CHANNELS}H", *pwm),
                ("127.0.0.1", RCIN_PORT + PORT_STRIDE * self.instance),
            )

    def use_servo_outputs(self) -> None:
        """Give outputs 1–4 function 0 for the DO_SET_SERVO backend.

        Switched at runtime, not in a parm file: an output whose function becomes 0 keeps its
        last value (the RC passthrough's 1500) until DO_SET_SERVO moves it, so the rover stays
        put; at boot a function-0 output starts at whatever SITL initialises it to.
        """
        for channel in range(1, 5):
            self.obs.set_param(f"SERVO{channel}_FUNCTION", 0.0)
        self.obs.wait_until(
            lambda: outputs_near(self.obs.servo_pwm(), NEUTRAL_US),
            10.0,
            "outputs 1 and 3 still at neutral after switching to function 0",
        )

    def distance_from_start_m(self) -> float | None:
        p = self.obs.position()
        if p is None:
            return None
        return math.hypot(p.north_m - self.start_ne_m[0], p.east_m - self.start_ne_m[1])

    def wait_driving(self, daemon: DaemonRun, min_distance_m: float, timeout_s: float) -> None:
        """Until helixd has armed and driven ``min_distance_m`` and the outputs are deflected."""

        def driving() -> bool:
            pwm = self.obs.servo_pwm()
            moved = self.distance_from_start_m()
            return (
                bool(self.obs.armed())
                and moved is not None
                and moved >= min_distance_m
                and pwm is not None
                and max(abs(pwm[0] - NEUTRAL_US), abs(pwm[2] - NEUTRAL_US)) >= DRIVING_DEFLECTION_US
            )

        self.obs.wait_until(
            driving, timeout_s, f"helixd driving ≥ {min_distance_m} m", abort=daemon.ended
        )

    def stop(self) -> None:
        if self.observer is not None:
            self.observer.close()
        stop_process(self.proc)
        if self.plant is not None:
            self.plant.stop()


def log_tail(path: Path, lines: int, what: str) -> str:
    """The last ``lines`` of the log at ``path`` (``what``'s), or why there is none."""
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        return f"(no {what} log: {exc})"
    return "\n".join(text.splitlines()[-lines:])


def stop_process(proc: subprocess.Popen[bytes]) -> None:
    """SIGTERM, then kill if it has not ended within SITL_STOP_TIMEOUT_S."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGTERM)
        try:
            proc.wait(timeout=SITL_STOP_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=SITL_STOP_TIMEOUT_S)


@dataclass
class HelixPlantProc:
    """``helixd plant`` serving SITL's JSON physics port for one instance; a thread copies
    its output into ``log_path`` and sets ``listening`` at its first line."""

    proc: subprocess.Popen[bytes]
    terrain: str
    truth_csv: Path
    log_path: Path
    listening: threading.Event = field(default_factory=threading.Event)

    def copy_output(self) -> None:
        assert self.proc.stdout is not None
        with self.log_path.open("wb") as log_file:
            for line in self.proc.stdout:
                log_file.write(line)
                log_file.flush()
                if b"Helix physics on udp" in line:
                    self.listening.set()

    def stop(self) -> None:
        stop_process(self.proc)

    def log_tail(self, lines: int = 15) -> str:
        return log_tail(self.log_path, lines, "plant")


def start_plant(
    workdir: Path,
    instance: int,
    terrain: str,
    media: Path | None = None,
    home: str = HOME,
    bathymetry: Path | None = None,
) -> HelixPlantProc:
    """``helixd plant -I instance --terrain terrain``, its UDP port bound before it returns
    (it says so on its first line; SITL then finds it answering from its first frame)."""
    cmd = [
        sys.executable, "-m", "helixd", "plant", "-I", str(instance),
        "--terrain", terrain, "--truth-csv", str(workdir / "truth.csv"), f"--home={home}",
    ]  # fmt: skip
    cmd += ["--ground", str(SITL_GROUND)]  # the suite's ground (the file says why)
    if media is not None:
        cmd += ["--media", str(media)]
    if bathymetry is not None:  # the depth to SITL's rangefinder 1 (JSON rng_1)
        cmd += ["--bathymetry", str(bathymetry)]
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen(
        cmd,
        cwd=workdir,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        env=env,
    )
    plant = HelixPlantProc(proc, terrain, workdir / "truth.csv", workdir / "plant.log")
    threading.Thread(target=plant.copy_output, name="plant-log", daemon=True).start()
    if not plant.listening.wait(BOOT_TIMEOUT_S):
        plant.stop()
        raise AssertionError(f"helixd plant did not start; log:\n{plant.log_tail()}")
    return plant


def outputs_near(pwm: tuple[int, int, int, int] | None, target_us: int) -> bool:
    """Outputs 1 and 3 (the skid model's motors) within tolerance of ``target_us``."""
    return pwm is not None and all(abs(pwm[i] - target_us) <= OUTPUT_TOLERANCE_US for i in (0, 2))


def wait_first_heartbeat(port: int, timeout_s: float, alive: Callable[[], str | None]) -> None:
    """Connect to SERIAL0 (which lets SITL boot), read until the autopilot's HEARTBEAT, close.

    SITL serves one client per TCP port and re-accepts once it closes: helixd connects next.
    """
    deadline = time.monotonic() + timeout_s
    parser = mavlink2.MAVLink(None)
    parser.robust_parsing = True
    with connect_tcp(port, timeout_s, alive) as sock:
        sock.settimeout(0.5)
        while True:
            try:
                data = sock.recv(65536)
            except TimeoutError:
                data = None
            if data == b"":
                raise AssertionError(f"SITL closed tcp:{port} before its first HEARTBEAT")
            for msg in parser.parse_buffer(data or b"") or ():
                if msg.get_type() == "HEARTBEAT" and msg.get_srcSystem() == AUTOPILOT_SYSID:
                    return
            dead = alive()
            if dead is not None:
                raise AssertionError(f"SITL {dead}")
            if time.monotonic() > deadline:
                raise AssertionError(f"no HEARTBEAT on tcp:{port} within {timeout_s} s")


def install_guard_file(workdir: Path) -> Path:
    """The packaged helixd-guard.lua into SITL's ./scripts (SCRIPTING_DIRECTORY), as the
    README's manual install puts it on an SD card's APM/scripts."""
    scripts = workdir / POSIX_SCRIPTS_DIR
    scripts.mkdir(exist_ok=True)
    path = scripts / SCRIPT_NAME
    path.write_bytes(script_bytes())
    return path


def start_sitl(
    binary: Path,
    workdir: Path,
    instance: int,
    speedup: float,
    guard: bool = True,
    terrain: str | None = None,
    media: Path | None = None,
    home: str = HOME,
    bathymetry: Path | None = None,
    extra_defaults: tuple[Path, ...] = (),
) -> SitlVehicle:
    """ardurover in ``workdir``; with ``guard`` helixd-guard.lua is in its scripts/ first and
    this waits until the script has loaded (its HXG_VERSION parameter exists). Without
    ``terrain`` the model is rover-skid; with it, the Helix plant on that ground (``helixd
    plant``, SITL's ``--model JSON``) and the Helix's own parameter files."""
    log_path = workdir / "sitl.log"
    if guard:
        install_guard_file(workdir)
    plant = (
        start_plant(workdir, instance, terrain, media, home, bathymetry)
        if terrain is not None
        else None
    )
    model, defaults = ("rover-skid", str(PARM_FILE))
    if plant is not None:
        files = (*HELIX_PARM_FILES, *extra_defaults)
        model, defaults = ("JSON", ",".join(str(p) for p in files))
    cmd = [
        str(binary),
        "--model",
        model,
        "--defaults",
        defaults,
        "-I",
        str(instance),
        "--speedup",
        f"{speedup:g}",
        f"--home={home}",  # one argv: the value starts with '-'
        "--wipe",
    ]
    with log_path.open("wb") as log_file:
        proc = subprocess.Popen(
            cmd, cwd=workdir, stdin=subprocess.DEVNULL, stdout=log_file, stderr=subprocess.STDOUT
        )
    vehicle = SitlVehicle(proc, instance, speedup, workdir, log_path, plant=plant)
    print(f"SITL: {' '.join(cmd)}  (cwd {workdir})")
    try:
        wait_first_heartbeat(vehicle.helixd_port, BOOT_TIMEOUT_S, vehicle.dead)
        vehicle.observer = MavClient.connect(
            SERIAL1_PORT + PORT_STRIDE * instance, "observer", CONNECT_TIMEOUT_S, vehicle.dead
        )
        obs = vehicle.obs
        for msg_id in (mavlink2.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, mavlink2.MAVLINK_MSG_ID_HEARTBEAT):
            obs.set_message_interval(msg_id, FAST_STREAM_RATE_HZ)
        for msg_id in (
            mavlink2.MAVLINK_MSG_ID_LOCAL_POSITION_NED,
            mavlink2.MAVLINK_MSG_ID_ATTITUDE,  # the heading the square's start frame takes
            mavlink2.MAVLINK_MSG_ID_EKF_STATUS_REPORT,
            mavlink2.MAVLINK_MSG_ID_GPS_RAW_INT,
        ):
            obs.set_message_interval(msg_id, STREAM_RATE_HZ)
        obs.wait_until(
            obs.ekf_has_position, READY_TIMEOUT_S, "GPS fix and EKF position", abort=vehicle.dead
        )
        if guard:  # scripts load at boot: long done by the time the EKF has a position
            running = vehicle.guard_version()
            assert running == VERSION, (
                f"helixd-guard not running in SITL (HXG_VERSION {running}); "
                f"STATUSTEXT {obs.statustexts[-8:]}; log tail:\n{vehicle.log_tail()}"
            )
        if plant is not None:
            # helix.parm's throttle is RC5 (RCMAP_THROTTLE, a channel helixd does not drive):
            # AP_Arming wants it at RC5_TRIM to arm; SITL's radio rests it at 1000 µs, the crew
            # centres it
            vehicle.pilot_rc({HELIX_THROTTLE_CHANNEL: NEUTRAL_US})
        start = obs.position()
        assert start is not None
        vehicle.start_ne_m = (start.north_m, start.east_m)
        vehicle.start_t_boot_s = start.t_boot_s
    except BaseException:
        vehicle.stop()
        raise
    return vehicle


def start_test_sitl(
    tmp_path: Path,
    guard: bool,
    terrain: str | None = None,
    media: Path | None = None,
    home: str = HOME,
    bathymetry: Path | None = None,
    extra_defaults: tuple[Path, ...] = (),
) -> Iterator[SitlVehicle]:
    binary = Path(os.environ[SITL_BIN_ENV]).resolve()
    workdir = tmp_path / "sitl"
    workdir.mkdir()
    vehicle = start_sitl(
        binary,
        workdir,
        pick_instance(),
        sitl_speedup(),
        guard,
        terrain,
        media,
        home,
        bathymetry,
        extra_defaults,
    )
    try:
        yield vehicle
    finally:
        vehicle.stop()


@pytest.fixture
def sitl(tmp_path: Path) -> Iterator[SitlVehicle]:
    """ardurover with helixd-guard running (the field setup)."""
    yield from start_test_sitl(tmp_path, guard=True)


@pytest.fixture
def helix_sitl(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[SitlVehicle]:
    """ardurover ``--model JSON`` with the Helix plant (``helixd plant``) on the ground the
    test names by indirect parametrisation (default hard), booted from config/ardupilot/
    helix.parm + tests/sitl/helix-json.parm, helixd-guard running."""
    terrain = str(getattr(request, "param", "hard"))
    yield from start_test_sitl(tmp_path, guard=True, terrain=terrain)


@pytest.fixture
def bare_sitl(tmp_path: Path) -> Iterator[SitlVehicle]:
    """ardurover with scripting on but no script in its scripts/ (before an install)."""
    yield from start_test_sitl(tmp_path, guard=False)


# ---------------------------------------------------------------------------------------------
# The helixd daemon (the real CLI, as a subprocess)


DaemonRun = DaemonProc  # the one subprocess harness for the daemon (tests/support/daemon.py)


def start_helixd(
    tmp_path: Path,
    vehicle: SitlVehicle,
    backend: str,
    mission: Path = SQUARE_MISSION,
    channel_offset: int = 0,
) -> DaemonRun:
    cfg_path = tmp_path / f"helixd-sitl-{backend}.yaml"
    config = helixd_sitl_config(backend, vehicle.helixd_url, channel_offset)
    cfg_path.write_text(
        yaml.safe_dump(config, sort_keys=False),
        encoding="utf-8",
    )
    run_root = tmp_path / "runs"
    args = ["run", "--connect", vehicle.helixd_url, "--mission", str(mission)]
    return spawn_daemon(
        [*args, "--config", str(cfg_path), "--run-dir", str(run_root)],
        cwd=tmp_path,
        run_root=run_root,
        stdin=subprocess.DEVNULL,
    )


@pytest.fixture
def launch_helixd(tmp_path: Path, sitl: SitlVehicle) -> Iterator[Callable[..., DaemonRun]]:
    """``launch_helixd(backend[, mission])`` starts ``helixd run`` against this test's SITL
    (the square unless another mission file is given)."""
    runs: list[DaemonRun] = []

    def launch(backend: str, mission: Path = SQUARE_MISSION, channel_offset: int = 0) -> DaemonRun:
        run = start_helixd(tmp_path, sitl, backend, mission, channel_offset)
        runs.append(run)
        return run

    try:
        yield launch
    finally:
        for run in runs:
            run.stop(DAEMON_STOP_TIMEOUT_S)


# Wall minutes of the longest tests at speed-up 1 (pytest --durations, 2026-11-28: the SITL
# suite side by side, docs/measurements.md); every other test takes 0.5-1.2 min.
LONGEST_TESTS_MIN = {
    "test_survey_block_helixd_against_auto": 11.9,  # helixd's block, then AUTO's on a 2nd SITL
    "test_survey_from_qgroundcontrol_as_precise_as_helixd_run": 11.7,  # run, then serve
    "test_pond_crossing_the_mode_follows_the_medium": 3.5,
    "test_pond_crossing_scrolls_through_the_water_and_roll_cannot": 3.1,
    "test_autopilot_mission_with_speed_change_and_servo": 1.8,
    "test_go_to_location_and_rtl_to_a_rally_point": 1.6,
    "test_helix_mission_on_real_ardupilot": 1.5,
    "test_set_current_waypoint_in_a_commands_mission": 1.5,
}
OTHER_TEST_MIN = 1.0


def sitl_minutes(item: pytest.Item) -> float:
    """The expected wall minutes of one SITL test; 0 for a test of another suite."""
    if item.get_closest_marker("sitl") is None:
        return 0.0
    return LONGEST_TESTS_MIN.get(getattr(item, "originalname", item.name), OTHER_TEST_MIN)


def worker_blocks(minutes: list[float], workers: int) -> list[list[int]]:
    """Indices of ``minutes`` in the contiguous blocks pytest-xdist's ``--dist worksteal``
    hands its workers at the start (block ``i`` holds ``remaining // (workers - i)`` tests),
    filled longest test first into the block with the least expected minutes that has room,
    each block in turn longest first. A worker then steals only from another's tail, so two
    long tests never queue behind each other on one worker."""
    count = len(minutes)
    sizes: list[int] = []
    remaining = count
    for i in range(workers):
        sizes.append(remaining // (workers - i))
        remaining -= sizes[-1]
    blocks: list[list[int]] = [[] for _ in sizes]
    loads = [0.0] * len(sizes)
    for index in sorted(range(count), key=lambda k: minutes[k], reverse=True):
        open_blocks = [b for b in range(len(blocks)) if len(blocks[b]) < sizes[b]]
        best = min(open_blocks, key=lambda b: loads[b])
        blocks[best].append(index)
        loads[best] += minutes[index]
    return blocks


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Spread the longest SITL tests over pytest-xdist's workers (``-n 5 --dist worksteal``):
    the suite then lasts about its longest test or its total over the workers, whichever is
    more, instead of two 12-minute surveys queued on one worker. Without xdist the longest
    run first. Every worker computes the same order, as xdist requires."""
    sitl = [item for item in items if item.get_closest_marker("sitl") is not None]
    others = [item for item in items if item.get_closest_marker("sitl") is None]
    workers = max(1, int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1")))
    minutes = [sitl_minutes(item) for item in sitl]
    order = [sitl[k] for block in worker_blocks(minutes, workers) for k in block]
    items[:] = order + others
