"""What loading a parameter file onto the autopilot would change (pure; ``helixd autopilot
setup``): each parameter whose value differs, those the autopilot lacks, and which changes
take effect only after a reboot.

Values are compared as the autopilot stores them: MAVLink carries every parameter as a
float32, so a value within float32 rounding of the file's counts as the same.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

# ArduPilot reads these at boot only: RC_Channels' RCMAP_* (RCMapper), scripting, the battery
# monitor's type, the scheduler's loop rate
REBOOT_PARAMS = frozenset(
    {
        "RCMAP_ROLL",
        "RCMAP_PITCH",
        "RCMAP_THROTTLE",
        "RCMAP_YAW",
        "SCR_ENABLE",
        "BATT_MONITOR",
        "SCHED_LOOP_RATE",
    }
)
FLOAT32_RELATIVE = 1e-6


@dataclass(frozen=True, slots=True)
class ParamChange:
    name: str
    now: float
    wanted: float

    @property
    def after_reboot(self) -> bool:
        """The autopilot reads this parameter at boot only."""
        return self.name in REBOOT_PARAMS

    def line(self) -> str:
        reboot = "  (after a reboot)" if self.after_reboot else ""
        return f"{self.name:<18} {self.now:>10g} → {self.wanted:g}{reboot}"


def same_value(a: float, b: float) -> bool:
    return abs(a - b) <= FLOAT32_RELATIVE * max(1.0, abs(a), abs(b))


def plan_changes(
    wanted: Mapping[str, float], current: Mapping[str, float | None]
) -> tuple[list[ParamChange], list[str]]:
    """(the changes, in the file's order; the names the autopilot does not have)."""
    changes: list[ParamChange] = []
    missing: list[str] = []
    for name, value in wanted.items():
        now = current.get(name)
        if now is None:
            missing.append(name)
        elif not same_value(now, value):
            changes.append(ParamChange(name, now, value))
    return changes, missing


def reboot_needed(names: Iterable[str]) -> list[str]:
    """Those of ``names`` that take effect only at the next boot."""
    return [n for n in names if n in REBOOT_PARAMS]
