"""ArduPilot Rover flight modes and the RC mode switch (pure)."""

from __future__ import annotations

from dataclasses import dataclass

MANUAL = 0
ACRO = 1
STEERING = 3
HOLD = 4
LOITER = 5
FOLLOW = 6
SIMPLE = 7
DOCK = 8
CIRCLE = 9
AUTO = 10
RTL = 11
SMART_RTL = 12
GUIDED = 15
INITIALISING = 16

MODE_NAMES: dict[int, str] = {
    MANUAL: "MANUAL",
    ACRO: "ACRO",
    STEERING: "STEERING",
    HOLD: "HOLD",
    LOITER: "LOITER",
    FOLLOW: "FOLLOW",
    SIMPLE: "SIMPLE",
    DOCK: "DOCK",
    CIRCLE: "CIRCLE",
    AUTO: "AUTO",
    RTL: "RTL",
    SMART_RTL: "SMART_RTL",
    GUIDED: "GUIDED",
    INITIALISING: "INITIALISING",
}
MODE_NUMBERS: dict[str, int] = {name: number for number, name in MODE_NAMES.items()}

# Mode::requires_position() is false only for these (Rover/mode.h)
NO_POSITION_MODES = frozenset({MANUAL, ACRO, STEERING, HOLD, INITIALISING})
# has_manual_input() → MAV_MODE_FLAG_MANUAL_INPUT_ENABLED in HEARTBEAT base_mode
MANUAL_INPUT_MODES = frozenset({MANUAL, ACRO, STEERING})
# is_autopilot_mode() → MAV_MODE_FLAG_GUIDED_ENABLED
AUTOPILOT_MODES = frozenset({LOITER, FOLLOW, CIRCLE, AUTO, RTL, SMART_RTL, GUIDED, DOCK})

MODE_SWITCH_DEBOUNCE_S = 0.2  # RC_Channel MODE_SWITCH_DEBOUNCE_TIME_MS


def mode_name(number: int) -> str:
    return MODE_NAMES.get(number, f"MODE_{number}")


def requires_position(mode: int) -> bool:
    return mode not in NO_POSITION_MODES


def switch_position(pwm_us: int) -> int | None:
    """RC_Channel::read_mode_switch: six positions (MODE1..MODE6), None = invalid pulse."""
    if pwm_us <= 900 or pwm_us >= 2200:
        return None
    for position, upper in enumerate((1231, 1361, 1491, 1621, 1750)):
        if pwm_us < upper:
            return position
    return 5


@dataclass(slots=True)
class ModeSwitch:
    """Debounced position of the pilot's mode switch; returns a position when it changes."""

    current: int | None = None
    pending: int | None = None
    pending_since_s: float = 0.0

    def update(self, pwm_us: int, now_s: float) -> int | None:
        position = switch_position(pwm_us)
        if position is None:
            return None
        if position != self.pending:
            self.pending = position
            self.pending_since_s = now_s
            return None
        if position == self.current or now_s - self.pending_since_s < MODE_SWITCH_DEBOUNCE_S:
            return None
        self.current = position
        return position
