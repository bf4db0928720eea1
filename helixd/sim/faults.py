"""Fault injection: names, arguments and the schedule (pure)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

FAULTS: dict[str, dict[str, object]] = {
    # name: {kwarg: default}
    "link_drop": {"duration_s": None, "link": None},  # both directions; link = index or all
    "stale_pose": {"duration_s": None, "attitude": False},  # pose streams stop
    "ekf_unhealthy": {"duration_s": None},
    "reboot": {"silent_s": None},  # time_boot_ms restarts, boots through INITIALISING
    # every later fix off by distance_m; the EKF's horizontal variance rises by variance (its
    # glitch; 0: a jump the EKF took without complaint, e.g. after its reset to the new fix)
    "gps_jump": {"distance_m": 10.0, "bearing_deg": 90.0, "variance": 1.0},
    # the receiver stops (SIM_GPS1_ENABLE 0): GPS_RAW_INT says no fix, 0 satellites after
    # gps_loss_report_s; the EKF dead-reckons and drops its position after gps_dead_reckon_s
    "gps_loss": {"duration_s": None},
    # GPS_RAW_INT stops while every other stream goes on (ArduPilot sends none while GPS1_TYPE
    # is 0, or when a stream rate is turned off); the EKF is left alone
    "gps_silent": {"duration_s": None},
    # the receiver stops sending (a cut cable; ArduPilot SITL: SIM_GPS1_BYTELOS 100): GPS_RAW_INT
    # repeats the last fix, time_usec frozen, for gps_receiver_timeout_s, then says no GPS,
    # 0 satellites; the EKF dead-reckons as after a gps_loss
    "gps_receiver_silent": {"duration_s": None},
    "pilot_takeover": {"mode": "HOLD"},  # pilot moves the RC mode switch
    # ArduPilot's own failsafes (helixd.sim.firmware.failsafe): battery 1 at its low (or critical)
    # limit — "Battery 1 is low …", then BATT_FS_LOW_ACT —, and the rover out of its enabled
    # fence — FENCE_STATUS, then FENCE_ACTION
    "battery_low": {"voltage_v": 10.5, "used_mah": 1234.0, "critical": False},
    "fence_breach": {},
    # the pilot's radio is lost. kind no_pulses: the receiver stops (SIM_RC_FAIL 1);
    # failsafe_values: it sends its failsafe frame, throttle channel 3 at 950 µs (SIM_RC_FAIL 2)
    "rc_loss": {"duration_s": None, "kind": "no_pulses"},
    "stall": {"duration_s": None},  # scrolls dig in: they turn, the rover does not move
    # Hostile telemetry: the autopilot reports values no pose can be made of.
    # armed_only: corrupt only while armed (inject before arming = bad "from the moment of
    # arming"). LOCAL_POSITION_NED x = y = NaN:
    "nan_position": {"duration_s": None, "armed_only": False},
    "nan_yaw": {"duration_s": None, "armed_only": False},  # ATTITUDE yaw = NaN
    "inf_yaw": {"duration_s": None, "armed_only": False, "sign": 1.0},  # yaw = ±inf
    # LOCAL_POSITION_NED x = y = distance_m (finite but absurd)
    "absurd_position": {"duration_s": None, "armed_only": False, "distance_m": 1e9},
    # every time_boot_ms sent is step_s older than the autopilot's clock (a backstep smaller
    # than a reboot's when step_s < 1 s)
    "time_backwards": {"duration_s": None, "armed_only": False, "step_s": 0.9},
}
RC_LOSS_KINDS = ("no_pulses", "failsafe_values")
HOSTILE_TELEMETRY_FAULTS = frozenset(
    {"nan_position", "nan_yaw", "inf_yaw", "absurd_position", "time_backwards"}
)
DURATION_FAULTS = (
    frozenset(
        {
            "link_drop",
            "stale_pose",
            "ekf_unhealthy",
            "rc_loss",
            "stall",
            "gps_loss",
            "gps_silent",
            "gps_receiver_silent",
        }
    )
    | HOSTILE_TELEMETRY_FAULTS
)


class FaultError(ValueError):
    pass


@dataclass(frozen=True, slots=True)
class FaultSpec:
    name: str
    kwargs: Mapping[str, object] = field(default_factory=dict)


def _convert(name: str, key: str, raw: str) -> object:
    default = FAULTS[name][key]
    if key == "mode":
        return raw.upper()
    if key == "kind":
        return raw  # checked with the programmatic arguments, in make_spec
    if isinstance(default, bool):
        if raw.lower() in ("1", "true", "yes", "on"):
            return True
        if raw.lower() in ("0", "false", "no", "off"):
            return False
        raise FaultError(f"{name}: {key} must be true/false, got {raw!r}")
    if key == "link":
        return int(raw)
    try:
        return float(raw)
    except ValueError:
        raise FaultError(f"{name}: {key} must be a number, got {raw!r}") from None


def make_spec(name: str, kwargs: Mapping[str, object]) -> FaultSpec:
    if name not in FAULTS:
        raise FaultError(f"unknown fault {name!r}; known: {', '.join(sorted(FAULTS))}")
    unknown = sorted(set(kwargs) - set(FAULTS[name]))
    if unknown:
        allowed = ", ".join(sorted(FAULTS[name])) or "none"
        raise FaultError(f"{name}: unknown argument(s) {', '.join(unknown)} (allowed: {allowed})")
    merged = {k: v for k, v in FAULTS[name].items()}
    merged.update(kwargs)
    duration = merged.get("duration_s")
    if duration is not None and float(str(duration)) <= 0.0:
        raise FaultError(f"{name}: duration_s must be > 0")
    step = merged.get("step_s")
    if step is not None and float(str(step)) <= 0.0:
        raise FaultError(f"{name}: step_s must be > 0")
    kind = merged.get("kind")
    if kind is not None and kind not in RC_LOSS_KINDS:
        raise FaultError(f"{name}: kind must be one of {', '.join(RC_LOSS_KINDS)}, got {kind!r}")
    sign = merged.get("sign")
    if sign is not None and float(str(sign)) == 0.0:
        raise FaultError(f"{name}: sign must be +1 or -1")
    variance = merged.get("variance")
    if variance is not None and not 0.0 <= float(str(variance)) < float("inf"):
        raise FaultError(f"{name}: variance must be finite and >= 0")
    return FaultSpec(name, merged)


def parse_fault(text: str) -> tuple[FaultSpec, float]:
    """``NAME@SECONDS[:key=value[,key=value]]`` → (spec, sim time in seconds)."""
    head, _, args = text.partition(":")
    name, at, when = head.partition("@")
    if not at:
        raise FaultError(f"{text!r}: expected NAME@SECONDS[:key=value,...]")
    try:
        at_s = float(when)
    except ValueError:
        raise FaultError(f"{text!r}: {when!r} is not a number of seconds") from None
    if at_s < 0.0:
        raise FaultError(f"{text!r}: time must be >= 0")
    name = name.strip()
    if name not in FAULTS:
        raise FaultError(f"unknown fault {name!r}; known: {', '.join(sorted(FAULTS))}")
    kwargs: dict[str, object] = {}
    for part in filter(None, (p.strip() for p in args.split(","))):
        key, eq, value = part.partition("=")
        if not eq:
            raise FaultError(f"{text!r}: argument {part!r} is not key=value")
        key = key.strip()
        if key not in FAULTS[name]:
            raise FaultError(f"{name}: unknown argument {key!r}")
        kwargs[key] = _convert(name, key, value.strip())
    return make_spec(name, kwargs), at_s


class FaultClock:
    """Active durational faults with their end times (None = until cleared)."""

    def __init__(self) -> None:
        self.active: dict[str, float | None] = {}
        self.args: dict[str, Mapping[str, object]] = {}

    def start(self, spec: FaultSpec, now_s: float) -> None:
        duration = spec.kwargs.get("duration_s")
        self.active[spec.name] = None if duration is None else now_s + float(str(duration))
        self.args[spec.name] = spec.kwargs

    def clear(self, name: str) -> bool:
        self.args.pop(name, None)
        return self.active.pop(name, "absent") != "absent"

    def expire(self, now_s: float) -> list[str]:
        ended = [n for n, end in self.active.items() if end is not None and now_s >= end]
        for name in ended:
            self.clear(name)
        return ended

    def on(self, name: str) -> bool:
        return name in self.active

    def hostile(self, name: str, armed: bool) -> Mapping[str, object] | None:
        """The arguments of hostile-telemetry fault ``name`` if it corrupts telemetry now."""
        if name not in self.active:
            return None
        args = self.args.get(name, {})
        if args.get("armed_only") and not armed:
            return None
        return args
