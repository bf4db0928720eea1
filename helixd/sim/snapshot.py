"""Thread-safe views of the running simulator: immutable snapshots and the event history."""

from __future__ import annotations

import math
import threading
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from helixd.mav.constants import (
    MAV_MISSION_TYPE_FENCE,
    MAV_MISSION_TYPE_MISSION,
    MAV_MISSION_TYPE_RALLY,
)
from helixd.plant.forward import radps_to_rpm
from helixd.sim.core import SimCore
from helixd.sim.firmware import modes
from helixd.sim.firmware.mission_items import StoredItem


@dataclass(frozen=True, slots=True)
class SimSnapshot:
    sim_time_s: float
    time_boot_ms: int
    silent: bool  # rebooting: no MAVLink at all
    booting: bool  # HEARTBEAT custom_mode 16
    mode: str
    mode_number: int
    armed: bool
    outputs_us: tuple[int, ...]  # SERVO1..16 (0 = no pulses)
    rc_in_us: tuple[int, ...]  # RC1..16 as the autopilot uses them (override or radio)
    pilot_rc_us: tuple[int, ...]  # what the pilot's transmitter sends
    receiver_ok: bool
    overrides_active: tuple[bool, ...]  # RC1..16
    override_us: tuple[int, ...]
    latched_servo_channels: tuple[int, ...]  # DO_SET_SERVO latched (1-based)
    held_servo_channels: tuple[int, ...]  # under a script's timed override (1-based)
    scroll_pwm_us: tuple[int, int, int, int]  # the outputs driving scrolls 1..4
    scroll_rpm: tuple[float, float, float, float]
    north_m: float  # truth
    east_m: float
    yaw_ned_rad: float
    est_north_m: float  # what LOCAL_POSITION_NED / ATTITUDE report
    est_east_m: float
    est_yaw_ned_rad: float
    speed_mps: float
    vx_body_mps: float
    vy_body_mps: float
    wz_body_radps: float
    pit_depth: float
    odometer_m: float
    params: Mapping[str, float]
    faults_active: frozenset[str]
    failsafe_radio: bool
    failsafe_gcs: bool
    failsafe_ekf: bool
    failsafe_triggered: bool
    ekf_flags: int
    gcs_heartbeats_seen: int
    gcs_last_seen_s: float | None
    terrain: str
    # the stored mission protocol items (helixd.sim.firmware.mission_server); row 0 of the
    # mission is home
    mission_items: tuple[StoredItem, ...] = ()
    fence_items: tuple[StoredItem, ...] = ()
    rally_items: tuple[StoredItem, ...] = ()
    mission_current_seq: int = 0
    guard_version: int | None = None  # helixd-guard.lua running (its VERSION); None: not
    guard_guarding: bool = False  # the guard holds the scrolls (helixd silent while armed)
    home_ne_m: tuple[float, float] | None = None  # the autopilot's home (None: not set)
    relays_on: tuple[int, ...] = ()  # relay instances switched on (0 = RELAY1)
    pictures: int = 0  # camera pictures taken (CAM1_TYPE set)

    def describe(self) -> str:
        return (
            f"t={self.sim_time_s:.2f}s mode={self.mode} armed={self.armed} "
            f"outputs1-8={list(self.outputs_us[:8])} overrides={self.overrides_active[:8]} "
            f"pose=({self.north_m:.2f}N {self.east_m:.2f}E "
            f"{math.degrees(self.yaw_ned_rad):.1f}°) faults={sorted(self.faults_active)}"
        )


def take_snapshot(core: SimCore) -> SimSnapshot:
    """Copy of the core's state (call on the simulator thread)."""
    ap, phys, view = core.ap, core.phys, core.view
    now = core.now_s
    timeout = core.params.get("RC_OVERRIDE_TIME")
    outputs = tuple(core.outputs_us)
    chans = core.config.scroll_output_channels
    return SimSnapshot(
        sim_time_s=now,
        time_boot_ms=ap.time_boot_ms(now),
        silent=ap.silent(now),
        booting=ap.booting(now),
        mode=modes.mode_name(ap.mode),
        mode_number=ap.mode,
        armed=ap.armed,
        outputs_us=outputs,
        rc_in_us=tuple(ap.rc.radio_in_us),
        pilot_rc_us=tuple(ap.pilot_rc_us),
        receiver_ok=ap.receiver_ok,
        overrides_active=ap.rc.active_overrides(now, timeout),
        override_us=tuple(ap.rc.override_us),
        latched_servo_channels=ap.outputs.latched_channels(),
        held_servo_channels=ap.outputs.held_channels(),
        scroll_pwm_us=(
            outputs[chans[0] - 1],
            outputs[chans[1] - 1],
            outputs[chans[2] - 1],
            outputs[chans[3] - 1],
        ),
        scroll_rpm=(
            radps_to_rpm(phys.scroll_radps[0]),
            radps_to_rpm(phys.scroll_radps[1]),
            radps_to_rpm(phys.scroll_radps[2]),
            radps_to_rpm(phys.scroll_radps[3]),
        ),
        north_m=phys.north_m,
        east_m=phys.east_m,
        yaw_ned_rad=phys.yaw_ned_rad,
        est_north_m=view.estimate.north_m,
        est_east_m=view.estimate.east_m,
        est_yaw_ned_rad=view.estimate.yaw_ned_rad,
        speed_mps=phys.speed_mps,
        vx_body_mps=phys.vx_body_mps,
        vy_body_mps=phys.vy_body_mps,
        wz_body_radps=phys.wz_body_radps,
        pit_depth=phys.pit_depth,
        odometer_m=phys.odometer_m,
        params=core.params_view(),
        faults_active=frozenset(core.faults.active),
        failsafe_radio=ap.failsafes.radio_on(),
        failsafe_gcs=ap.failsafes.gcs_on(),
        failsafe_ekf=ap.failsafes.ekf_failsafe,
        failsafe_triggered=bool(ap.failsafes.triggered),
        ekf_flags=view.ekf.flags,
        gcs_heartbeats_seen=ap.gcs_heartbeats_seen,
        gcs_last_seen_s=ap.gcs_last_seen_s,
        terrain=core.config.terrain.value,
        mission_items=core.mission.stored(MAV_MISSION_TYPE_MISSION),
        fence_items=core.mission.stored(MAV_MISSION_TYPE_FENCE),
        rally_items=core.mission.stored(MAV_MISSION_TYPE_RALLY),
        mission_current_seq=core.mission.current_seq,
        guard_version=None if ap.guard is None else ap.guard.version,
        guard_guarding=ap.guard is not None and ap.guard.machine.guarding,
        home_ne_m=None if ap.home is None else (ap.home.north_m, ap.home.east_m),
        relays_on=tuple(sorted(i for i, on in ap.payload.relays.items() if on)),
        pictures=ap.payload.pictures,
    )


@dataclass(frozen=True, slots=True)
class HistoryEntry:
    wall_monotonic_s: float
    sim_time_s: float
    kind: str
    details: Mapping[str, object] = field(default_factory=dict)


class History:
    """Append-only, thread-safe log of what happened (oldest entries dropped past the cap)."""

    def __init__(self, max_entries: int) -> None:
        self._entries: deque[HistoryEntry] = deque(maxlen=max_entries)
        self._lock = threading.Lock()
        self._appended = 0

    def append(self, entry: HistoryEntry) -> None:
        with self._lock:
            self._entries.append(entry)
            self._appended += 1

    def __len__(self) -> int:
        with self._lock:
            return len(self._entries)

    def entries(self, kind: str | None = None) -> list[HistoryEntry]:
        with self._lock:
            items = list(self._entries)
        return items if kind is None else [e for e in items if e.kind == kind]

    def first(
        self,
        kind: str,
        predicate: Callable[[HistoryEntry], bool] | None = None,
        after_wall_s: float | None = None,
    ) -> HistoryEntry | None:
        for entry in self.entries(kind):
            if after_wall_s is not None and entry.wall_monotonic_s < after_wall_s:
                continue
            if predicate is None or predicate(entry):
                return entry
        return None
