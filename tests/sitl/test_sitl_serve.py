"""``helixd serve`` against real ArduPilot Rover SITL (opt-in: ``HELIXD_SITL_BIN``): the start
switch and the ground station's commands start, pause and continue the autopilot's mission.

SITL's three TCP serial ports: helixd serve on SERIAL0, the suite's observer (system 250, no
HEARTBEAT) on SERIAL1, and a ground station as QGroundControl behaves on SERIAL2 (system 255,
HEARTBEAT at 1 Hz; it uploads the mission with the mission protocol and sends COMMAND_LONG to
helixd's own 247/191, which ArduPilot routes to SERIAL0 by MAVLink_routing, and reads helixd's
COMMAND_ACK routed back). The start switch is RC7 on SITL's RC-input UDP port (the pilot's
radio). The sequence, one mission of three waypoints (8 m legs, left-hand turns):

* upload → ``state=ready``; nothing moves;
* switch high → ``state=flying``; the rover drives (LOCAL_POSITION_NED); a command from a
  system not in ``serve.gcs_system_ids`` is DENIED, the ground station's MISSION_START while
  flying TEMPORARILY_REJECTED;
* switch low on leg 1 → ``state=paused``; outputs 1/3 at trim and HOLD (latencies printed);
  the ground station's DO_PAUSE_CONTINUE 1 is DENIED while the switch is low (the pilot's
  veto, serve.core); switch high → ``event=run_resumed``, the rover drives on;
* DO_PAUSE_CONTINUE 0 from the ground station on leg 2 → ACCEPTED, ``state=paused``, trim and
  HOLD; DO_PAUSE_CONTINUE 1 → ACCEPTED, ``event=run_resumed``, ``state=completed``;
* the autopilot's MISSION_CURRENT, as the ground station receives it, goes 1 → 2 → 3 with the
  leg being flown (across both continues; 0 only while paused and after the end: helixd
  disarms then and Rover resets its mission on a disarm outside AUTO); outputs 1/3 at trim and
  HOLD at the end; three run directories, the last one completed.

The ids: the stranger is system 251 speaking on the ground station's link (SITL has no fourth
TCP serial port; ArduPilot learns the route to 251 from its COMMAND_LONG and routes helixd's
answer back the same way).
"""

from __future__ import annotations

import json
import math
import re
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest
import yaml
from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from helixd.base.frames import ne_to_latlon
from helixd.config.link import LinkConfig
from helixd.mav.constants import (
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_TEMPORARILY_REJECTED,
)
from tests.sitl.conftest import (
    AUTOPILOT_COMPID,
    AUTOPILOT_SYSID,
    CONNECT_TIMEOUT_S,
    DAEMON_STOP_TIMEOUT_S,
    MODE_HOLD,
    NEUTRAL_US,
    PORT_STRIDE,
    SERIAL2_PORT,
    STREAM_RATE_HZ,
    MavClient,
    SitlVehicle,
    connect_tcp,
    outputs_near,
    start_test_sitl,
)
from tests.support.daemon import DaemonProc, deep_merge, spawn_daemon
from tests.support.helix_sitl import helix_sitl_config
from tests.support.skid_setup import HELIXD_SYSID, helixd_sitl_config

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(1500)]

HELIXD_COMPID = int(LinkConfig.model_fields["source_component"].default)
GCS_SYSID = 255  # QGroundControl / Mission Planner
GCS_COMPID = 190
STRANGER_SYSID = 251  # not in serve.gcs_system_ids
HOME_LATLON = (-35.363261, 149.165230)  # conftest.HOME: where the rover boots

SWITCH_CH = 7  # RC7_OPTION 0 (nothing); MODE_CH is 8, outputs 1..4 are the scrolls
LOW_US, HIGH_US = 1100, 1900
RC_TOLERANCE_US = 10
WAYPOINTS_NE_M = [(8.0, 0.0), (8.0, 8.0), (0.0, 8.0)]  # from home: north, then east, then south
LAST_ITEM = len(WAYPOINTS_NE_M)  # home is item 0
PAUSE_LEG1_AT_M = 3.0  # distance from the start on leg 1 where the switch goes low
PAUSE_LEG2_AT_M = 3.0  # metres east of waypoint 1 on leg 2 where the GCS pauses
ARRIVAL_TOLERANCE_M = 1.0

# on the Helix plant the ground station's missions fly in SCROLL (over CONFIG's ROLL)
HELIX_MODE: dict[str, Any] = {"mission": {"ground_station_mode": "scroll"}}
CONFIG: dict[str, Any] = {
    "mission": {"ground_station_mode": "roll"},
    "startup": {"start_switch_channel": SWITCH_CH},
    "serve": {
        "gcs_system_ids": [GCS_SYSID],
        "mission_poll_s": 1.0,
        "tick_s": 0.05,
        "state_rate_hz": 2.0,
    },
}

# Wall-clock bounds (s): generous, the machine may be busy with another suite.
STATE_WAIT_S = 120.0
DRIVE_WAIT_S = 180.0
SECURE_WAIT_S = 10.0
ACK_WAIT_S = 10.0
UPLOAD_WAIT_S = 30.0
MISSION_WAIT_S = 600.0
HEARTBEAT_PERIOD_S = 1.0

TS_RE = re.compile(r"\bts=(\S+)")


def mono_of(line: str) -> float:
    """When the daemon logged a logfmt line (its ``ts``, ISO-8601 UTC), on this process's
    time.monotonic() clock."""
    match = TS_RE.search(line)
    assert match is not None, f"no ts in {line!r}"
    logged = datetime.fromisoformat(match.group(1).replace("Z", "+00:00")).timestamp()
    return logged - (time.time() - time.monotonic())


# ---------------------------------------------------------------------------------------------
# The ground station


@dataclass
class GroundStation(MavClient):
    """A QGroundControl-like client on one SITL TCP port: system 255, HEARTBEAT at 1 Hz, the
    mission protocol, COMMAND_LONG to helixd; records helixd's COMMAND_ACKs and STATUSTEXTs
    and the autopilot's MISSION_CURRENT as it receives them."""

    helixd_acks: list[tuple[int, int, int, float]] = field(default_factory=list)
    helixd_texts: list[str] = field(default_factory=list)
    mission_requests: list[int] = field(default_factory=list)
    mission_acks: list[int] = field(default_factory=list)
    # every COMMAND_ACK from a component of the vehicle's system: (compid, command, result)
    acks_from: list[tuple[int, int, int]] = field(default_factory=list)
    mission_current: list[tuple[float, int]] = field(default_factory=list)  # (wall s, seq)
    _hb_stop: threading.Event = field(default_factory=threading.Event)

    def wait_helixd_says(self, state: str, timeout_s: float) -> None:
        """Until helixd's STATUSTEXT ``helixd: <state>…`` reaches the ground station."""
        self.wait_until(
            lambda: any(t.startswith(f"helixd: {state}") for t in self.helixd_texts),
            timeout_s,
            f"STATUSTEXT 'helixd: {state}' at the ground station",
        )

    def __post_init__(self) -> None:
        super().__post_init__()
        self.mav = mavlink2.MAVLink(None, srcSystem=GCS_SYSID, srcComponent=GCS_COMPID)
        self.stranger = mavlink2.MAVLink(None, srcSystem=STRANGER_SYSID, srcComponent=GCS_COMPID)
        self._hb = threading.Thread(target=self._heartbeats, name="gcs-heartbeat", daemon=True)
        self._hb.start()

    def _heartbeats(self) -> None:
        """QGC's 1 Hz HEARTBEAT: how the autopilot learns the route to system 255."""
        while not self._hb_stop.is_set() and self.closed_reason is None:
            try:
                self.heartbeat()
            except OSError:
                return
            self._hb_stop.wait(HEARTBEAT_PERIOD_S)  # the period, not a synchronisation

    def heartbeat(self) -> None:
        self.send(
            self.mav.heartbeat_encode(
                mavlink2.MAV_TYPE_GCS,
                mavlink2.MAV_AUTOPILOT_INVALID,
                0,
                0,
                mavlink2.MAV_STATE_ACTIVE,
            )
        )

    def _handle(self, msg: Any) -> None:
        kind = str(msg.get_type())
        src = (int(msg.get_srcSystem()), int(msg.get_srcComponent()))
        target = int(getattr(msg, "target_system", 0) or 0)
        with self._cond:
            if src == (HELIXD_SYSID, HELIXD_COMPID):
                if kind == "COMMAND_ACK":
                    self.helixd_acks.append(
                        (target, int(msg.command), int(msg.result), time.monotonic())
                    )
                elif kind == "STATUSTEXT":
                    self.helixd_texts.append(str(msg.text))
                self._cond.notify_all()
                return
            if src[0] == AUTOPILOT_SYSID:
                if kind in ("MISSION_REQUEST", "MISSION_REQUEST_INT") and target == GCS_SYSID:
                    self.mission_requests.append(int(msg.seq))
                elif kind == "MISSION_ACK" and target == GCS_SYSID:
                    self.mission_acks.append(int(msg.type))
                elif kind == "COMMAND_ACK" and target == GCS_SYSID:
                    self.acks.append((int(msg.command), int(msg.result)))
                    self.acks_from.append((src[1], int(msg.command), int(msg.result)))
                elif kind == "MISSION_CURRENT":
                    seq = int(msg.seq)
                    if not self.mission_current or self.mission_current[-1][1] != seq:
                        self.mission_current.append((time.monotonic(), seq))
        super()._handle(msg)

    # -- the mission protocol -----------------------------------------------------------------

    def upload(self, points_ne_m: list[tuple[float, float]], timeout_s: float) -> None:
        """Home + one NAV_WAYPOINT per point (north/east of home); MISSION_ACK ACCEPTED."""
        self.upload_items([(n, e) for n, e in points_ne_m], timeout_s)

    def upload_items(
        self, entries: list[tuple[float, float] | tuple[int, tuple[float, ...]]], timeout_s: float
    ) -> None:
        """Home + the items: a NAV_WAYPOINT (north, east of home) or a DO command
        (MAV_CMD, its params 1..4); MISSION_ACK ACCEPTED."""
        items = [self._waypoint(0, 0.0, 0.0)]
        for seq, entry in enumerate(entries, start=1):
            first, rest = entry
            if isinstance(rest, tuple):
                items.append(self._do_item(seq, int(first), rest))
            else:
                items.append(self._waypoint(seq, float(first), rest))
        with self._cond:
            self.mission_requests.clear()
            self.mission_acks.clear()
        self.send(
            self.mav.mission_count_encode(
                AUTOPILOT_SYSID, AUTOPILOT_COMPID, len(items), mavlink2.MAV_MISSION_TYPE_MISSION
            )
        )
        answered = 0
        deadline = time.monotonic() + timeout_s

        def next_event() -> tuple[str, int] | None:
            if self.mission_acks:
                return ("ack", self.mission_acks[0])
            if len(self.mission_requests) > answered:
                return ("request", self.mission_requests[answered])
            return None

        while True:
            kind, value = self.wait_value(
                next_event, max(deadline - time.monotonic(), 0.1), "the mission upload"
            )
            if kind == "ack":
                assert value == mavlink2.MAV_MISSION_ACCEPTED, (
                    f"upload refused: MISSION_ACK {value}"
                )
                return
            answered += 1
            self.send(items[value])

    def _waypoint(self, seq: int, north_m: float, east_m: float) -> Any:
        lat, lon = ne_to_latlon(north_m, east_m, *HOME_LATLON)
        return self.mav.mission_item_int_encode(
            AUTOPILOT_SYSID, AUTOPILOT_COMPID, seq, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
            mavlink2.MAV_CMD_NAV_WAYPOINT, 0, 1, 0.0, 0.0, 0.0, 0.0,
            round(lat * 1e7), round(lon * 1e7), 0.0, mavlink2.MAV_MISSION_TYPE_MISSION,
        )  # fmt: skip

    def _do_item(self, seq: int, command: int, params: tuple[float, ...]) -> Any:
        p1, p2, p3, p4 = (*params, 0.0, 0.0, 0.0, 0.0)[:4]
        return self.mav.mission_item_int_encode(
            AUTOPILOT_SYSID, AUTOPILOT_COMPID, seq, mavlink2.MAV_FRAME_MISSION, command, 0, 1,
            p1, p2, p3, p4, 0, 0, 0.0, mavlink2.MAV_MISSION_TYPE_MISSION,
        )  # fmt: skip

    # -- commands to helixd -------------------------------------------------------------------

    def command_helixd(
        self, command: int, *params: float, as_stranger: bool = False
    ) -> tuple[int, float]:
        """COMMAND_LONG to helixd (247/191), sent once; (result of helixd's COMMAND_ACK, its
        wall-clock latency in s)."""
        sender = STRANGER_SYSID if as_stranger else GCS_SYSID
        encoder = self.stranger if as_stranger else self.mav
        padded = (*params, *(0.0,) * (7 - len(params)))
        self.heartbeat()
        with self._cond:
            seen = len(self.helixd_acks)
        sent = time.monotonic()
        frame = encoder.command_long_encode(HELIXD_SYSID, HELIXD_COMPID, command, 0, *padded)
        data = frame.pack(encoder)  # the header's system id is the packing encoder's
        with self._send_lock:
            self.sock.sendall(data)

        def ack() -> tuple[int, float] | None:
            for target, cmd, result, wall in self.helixd_acks[seen:]:
                if cmd == command and target == sender:
                    return result, wall - sent
            return None

        return self.wait_value(ack, ACK_WAIT_S, f"helixd's COMMAND_ACK for {command} ({sender})")

    def seq(self) -> int | None:
        with self._cond:
            return self.mission_current[-1][1] if self.mission_current else None

    def close(self) -> None:
        self._hb_stop.set()
        super().close()


# ---------------------------------------------------------------------------------------------


def serve_proc(
    tmp_path: Path, vehicle: SitlVehicle, config: dict[str, Any] | None = None
) -> DaemonProc:
    """``helixd serve`` on SERIAL0 with the suite's setup and ``config`` (this module's
    CONFIG unless given) merged over it."""
    if vehicle.plant is None:  # rover-skid: the suite's skid mapping
        cfg = deep_merge(
            helixd_sitl_config("rc_override", vehicle.helixd_url),
            CONFIG if config is None else config,
        )
    else:  # the Helix plant: helixd's defaults
        cfg = deep_merge(
            helix_sitl_config(vehicle.helixd_url), CONFIG if config is None else config
        )
        cfg = deep_merge(cfg, HELIX_MODE)
    cfg_path = tmp_path / "helixd-serve.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg, sort_keys=False), encoding="utf-8")
    run_root = tmp_path / "runs"
    return spawn_daemon(
        ["serve", "--connect", vehicle.helixd_url, "--config", str(cfg_path), "--run-dir",
         str(run_root)],
        cwd=tmp_path,
        run_root=run_root,
    )  # fmt: skip


@dataclass
class Clock:
    """Phase figures, printed at the end (wall-clock seconds)."""

    rows: list[tuple[str, float]] = field(default_factory=list)

    def add(self, what: str, seconds: float) -> None:
        self.rows.append((what, seconds))
        print(f"serve SITL: {what}: {seconds:.2f} s")


@pytest.fixture(params=[None, "hard"], ids=["rover-skid", "helix"])
def serve_sitl(tmp_path: Path, request: pytest.FixtureRequest) -> Iterator[SitlVehicle]:
    """The suite's rover-skid SITL, and the Helix plant on hard ground (``--model JSON``)."""
    yield from start_test_sitl(tmp_path, guard=True, terrain=request.param)


def test_serve_start_pause_continue(serve_sitl: SitlVehicle, tmp_path: Path) -> None:
    sitl = serve_sitl
    obs = sitl.obs
    obs.set_message_interval(mavlink2.MAVLINK_MSG_ID_RC_CHANNELS, STREAM_RATE_HZ)
    home_ne = sitl.start_ne_m
    targets = [(home_ne[0] + n, home_ne[1] + e) for n, e in WAYPOINTS_NE_M]
    clock = Clock()

    def rc_switch(value_us: int) -> float:
        """The pilot flips the switch; returns when (wall) the radio sent it, once ArduPilot's
        RC_CHANNELS shows it."""
        sent = time.monotonic()
        sitl.pilot_rc({SWITCH_CH: value_us})
        obs.wait_until(
            lambda: (
                (rc := obs.latest.get("RC_CHANNELS")) is not None
                and abs(int(getattr(rc, f"chan{SWITCH_CH}_raw")) - value_us) <= RC_TOLERANCE_US
            ),
            SECURE_WAIT_S,
            f"RC{SWITCH_CH} at {value_us} µs",
        )
        return sent

    def distance(a: tuple[float, float]) -> float | None:
        p = obs.position()
        return None if p is None else math.hypot(p.north_m - a[0], p.east_m - a[1])

    def secured_since(t0: float, what: str) -> tuple[float, float]:
        """Outputs 1/3 at trim and HOLD after wall time t0: (trim latency, HOLD latency)."""

        def trim_at() -> float | None:
            return next(
                (s.wall_s for s in obs.servo
                 if s.wall_s >= t0 and outputs_near(s.pwm_us, NEUTRAL_US)),
                None,
            )  # fmt: skip

        def hold_at() -> float | None:
            return next((w for w, m in obs.mode_changes if m == MODE_HOLD and w >= t0), None)

        obs.wait_until(
            lambda: trim_at() is not None and hold_at() is not None,
            SECURE_WAIT_S,
            f"outputs 1/3 at trim and a switch to HOLD after {what}",
            abort=d.ended,
        )
        trim, hold = trim_at(), hold_at()
        assert trim is not None and hold is not None
        return trim - t0, hold - t0

    def held_still(t_from: float, t_to: float, what: str) -> None:
        """Every SERVO_OUTPUT_RAW between the two wall times at trim; the rover stopped."""
        samples = [s for s in obs.servo if t_from <= s.wall_s <= t_to]
        assert samples, f"no SERVO_OUTPUT_RAW while {what}"
        bad = [s.pwm_us for s in samples if not outputs_near(s.pwm_us, NEUTRAL_US)]
        assert not bad, f"outputs left trim while {what}: {bad[:5]}"

    # the switch is low before helixd comes up (a switch first seen high is no start)
    rc_switch(LOW_US)
    gcs = GroundStation(
        connect_tcp(SERIAL2_PORT + PORT_STRIDE * sitl.instance, CONNECT_TIMEOUT_S, sitl.dead),
        "gcs",
    )
    gcs.set_message_interval(mavlink2.MAVLINK_MSG_ID_MISSION_CURRENT, 5.0)
    t_spawn = time.monotonic()
    d = serve_proc(tmp_path, sitl)
    try:
        d.wait_line("no mission on the autopilot", STATE_WAIT_S)
        clock.add("helixd serve spawned → state=idle (no mission)", time.monotonic() - t_spawn)
        assert not obs.armed()

        # -- the ground station uploads; helixd checks it and waits --------------------------
        mark = d.mark()
        t_upload = time.monotonic()
        gcs.upload(WAYPOINTS_NE_M, UPLOAD_WAIT_S)
        t_uploaded = time.monotonic()
        clock.add("mission upload (mission protocol, 4 items)", t_uploaded - t_upload)
        ready = d.wait_line("event=serve_state state=ready", STATE_WAIT_S, after=mark)
        clock.add("upload acknowledged → state=ready", mono_of(ready) - t_uploaded)
        gcs.wait_helixd_says("ready", STATE_WAIT_S)
        assert f"{len(WAYPOINTS_NE_M)} waypoints" in ready, ready
        assert not obs.armed(), "helixd armed on its own after the upload"

        # -- switch high: flying --------------------------------------------------------------
        mark = d.mark()
        t_high = rc_switch(HIGH_US)
        flying = d.wait_line("event=serve_state state=flying", STATE_WAIT_S, after=mark)
        clock.add("switch high → state=flying", mono_of(flying) - t_high)
        sitl.wait_driving(d, 1.0, DRIVE_WAIT_S)
        t_moving = time.monotonic()
        clock.add("switch high → driving ≥ 1 m (LOCAL_POSITION_NED)", t_moving - t_high)
        gcs.wait_until(lambda: gcs.seq() == 1, SECURE_WAIT_S, "MISSION_CURRENT 1 on leg 1")

        # a stranger is denied; the ground station cannot start a second flight
        result, _ = gcs.command_helixd(MAV_CMD_DO_PAUSE_CONTINUE, 0, as_stranger=True)
        assert result == MAV_RESULT_DENIED, result
        result, _ = gcs.command_helixd(MAV_CMD_MISSION_START, 0, 0)
        assert result == MAV_RESULT_TEMPORARILY_REJECTED, result

        # -- switch low on leg 1: paused -------------------------------------------------------
        obs.wait_until(
            lambda: (m := sitl.distance_from_start_m()) is not None and m >= PAUSE_LEG1_AT_M,
            DRIVE_WAIT_S,
            f"{PAUSE_LEG1_AT_M} m along leg 1",
            abort=d.ended,
        )
        mark = d.mark()
        t_low = rc_switch(LOW_US)
        trim_s, hold_s = secured_since(t_low, "the switch went low")
        clock.add("switch low → outputs 1/3 at trim (SERVO_OUTPUT_RAW)", trim_s)
        clock.add("switch low → HOLD (HEARTBEAT)", hold_s)
        paused = d.wait_line("event=serve_state state=paused", STATE_WAIT_S, after=mark)
        clock.add("switch low → state=paused", mono_of(paused) - t_low)
        left = distance(targets[0])
        assert left is not None and left > ARRIVAL_TOLERANCE_M, "paused at waypoint 1, not on leg 1"
        print(f"serve SITL: paused by the switch {left:.2f} m before waypoint 1")

        # the pilot's veto: the ground station cannot continue while the switch is low
        result, ack_s = gcs.command_helixd(MAV_CMD_DO_PAUSE_CONTINUE, 1)
        assert result == MAV_RESULT_DENIED, result
        clock.add("DO_PAUSE_CONTINUE 1, switch low → helixd's COMMAND_ACK (DENIED)", ack_s)
        held_still(t_low + trim_s, time.monotonic(), "paused by the switch")
        assert obs.mode() == MODE_HOLD

        # -- switch high again: continues from leg 1 ------------------------------------------
        mark = mark_c1 = d.mark()
        t_high2 = rc_switch(HIGH_US)
        resumed = d.wait_line("event=run_resumed", STATE_WAIT_S, after=mark)
        clock.add("switch high → event=run_resumed", mono_of(resumed) - t_high2)
        d.wait_line("event=serve_state state=flying", STATE_WAIT_S, after=mark)
        obs.wait_until(
            lambda: (m := distance(targets[0])) is not None and m <= ARRIVAL_TOLERANCE_M,
            DRIVE_WAIT_S,
            "waypoint 1 reached after the switch's continue",
            abort=d.ended,
        )
        clock.add("switch high → at waypoint 1", time.monotonic() - t_high2)

        # -- DO_PAUSE_CONTINUE 0 from the ground station on leg 2 -----------------------------
        obs.wait_until(
            lambda: (
                (p := obs.position()) is not None and p.east_m - targets[0][1] >= PAUSE_LEG2_AT_M
            ),
            DRIVE_WAIT_S,
            f"{PAUSE_LEG2_AT_M} m along leg 2",
            abort=d.ended,
        )
        gcs.wait_until(lambda: gcs.seq() == 2, SECURE_WAIT_S, "MISSION_CURRENT 2 on leg 2")
        mark = d.mark()
        t_pause = time.monotonic()
        result, ack_s = gcs.command_helixd(MAV_CMD_DO_PAUSE_CONTINUE, 0)
        assert result == MAV_RESULT_ACCEPTED, result
        clock.add("DO_PAUSE_CONTINUE 0 → helixd's COMMAND_ACK", ack_s)
        trim_s2, hold_s2 = secured_since(t_pause, "DO_PAUSE_CONTINUE 0")
        clock.add("DO_PAUSE_CONTINUE 0 → outputs 1/3 at trim", trim_s2)
        clock.add("DO_PAUSE_CONTINUE 0 → HOLD", hold_s2)
        paused2 = d.wait_line("event=serve_state state=paused", STATE_WAIT_S, after=mark)
        clock.add("DO_PAUSE_CONTINUE 0 → state=paused", mono_of(paused2) - t_pause)
        gcs.wait_helixd_says("paused", STATE_WAIT_S)
        pause_pos = obs.position()
        assert pause_pos is not None

        # -- DO_PAUSE_CONTINUE 1: continues on leg 2 and completes ----------------------------
        mark = mark_c2 = d.mark()
        t_cont = time.monotonic()
        held_still(t_pause + trim_s2, t_cont, "paused by the ground station")
        result, ack_s = gcs.command_helixd(MAV_CMD_DO_PAUSE_CONTINUE, 1)
        assert result == MAV_RESULT_ACCEPTED, result
        clock.add("DO_PAUSE_CONTINUE 1 → helixd's COMMAND_ACK", ack_s)
        resumed2 = d.wait_line("event=run_resumed", STATE_WAIT_S, after=mark)
        clock.add("DO_PAUSE_CONTINUE 1 → event=run_resumed", mono_of(resumed2) - t_cont)
        completed = d.wait_line("event=serve_state state=completed", MISSION_WAIT_S, after=mark)
        t_done = mono_of(completed)
        clock.add("DO_PAUSE_CONTINUE 1 → state=completed", t_done - t_cont)
        clock.add("switch first high → state=completed (with both pauses)", t_done - t_high)
        obs.wait_until(
            lambda: outputs_near(obs.servo_pwm(), NEUTRAL_US) and obs.mode() == MODE_HOLD,
            SECURE_WAIT_S,
            "outputs 1/3 at trim and HOLD after the mission",
            abort=d.ended,
        )
        end_error = distance(targets[-1])
        assert end_error is not None and end_error <= ARRIVAL_TOLERANCE_M, end_error
        print(f"serve SITL: final position {end_error:.2f} m from waypoint {LAST_ITEM}")

        # The current item followed the flight: 1, 2, 3, never back (across both continues).
        # helixd disarms when it pauses and when it completes, and Rover resets its mission on
        # a disarm outside AUTO (AP_Arming_Rover::disarm → AP_Mission::reset), so MISSION_CURRENT
        # reads 0 while paused and after the end: allowed there, nowhere else.
        # A 0 may arrive from the action that paused (or the last leg's stop) until helixd set
        # the item of the continued flight (its "mission_current_set" log line, after the ack).
        def item_set_after(line_mark: int) -> float:
            return mono_of(d.wait_line("event=mission_current_set", 0.0, after=line_mark))

        t_stop_last = mono_of(d.wait_line("event=phase_start phase=stop", 0.0, after=mark))
        idle = [
            (t_low, item_set_after(mark_c1)),
            (t_pause, item_set_after(mark_c2)),
            (t_stop_last, math.inf),
        ]
        history = [(wall, seq) for wall, seq in gcs.mission_current if wall >= t_high]
        before = [seq for wall, seq in gcs.mission_current if wall < t_high][-1:]
        shown = " ".join(f"{seq}@{wall - t_high:.1f}s" for wall, seq in history)
        print(f"serve SITL: MISSION_CURRENT at the GCS (before the start: {before}): {shown}")
        stray = [
            (round(wall - t_high, 2), seq)
            for wall, seq in history
            if seq == 0 and not any(a <= wall <= b for a, b in idle)
        ]
        assert not stray, f"MISSION_CURRENT 0 while flying (s after the start, seq): {stray}"
        flown: list[int] = []
        for seq in [*before, *(seq for _, seq in history)]:
            if seq != 0 and (not flown or flown[-1] != seq):
                flown.append(seq)
        assert flown == list(range(1, LAST_ITEM + 1)), gcs.mission_current
        print(f"serve SITL: armed at the end: {obs.armed()}; helixd texts: {gcs.helixd_texts}")
        assert d.ended() is None, "helixd serve exited"
    finally:
        gcs.close()
        d.stop(DAEMON_STOP_TIMEOUT_S)
        (tmp_path / "serve.log").write_text(d.log_text(), encoding="utf-8")

    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    summaries = [json.loads((r / "summary.json").read_text()) for r in runs]
    assert [s["completed"] for s in summaries] == [False, False, True], runs
    assert all(s["resumed_from"] is not None for s in summaries[1:]), summaries
    states = [ln.split("state=")[1].split()[0] for ln in d.lines if "event=serve_state" in ln]
    print(f"serve SITL: states {states}")
    print("serve SITL figures:\n" + "\n".join(f"  {w:<60} {s:7.2f} s" for w, s in clock.rows))
