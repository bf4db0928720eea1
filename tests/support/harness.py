"""The integration harness: the simulator in-process over real UDP, pymavlink/MAVSDK clients
for it, and the real ``helixd run`` CLI as a subprocess against it.

The simulator runs in this test process (a thread); the daemon is a separate process
(:mod:`tests.support.daemon`) talking MAVLink to it exactly as it would to a Pixhawk.
Assertions are made from the simulator's side: what the autopilot saw, not what the daemon
claims.
"""

from __future__ import annotations

import asyncio
import contextlib
import itertools
import math
import os
import socket
import threading
import time
from collections.abc import AsyncGenerator, Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import yaml

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil

from helixd.mav.arming import FORCE_ARM_MAGIC
from helixd.sim.server import SimServer, start_embedded
from helixd.sim.sim_config import HELIXD_SYSID, SimConfig
from helixd.sim.snapshot import SimSnapshot
from tests.support.daemon import DaemonProc, deep_merge, spawn_daemon
from tests.support.mavmsgs import TextPane
from tests.support.paths import REPO_ROOT

T = TypeVar("T")

# ---------------------------------------------------------------------------------------------
# The simulator and MAVLink clients

UINT16_MAX = 0xFFFF
GCS_SYSID = HELIXD_SYSID  # the simulator's MAV_GCS_SYSID (set up for helixd; ArduPilot: 255)
GCS_COMPID = 190
MAV_RESULT_ACCEPTED = 0
MAV_RESULT_DENIED = 2
MAV_RESULT_UNSUPPORTED = 3
MAV_RESULT_FAILED = 4
MAV_CMD_DO_SET_MODE = 176
MAV_CMD_DO_SET_SERVO = 183
MAV_CMD_DO_SET_HOME = 179
MAV_CMD_COMPONENT_ARM_DISARM = 400
MAV_CMD_SET_MESSAGE_INTERVAL = 511
FORCE_ARM = FORCE_ARM_MAGIC  # the simulator's forced arm, for wire tests of the simulator itself
MSG_LOCAL_POSITION_NED = 32
MODE_MANUAL = 0
MODE_HOLD = 4

# fast, deterministic defaults for wire tests: 10× SITL-style speed-up, exact pose (arming
# is allowed once home is set, with the EKF origin: the simulator's default, as ArduPilot)
FAST = {"speedup": 10.0, "noise": "none", "seed": 7}
# Clients pace their HEARTBEATs in wall time while FS_GCS_TIMEOUT runs on simulated time, so
# the GCS failsafe is off in tests unless a test turns it on (its params are merged over this).
FAST_PARAMS = {"FS_GCS_ENABLE": 0.0}


def sim_config(**overrides: Any) -> SimConfig:
    params = {**FAST_PARAMS, **overrides.pop("params", {})}
    return SimConfig.model_validate({**FAST, **overrides, "params": params})


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@contextmanager
def running_sim(**overrides: Any) -> Iterator[tuple[SimServer, str]]:
    server, url = start_embedded(sim_config(**overrides))
    try:
        yield server, url
    finally:
        server.stop()


class MavClient:
    """A plain pymavlink GCS on a real UDP socket."""

    def __init__(self, url: str, sysid: int = GCS_SYSID, compid: int = GCS_COMPID) -> None:
        self.conn = mavutil.mavlink_connection(
            url, source_system=sysid, source_component=compid, dialect="ardupilotmega"
        )
        self.texts: list[str] = []  # every STATUSTEXT seen (chunks joined)
        self._pane = TextPane(self.texts)
        self.heartbeat()

    def close(self) -> None:
        self.conn.close()

    def __enter__(self) -> MavClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def mav(self) -> Any:
        return self.conn.mav

    def heartbeat(self) -> None:
        self.mav.heartbeat_send(6, 8, 0, 0, 0)  # MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID

    def recv(
        self, kind: str, timeout_s: float, condition: Callable[[Any], bool] | None = None
    ) -> Any | None:
        """Next message of ``kind`` satisfying ``condition`` within ``timeout_s`` (wall)."""
        deadline = time.monotonic() + timeout_s
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return None
            msg = self.conn.recv_match(blocking=True, timeout=min(remaining, 0.2))
            if msg is None:
                continue
            if msg.get_type() == "STATUSTEXT":
                self._pane.note(msg)
            if msg.get_type() == kind and (condition is None or condition(msg)):
                return msg

    def wait_text(self, prefix: str, timeout_s: float) -> str:
        """A STATUSTEXT starting with ``prefix`` seen so far or arriving within the timeout."""
        deadline = time.monotonic() + timeout_s
        while True:
            for text in self.texts:
                if text.startswith(prefix):
                    return text
            if time.monotonic() > deadline:
                raise AssertionError(f"no STATUSTEXT {prefix!r}; saw {self.texts}")
            self.recv("STATUSTEXT", 0.1)

    def wait_said(self, sentence: str, timeout_s: float) -> None:
        """Until helixd's texts, its lines joined as a ground station's pane reads them (each
        line starts with ``helixd: ``), contain ``sentence``."""
        deadline = time.monotonic() + timeout_s
        while True:
            said = " ".join(
                t.removeprefix("helixd: ") for t in self.texts if t.startswith("helixd: ")
            )
            if sentence in said:
                return
            if time.monotonic() > deadline:
                raise AssertionError(f"helixd never said {sentence!r}; saw {self.texts}")
            self.recv("STATUSTEXT", 0.1)

    def expect(
        self, kind: str, timeout_s: float, condition: Callable[[Any], bool] | None = None
    ) -> Any:
        msg = self.recv(kind, timeout_s, condition)
        assert msg is not None, f"no {kind} within {timeout_s} s"
        return msg

    def drain(self) -> None:
        while (msg := self.conn.recv_match(blocking=False)) is not None:
            if msg.get_type() == "STATUSTEXT":
                self._pane.note(msg)

    def command(self, command: int, *params: float, timeout_s: float = 10.0) -> int:
        p = [float(x) for x in params] + [0.0] * (7 - len(params))
        self.drain()  # a socket buffer filled while nobody read would drop the ACK
        self.mav.command_long_send(1, 1, command, 0, *p)
        ack = self.expect("COMMAND_ACK", timeout_s, lambda m: int(m.command) == command)
        return int(ack.result)

    def override(self, *channels: int) -> None:
        """RC_CHANNELS_OVERRIDE; unspecified 1–8 = UINT16_MAX (unchanged), 9–18 = 0."""
        values = list(channels) + [UINT16_MAX] * max(0, 8 - len(channels))
        values += [0] * (18 - len(values))
        self.mav.rc_channels_override_send(1, 1, *values)

    def param_read(self, name: str, timeout_s: float = 1.0) -> float | None:
        self.mav.param_request_read_send(1, 1, name.encode(), -1)
        msg = self.recv("PARAM_VALUE", timeout_s, lambda m: str(m.param_id) == name)
        return None if msg is None else float(msg.param_value)

    def param_set(self, name: str, value: float, timeout_s: float = 2.0) -> float:
        self.mav.param_set_send(1, 1, name.encode(), float(value), 9)
        msg = self.expect("PARAM_VALUE", timeout_s, lambda m: str(m.param_id) == name)
        return float(msg.param_value)

    def servo(self, channel: int, timeout_s: float, condition: Callable[[int], bool]) -> Any:
        """Wait for a SERVO_OUTPUT_RAW whose ``channel`` value satisfies ``condition``."""
        return self.expect(
            "SERVO_OUTPUT_RAW",
            timeout_s,
            lambda m: condition(int(getattr(m, f"servo{channel}_raw"))),
        )

    def request_interval(self, msg_id: int, interval_us: int) -> int:
        return self.command(MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, interval_us)

    def fast_streams(self) -> None:
        """Ask for SERVO_OUTPUT_RAW and HEARTBEAT-free fast telemetry the way helixd will."""
        assert self.request_interval(36, 50_000) == MAV_RESULT_ACCEPTED  # SERVO_OUTPUT_RAW
        assert self.request_interval(65, 50_000) == MAV_RESULT_ACCEPTED  # RC_CHANNELS


@contextmanager
def client(url: str, sysid: int = GCS_SYSID) -> Iterator[MavClient]:
    c = MavClient(url, sysid)
    try:
        yield c
    finally:
        c.close()


@contextmanager
def running_sim_links(links: list[str], **overrides: Any) -> Iterator[SimServer]:
    server = SimServer(links, sim_config(**overrides))
    server.start()
    try:
        yield server
    finally:
        server.stop()


class OverrideStreamer:
    """Re-sends an RC override every ``period_s`` (wall) on a background thread, as helixd's
    RC-override sink does, until stopped."""

    def __init__(self, c: MavClient, channels: tuple[int, ...], period_s: float = 0.05) -> None:
        self.client = c
        self.channels = channels
        self.period_s = period_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="override-streamer", daemon=True)

    def _run(self) -> None:
        while not self._stop.is_set():
            self.client.override(*self.channels)
            self._stop.wait(self.period_s)

    def __enter__(self) -> OverrideStreamer:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)


async def first_matching(
    stream: AsyncGenerator[T, None], predicate: Callable[[T], bool], timeout_s: float
) -> T:
    """First item of a MAVSDK subscription satisfying ``predicate`` (unsubscribes after)."""

    async def scan() -> T:
        async with contextlib.aclosing(stream) as items:
            async for item in items:
                if predicate(item):
                    return item
        raise AssertionError("stream ended")

    return await asyncio.wait_for(scan(), timeout_s)


# ---------------------------------------------------------------------------------------------
# The daemon against the simulator

ROOT = REPO_ROOT
MISSIONS = ROOT / "config" / "missions"
SPEEDUP = 5.0  # simulator speed-up for daemon runs (sim time runs 5× wall)
NEUTRAL_US = 1500
NEUTRAL_TOLERANCE_US = 10
KEEP_NOTIFY_SOCKET = False  # the systemd test hands its own NOTIFY_SOCKET to the daemon

# Daemon settings for tests: faster setup, everything else at its field default.
BASE_CONFIG: dict[str, Any] = {
    "startup": {"connect_timeout_s": 20.0, "arm_retry_interval_s": 0.5},
}


@contextmanager
def daemon(
    tmp_path: Path,
    url: str,
    mission: str | Path = "square",
    config: dict[str, Any] | None = None,
) -> Iterator[DaemonProc]:
    """``helixd run`` as a subprocess against ``url``; killed on the way out if still running."""
    cfg = deep_merge(BASE_CONFIG, config or {})
    cfg = deep_merge(cfg, {"link": {"url": url}})
    cfg_path = tmp_path / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg), encoding="utf-8")
    mission_path = mission if isinstance(mission, Path) else MISSIONS / f"{mission}.yaml"
    run_root = tmp_path / "runs"
    args = ["run", "--mission", str(mission_path), "--config", str(cfg_path)]
    handle = spawn_daemon(
        [*args, "--run-dir", str(run_root)],
        cwd=tmp_path,
        run_root=run_root,
        keep_notify_socket=KEEP_NOTIFY_SOCKET,
    )
    try:
        yield handle
    finally:
        handle.kill()


@contextmanager
def sim_and_daemon(
    tmp_path: Path,
    mission: str | Path = "square",
    config: dict[str, Any] | None = None,
    **sim_overrides: Any,
) -> Iterator[tuple[SimServer, DaemonProc]]:
    overrides = {"speedup": SPEEDUP, **sim_overrides}
    with running_sim(**overrides) as (server, url), daemon(tmp_path, url, mission, config) as d:
        yield server, d


def guard_installed(speedup: float, outputs: tuple[int, ...] = (1, 2, 3, 4)) -> dict[str, Any]:
    """Simulator settings with helixd-guard installed on ``outputs``, its timeout 0.5 s of wall
    time: helixd paces its HEARTBEAT on the wall clock, the guard counts simulated time (as
    ``run --sim`` sets it up, helixd.cli.simulated)."""
    chans = {f"HXG_CHAN{i + 1}": float(n) for i, n in enumerate(outputs)}
    return {
        "guard_installed": True,
        "guard_params": {"HXG_TIMEOUT": min(0.5 * speedup, 10.0), **chans},
    }


def scrolls_neutral(s: SimSnapshot) -> bool:
    return all(abs(p - NEUTRAL_US) <= NEUTRAL_TOLERANCE_US for p in s.scroll_pwm_us)


def overrides_released(s: SimSnapshot) -> bool:
    return not any(s.overrides_active)


def secured(s: SimSnapshot) -> bool:
    """What the autopilot must show after any fall-back: HOLD, no override, scrolls neutral."""
    return s.mode == "HOLD" and overrides_released(s) and scrolls_neutral(s)


def wait_moving(server: SimServer, timeout_s: float = 40.0) -> SimSnapshot:
    """Until the rover is armed and driving its mission (scrolls commanded, rover moving)."""
    return server.wait_for(lambda s: s.armed and s.speed_mps > 0.1, timeout_s)


def time_until(
    server: SimServer, predicate: Callable[[SimSnapshot], bool], since_s: float, timeout_s: float
) -> float:
    """Wall seconds from ``since_s`` (monotonic) until ``predicate`` holds in the simulator
    (woken by each snapshot the simulator publishes)."""
    try:
        server.wait_for(predicate, timeout_s)
    except TimeoutError as exc:
        raise AssertionError(f"not reached within {timeout_s} s: {exc}") from None
    return time.monotonic() - since_s


@dataclass(frozen=True)
class Trace:
    """What the simulator showed, polled every few ms: (monotonic wall s, snapshot) pairs."""

    samples: list[tuple[float, SimSnapshot]]

    def first(self, predicate: Callable[[SimSnapshot], bool], after_s: float = -1e18) -> float:
        """Wall time of the first sample at or after ``after_s`` where ``predicate`` holds."""
        for t, snap in self.samples:
            if t >= after_s and predicate(snap):
                return t
        raise AssertionError(f"never seen in {len(self.samples)} samples")

    def driven_after(self, after_s: float) -> list[tuple[float, tuple[int, int, int, int]]]:
        """Samples after ``after_s`` whose scroll outputs were away from neutral."""
        return [
            (t, s.scroll_pwm_us) for t, s in self.samples if t > after_s and not scrolls_neutral(s)
        ]

    def yaw_change_deg(self, after_s: float) -> float:
        """Total |rotation| of the rover (truth) after ``after_s``, unwrapped, in degrees."""
        yaws = [s.yaw_ned_rad for t, s in self.samples if t >= after_s]
        total = 0.0
        for a, b in itertools.pairwise(yaws):
            total += abs(math.remainder(b - a, 2 * math.pi))
        return math.degrees(total)


def record_until(
    server: SimServer, predicate: Callable[[SimSnapshot], bool], timeout_s: float
) -> Trace:
    """Every snapshot the simulator publishes until ``predicate`` holds (and 0.2 s more)."""
    samples: list[tuple[float, SimSnapshot]] = []
    deadline = time.monotonic() + timeout_s
    done_at: float | None = None
    snap: SimSnapshot | None = None
    while True:
        try:
            snap = server.next_snapshot(snap, max(0.0, deadline - time.monotonic()))
        except TimeoutError as exc:
            raise AssertionError(f"not reached within {timeout_s} s: {exc}") from None
        now = time.monotonic()
        samples.append((now, snap))
        if done_at is None and predicate(snap):
            done_at = now
        if done_at is not None and now - done_at >= 0.2:
            return Trace(samples)
        if now > deadline:
            raise AssertionError(f"not reached within {timeout_s} s; simulator: {snap.describe()}")
