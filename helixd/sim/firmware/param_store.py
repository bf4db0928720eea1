"""The ArduPilot Rover parameters the simulator models, with their defaults and MAVLink types.

Names follow current ArduPilot master: ``MAV_SYSID`` / ``MAV_GCS_SYSID`` / ``MAV_GCS_SYSID_HI``
/ ``MAV_OPTIONS`` (libraries/GCS_MAVLink/GCS.cpp var_info) replaced ``SYSID_THISMAV`` /
``SYSID_MYGCS``, which therefore do not exist here. Servo outputs 1–4 default to RCIN1..RCIN4
passthrough (51..54), 16 to 94 (Script1, a spare output nothing is connected to: without a
motor, sail or scripting output ArduPilot refuses a normal arm, :mod:`helixd.mav.arming`) and
5..15 to 0 — the Helix per-scroll setup; stock Rover would have SERVO1_FUNCTION 26 (steering)
and SERVO3_FUNCTION 70 (throttle).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from enum import IntEnum
from types import MappingProxyType

from helixd.mav.arming import K_SCRIPTING1


class ParamType(IntEnum):
    """MAV_PARAM_TYPE values ArduPilot reports in PARAM_VALUE."""

    INT8 = 2
    INT16 = 4
    INT32 = 6
    REAL32 = 9


@dataclass(frozen=True, slots=True)
class SimParamSpec:
    default: float
    kind: ParamType


HELIX_SPARE_OUTPUT = 16  # SERVO16_FUNCTION = 94 (Script1): lets a passthrough Helix arm


def _helix_function(n: int) -> int:
    """The Helix's SERVOn_FUNCTION: RCINn on the scroll outputs 1-4, Script1 on the spare."""
    if n <= 4:
        return 50 + n
    return K_SCRIPTING1 if n == HELIX_SPARE_OUTPUT else 0


def _build_defaults() -> dict[str, SimParamSpec]:
    i8, i16, i32, f32 = ParamType.INT8, ParamType.INT16, ParamType.INT32, ParamType.REAL32
    table: dict[str, SimParamSpec] = {
        "MAV_SYSID": SimParamSpec(1, i16),
        "MAV_GCS_SYSID": SimParamSpec(255, i16),
        "MAV_GCS_SYSID_HI": SimParamSpec(0, i16),
        "MAV_OPTIONS": SimParamSpec(0, i16),
        "SCHED_LOOP_RATE": SimParamSpec(50, i16),  # Rover default; takes effect after reboot
        "RC_OVERRIDE_TIME": SimParamSpec(3.0, f32),  # RC_Channels.cpp _OVERRIDE_TIME
        "RC_OPTIONS": SimParamSpec(0, i32),
        "RC_FS_TIMEOUT": SimParamSpec(1.0, f32),
        "RCMAP_THROTTLE": SimParamSpec(3, i8),
        "FS_ACTION": SimParamSpec(2, i8),  # 2 = Hold
        "FS_TIMEOUT": SimParamSpec(1.5, f32),
        "FS_OPTIONS": SimParamSpec(0, i32),
        "FS_GCS_ENABLE": SimParamSpec(0, i8),
        "FS_GCS_TIMEOUT": SimParamSpec(5.0, f32),
        "FS_THR_ENABLE": SimParamSpec(1, i8),
        "FS_THR_VALUE": SimParamSpec(910, i16),
        "FS_EKF_ACTION": SimParamSpec(1, i8),  # 1 = Hold
        "FS_EKF_THRESH": SimParamSpec(0.8, f32),
        # AP_BattMonitor_Params: no action by default; AC_Fence: off, action 1 (Rover: RTL)
        "BATT_FS_LOW_ACT": SimParamSpec(0, i8),
        "BATT_FS_CRT_ACT": SimParamSpec(0, i8),
        "FENCE_ENABLE": SimParamSpec(0, i8),
        "FENCE_ACTION": SimParamSpec(1, i8),
        "INITIAL_MODE": SimParamSpec(0, i8),
        "MODE_CH": SimParamSpec(8, i8),
        "SCR_ENABLE": SimParamSpec(0, i8),  # AP_Scripting: scripts start at boot when 1
        "ARMING_SKIPCHK": SimParamSpec(0, i32),  # AP_Arming: checks to skip; -1 = all
        "WP_RADIUS": SimParamSpec(2.0, f32),  # AR_WPNav: a waypoint is reached within (m)
        "MIS_DONE_BEHAVE": SimParamSpec(0, i8),  # ModeAuto::exit_mission: 0 = HOLD (stop)
    }
    for n in range(1, 7):
        table[f"MODE{n}"] = SimParamSpec(0, i8)  # Rover Parameters.cpp: every MODEn = MANUAL
    for n in range(1, 17):
        table[f"RC{n}_MIN"] = SimParamSpec(1100, i16)
        table[f"RC{n}_TRIM"] = SimParamSpec(1500, i16)
        table[f"RC{n}_MAX"] = SimParamSpec(1900, i16)
        # Rover::init_rc_in sets a 30 µs dead zone on steering (1) and throttle (3)
        table[f"RC{n}_DZ"] = SimParamSpec(30 if n in (1, 3) else 0, i16)
        table[f"RC{n}_OPTION"] = SimParamSpec(0, i16)  # RC_Channel: aux function, 0 = none
    for n in range(1, 17):
        table[f"SERVO{n}_FUNCTION"] = SimParamSpec(_helix_function(n), i16)
        table[f"SERVO{n}_MIN"] = SimParamSpec(1100, i16)
        table[f"SERVO{n}_TRIM"] = SimParamSpec(1500, i16)
        table[f"SERVO{n}_MAX"] = SimParamSpec(1900, i16)
        table[f"SERVO{n}_REVERSED"] = SimParamSpec(0, i8)
    table["CAM1_TYPE"] = SimParamSpec(0, i8)  # 0: no camera (AP_Camera has no backend)
    table["GRIP_ENABLE"] = SimParamSpec(0, i8)
    for n in range(1, 7):  # AP_Relay: RELAYn_FUNCTION 1 = relay, and a pin, make it usable
        table[f"RELAY{n}_FUNCTION"] = SimParamSpec(0, i8)
        table[f"RELAY{n}_PIN"] = SimParamSpec(-1, i8)
    return table


DEFAULT_PARAMS: Mapping[str, SimParamSpec] = MappingProxyType(_build_defaults())


def _coerce(value: float, kind: ParamType) -> float:
    if kind is ParamType.REAL32:
        return float(value)
    return float(round(value))


class ParamStore:
    """Current values, in ArduPilot's order (PARAM_REQUEST_LIST index order).

    Besides the firmware's parameters, a running script may add its own
    (:meth:`add_script_param`, as ``param:add_param``; REAL32, listed after the firmware's).
    They exist only while the script runs: a reboot removes them, but their values stay in
    storage (``stored``) and come back when the script adds them again. ArduPilot does not
    take them from ``--defaults`` files either: a script's parameters load from storage only.
    """

    def __init__(
        self,
        overrides: Mapping[str, float] | None = None,
        stored: Mapping[str, float] | None = None,
    ) -> None:
        self._values: dict[str, float] = {k: float(s.default) for k, s in DEFAULT_PARAMS.items()}
        self._specs: dict[str, SimParamSpec] = dict(DEFAULT_PARAMS)
        self._stored: dict[str, float] = {k: float(v) for k, v in (stored or {}).items()}
        self._version = 0
        for name, value in (overrides or {}).items():
            self.set(name, value)
        # values the running "firmware" booted with (those read at boot: SCHED_LOOP_RATE, ...)
        self._boot_values = dict(self._values)

    @property
    def version(self) -> int:
        """Bumped on every change, so observers can cache copies."""
        return self._version

    def names(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __contains__(self, name: object) -> bool:
        return name in self._values

    def get(self, name: str) -> float:
        return self._values[name]

    def get_int(self, name: str) -> int:
        return int(self._values[name])

    def boot_value(self, name: str) -> float:
        """Value in effect for parameters that need a reboot to change."""
        return self._boot_values[name]

    def kind(self, name: str) -> ParamType:
        return self._specs[name].kind

    def index(self, name: str) -> int:
        return list(self._values).index(name)

    def name_at(self, index: int) -> str | None:
        if 0 <= index < len(self._values):
            return list(self._values)[index]
        return None

    def set(self, name: str, value: float) -> float:
        """Set a known parameter (KeyError otherwise); returns the stored value."""
        spec = self._specs[name]
        stored = _coerce(value, spec.kind)
        if name not in DEFAULT_PARAMS:
            self._stored[name] = stored
        if self._values[name] != stored:
            self._values[name] = stored
            self._version += 1
        return stored

    def add_script_param(self, name: str, default: float) -> float:
        """A script's ``param:add_param``: the parameter appears (REAL32) with its stored value,
        else ``default``; returns the value. Adding one that exists keeps it as it is."""
        if name in self._values:
            return self._values[name]
        self._specs[name] = SimParamSpec(default, ParamType.REAL32)
        self._values[name] = float(self._stored.get(name, default))
        self._version += 1
        return self._values[name]

    def on_reboot(self) -> None:
        for name in [n for n in self._values if n not in DEFAULT_PARAMS]:
            del self._values[name]
            del self._specs[name]
            self._version += 1
        self._boot_values = dict(self._values)

    def as_dict(self) -> dict[str, float]:
        return dict(self._values)

    def stored(self) -> dict[str, float]:
        """A script's parameter values in storage (kept while the script is not running)."""
        return dict(self._stored)
