"""helixd-guard, the dead-man switch that runs on the autopilot: its script and its parameters.

The Lua script ships inside this package (``helixd/mav/scripts/helixd-guard.lua``, package
data) so that an installed helixd finds it: ``helixd autopilot install-guard`` copies
:func:`script_bytes` onto the autopilot. It lives in :mod:`helixd.mav` because every user of
it may import this layer: the installer and preflight (link, runtime, CLI) and the simulator,
which runs the same guard logic (:mod:`helixd.sim.firmware.guard_model`) and reads these
parameter facts.

What the script defines and helixd relies on (``tests/sim/firmware/test_guard_model.py`` checks
that the constants here and in :mod:`helixd.sim.firmware.guard_model` match the Lua):

* its parameter table, key 144, prefix ``HXG_``: HXG_ENABLE (1), HXG_TIMEOUT (0.5 s, clamped
  to 0.1 … 10 s), HXG_CHAN1..4 (1, 2, 3, 4: the guarded 1-based servo outputs, 0 = none, values
  outside 1..16 ignored, duplicates guarded once), HXG_VERSION (set by the script);
* silent means ``now − gcs:last_seen() > timeout`` in whole milliseconds, where last_seen is
  refreshed by HEARTBEAT, RC_CHANNELS_OVERRIDE and MANUAL_CONTROL from MAV_GCS_SYSID (helixd),
  never by COMMAND_LONG.

Where scripts live (ArduPilot ``libraries/AP_Scripting/lua_common_defs.h``,
``SCRIPTING_DIRECTORY``): ``/APM/scripts`` on boards with an SD card (``HAL_OS_FATFS_IO``),
``./scripts`` elsewhere (SITL, Linux boards), relative to the autopilot's working directory.
MAVLink FTP paths go to ``AP_Filesystem`` unchanged, except that SITL strips a leading ``/``
(``AP_Filesystem_posix.cpp`` ``map_filename``): so :data:`BOARD_SCRIPTS_DIR` reaches the SD
card's folder and :data:`POSIX_SCRIPTS_DIR` (relative, no leading ``/``) reaches SITL's and a
Linux board's. Scripting creates its directory at start when ``SCR_ENABLE`` is 1 and loads the
scripts it finds there once, at boot.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources

__all__ = [
    "BOARD_SCRIPTS_DIR",
    "HXG_CHANS",
    "HXG_ENABLE",
    "HXG_TIMEOUT",
    "HXG_VERSION",
    "MAX_OUTPUT",
    "PARAM_DEFAULTS",
    "PARAM_PREFIX",
    "PARAM_TABLE_KEY",
    "POSIX_SCRIPTS_DIR",
    "SCRIPT_NAME",
    "SCR_ENABLE",
    "TIMEOUT_MAX_MS",
    "TIMEOUT_MIN_MS",
    "VERSION",
    "GuardParams",
    "script_bytes",
    "script_version",
    "to_ms",
]

VERSION = 1  # the packaged script's ``local VERSION``; HXG_VERSION says which one runs
SCRIPT_NAME = "helixd-guard.lua"
BOARD_SCRIPTS_DIR = "/APM/scripts"  # SD card (ChibiOS boards: HAL_OS_FATFS_IO)
POSIX_SCRIPTS_DIR = "scripts"  # ./scripts in the working directory (SITL, Linux boards)
SCR_ENABLE = "SCR_ENABLE"  # ArduPilot's scripting switch; read at boot

PARAM_TABLE_KEY = 144
PARAM_PREFIX = "HXG_"
MAX_OUTPUT = 16
TIMEOUT_MIN_MS = 100
TIMEOUT_MAX_MS = 10_000

HXG_ENABLE = "HXG_ENABLE"
HXG_TIMEOUT = "HXG_TIMEOUT"
HXG_CHANS = ("HXG_CHAN1", "HXG_CHAN2", "HXG_CHAN3", "HXG_CHAN4")
HXG_VERSION = "HXG_VERSION"

# name → default, in the Lua's table order (index 1..7)
PARAM_DEFAULTS: Mapping[str, float] = {
    HXG_ENABLE: 1.0,
    HXG_TIMEOUT: 0.5,
    HXG_CHANS[0]: 1.0,
    HXG_CHANS[1]: 2.0,
    HXG_CHANS[2]: 3.0,
    HXG_CHANS[3]: 4.0,
    HXG_VERSION: float(VERSION),
}

_VERSION_LINE = re.compile(rb"^local VERSION = (\d+)\s*(?:--.*)?$", re.MULTILINE)


def script_bytes() -> bytes:
    """The packaged ``helixd-guard.lua``, byte for byte what is installed on the autopilot."""
    return resources.files("helixd.mav").joinpath("scripts", SCRIPT_NAME).read_bytes()


def script_version(source: bytes) -> int | None:
    """The ``local VERSION = N`` a guard script declares (None: not a helixd-guard script)."""
    found = _VERSION_LINE.search(source)
    return None if found is None else int(found.group(1))


def to_ms(t_s: float) -> int:
    """Seconds → whole milliseconds (round half up), the unit of ArduPilot's millis()."""
    return math.floor(t_s * 1000.0 + 0.5)


def _lua_round(value: float) -> int:
    return math.floor(value + 0.5)


@dataclass(frozen=True, slots=True)
class GuardParams:
    """The HXG_ parameters as ArduPilot stores them (floats), read as the script reads them."""

    enable: float = PARAM_DEFAULTS[HXG_ENABLE]
    timeout_s: float = PARAM_DEFAULTS[HXG_TIMEOUT]
    chan1: float = PARAM_DEFAULTS[HXG_CHANS[0]]
    chan2: float = PARAM_DEFAULTS[HXG_CHANS[1]]
    chan3: float = PARAM_DEFAULTS[HXG_CHANS[2]]
    chan4: float = PARAM_DEFAULTS[HXG_CHANS[3]]

    def __post_init__(self) -> None:
        for name in ("enable", "timeout_s", "chan1", "chan2", "chan3", "chan4"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"GuardParams.{name} must be finite")

    @classmethod
    def from_params(cls, values: Mapping[str, float]) -> GuardParams:
        """From HXG_* names (missing ones take the script's defaults)."""

        def get(name: str) -> float:
            return float(values.get(name, PARAM_DEFAULTS[name]))

        return cls(
            enable=get(HXG_ENABLE),
            timeout_s=get(HXG_TIMEOUT),
            chan1=get(HXG_CHANS[0]),
            chan2=get(HXG_CHANS[1]),
            chan3=get(HXG_CHANS[2]),
            chan4=get(HXG_CHANS[3]),
        )

    @property
    def enabled(self) -> bool:
        return self.enable > 0

    @property
    def timeout_ms(self) -> int:
        return min(max(to_ms(self.timeout_s), TIMEOUT_MIN_MS), TIMEOUT_MAX_MS)

    @property
    def outputs(self) -> tuple[int, ...]:
        """Guarded outputs (1-based) in HXG_CHAN1..4 order, valid and unique."""
        out: list[int] = []
        for value in (self.chan1, self.chan2, self.chan3, self.chan4):
            n = _lua_round(value)
            if 1 <= n <= MAX_OUTPUT and n not in out:
                out.append(n)
        return tuple(out)
