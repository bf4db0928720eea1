"""helixd-guard, the autopilot's dead-man switch, as a pure state machine (no sockets, no clocks).

This mirrors ``autopilot/scripts/helixd-guard.lua`` (version 1) line for line, so that the
built-in simulator can run the same guard ArduPilot runs:

* parameters HXG_ENABLE (1), HXG_TIMEOUT (0.5 s, clamped to 0.1 … 10 s), HXG_CHAN1..4
  (1, 2, 3, 4: 1-based servo outputs, 0 = none, outside 1..16 ignored, duplicates once),
  HXG_VERSION (1, set by the script);
* every 50 ms (``UPDATE_PERIOD_MS``): armed and helixd *silent* — never heard since boot
  (``last_gcs_heartbeat_s`` None, as ArduPilot's ``gcs:last_seen()`` 0) or ``now − last >
  timeout`` in whole milliseconds — → the guarded outputs are held at their SERVOn_TRIM for
  ``OVERRIDE_MS`` (renewed each step while the silence lasts), HOLD (Rover mode 4) is asked
  once per episode unless already in HOLD, and one CRITICAL STATUSTEXT is sent;
* when helixd is heard again, the vehicle is disarmed or HXG_ENABLE is 0, it lets go: no more
  renewals and one NOTICE STATUSTEXT. Disarmed it never acts.

The Lua holds an RC-passthrough output at trim by overriding its RC input as well (ArduPilot
copies the RC input onto a passthrough output after a servo override); here that is the
shell's business: :attr:`GuardAction.hold_trim` lists the outputs, the simulator applies
SERVOn_TRIM. If the shell's HOLD request fails it sends :data:`HOLD_REFUSED_TEXT`.
Times are quantised to whole milliseconds, as ArduPilot's ``millis()``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

VERSION = 1
PARAM_TABLE_KEY = 144
PARAM_PREFIX = "HXG_"
UPDATE_PERIOD_MS = 50
OVERRIDE_MS = 100  # each renewal holds the outputs this long (2 update periods)
MODE_HOLD = 4
MAX_OUTPUT = 16
TIMEOUT_MIN_MS = 100
TIMEOUT_MAX_MS = 10_000

SEVERITY_CRITICAL = 2
SEVERITY_WARNING = 4
SEVERITY_NOTICE = 5
SEVERITY_INFO = 6

TEXT_PREFIX = "helixd-guard: "
NEVER_SEEN_TEXT = "helixd-guard: no heartbeat yet, trim + HOLD"
HOLD_REFUSED_TEXT = "helixd-guard: HOLD refused"
BACK_TEXT = "helixd-guard: heartbeat back, released"
DISARMED_TEXT = "helixd-guard: disarmed, released"
DISABLED_TEXT = "helixd-guard: disabled, released"

# name → default, in the Lua's table order (index 1..7)
PARAM_DEFAULTS: dict[str, float] = {
    "HXG_ENABLE": 1.0,
    "HXG_TIMEOUT": 0.5,
    "HXG_CHAN1": 1.0,
    "HXG_CHAN2": 2.0,
    "HXG_CHAN3": 3.0,
    "HXG_CHAN4": 4.0,
    "HXG_VERSION": float(VERSION),
}


def silent_text(timeout_ms: int) -> str:
    return f"helixd-guard: no heartbeat {timeout_ms} ms, trim + HOLD"


def to_ms(t_s: float) -> int:
    """Seconds → whole milliseconds (round half up), the unit of ArduPilot's millis()."""
    return math.floor(t_s * 1000.0 + 0.5)


def _lua_round(value: float) -> int:
    return math.floor(value + 0.5)


@dataclass(frozen=True, slots=True)
class GuardParams:
    """The HXG_ parameters as ArduPilot stores them (floats)."""

    enable: float = PARAM_DEFAULTS["HXG_ENABLE"]
    timeout_s: float = PARAM_DEFAULTS["HXG_TIMEOUT"]
    chan1: float = PARAM_DEFAULTS["HXG_CHAN1"]
    chan2: float = PARAM_DEFAULTS["HXG_CHAN2"]
    chan3: float = PARAM_DEFAULTS["HXG_CHAN3"]
    chan4: float = PARAM_DEFAULTS["HXG_CHAN4"]

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
            enable=get("HXG_ENABLE"),
            timeout_s=get("HXG_TIMEOUT"),
            chan1=get("HXG_CHAN1"),
            chan2=get("HXG_CHAN2"),
            chan3=get("HXG_CHAN3"),
            chan4=get("HXG_CHAN4"),
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


@dataclass(frozen=True, slots=True)
class GuardAction:
    """What one step asks of the autopilot."""

    hold_trim: tuple[int, ...] = ()  # outputs (1-based) to hold at SERVOn_TRIM for hold_ms
    hold_ms: int = 0
    request_hold: bool = False  # vehicle:set_mode(4); on failure send HOLD_REFUSED_TEXT
    texts: tuple[tuple[int, str], ...] = ()  # (MAV_SEVERITY, STATUSTEXT)
    guarding: bool = False  # state after this step


def start_text(params: GuardParams) -> tuple[int, str]:
    """The INFO STATUSTEXT the script sends when it loads."""
    outputs = " ".join(str(n) for n in params.outputs) or "none"
    state = "on" if params.enabled else "off"
    return (
        SEVERITY_INFO,
        f"helixd-guard: v{VERSION} {state}, outputs {outputs}, {params.timeout_ms} ms",
    )


class HelixdGuard:
    """One guard instance; call :meth:`step` every ``UPDATE_PERIOD_MS`` of autopilot time.

    ``params`` may be replaced between steps (the script reads its parameters every update).
    """

    def __init__(self, params: GuardParams | None = None) -> None:
        self.params = params if params is not None else GuardParams()
        self.guarding = False

    def step(
        self, now_s: float, armed: bool, last_gcs_heartbeat_s: float | None, mode: int
    ) -> GuardAction:
        p = self.params
        now_ms = to_ms(now_s)
        never = last_gcs_heartbeat_s is None or to_ms(last_gcs_heartbeat_s) == 0
        tmo = p.timeout_ms
        silent = never or (
            last_gcs_heartbeat_s is not None and now_ms - to_ms(last_gcs_heartbeat_s) > tmo
        )

        if not p.enabled:
            if self.guarding:
                self.guarding = False
                return GuardAction(texts=((SEVERITY_NOTICE, DISABLED_TEXT),))
            return GuardAction()

        if armed and silent:
            texts: tuple[tuple[int, str], ...] = ()
            request_hold = False
            if not self.guarding:
                self.guarding = True
                text = NEVER_SEEN_TEXT if never else silent_text(tmo)
                texts = ((SEVERITY_CRITICAL, text),)
                request_hold = mode != MODE_HOLD
            return GuardAction(
                hold_trim=p.outputs,
                hold_ms=OVERRIDE_MS,
                request_hold=request_hold,
                texts=texts,
                guarding=True,
            )

        if self.guarding:
            self.guarding = False
            text = BACK_TEXT if armed else DISARMED_TEXT
            return GuardAction(texts=((SEVERITY_NOTICE, text),))
        return GuardAction()
