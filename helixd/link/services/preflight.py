"""Will the autopilot obey us? Parameter checks before anything is armed or driven.

Reads the parameters concurrently (a missing one costs one command timeout, in parallel) and
judges them with the pure :func:`judge`. Every problem says exactly what to change.

What is checked (ArduPilot Rover; docs/ardupilot.md):

* GCS system id — ``MAV_GCS_SYSID`` (current; with ``MAV_GCS_SYSID_HI`` a range, as
  ``GCS::sysid_is_gcs``) or ``SYSID_MYGCS`` (legacy), whichever exists, must cover
  ``link.source_system``. RC overrides from any other sysid are silently ignored (error for
  ``rc_override``); the GCS failsafe only counts that sysid's heartbeats (warning otherwise).
  helixd never suggests taking a ground station's default id (255, 245) instead, and warns
  when it is configured with one, or when MAV_GCS_SYSID_HI makes a range of ids "the GCS".
* Nobody else uses helixd's system id — messages arriving with our own srcSystem (a ground
  station or a second helixd on the same id, seen directly or forwarded by ArduPilot from
  another link, MAVLink_routing.cpp) → error: that sender's heartbeats would keep the GCS
  failsafe quiet when helixd dies, and its overrides would fight ours. Preflight listens for
  at least ``link.own_id_watch_s`` after our first message before judging.
* ``RC_OVERRIDE_TIME`` (rc_override) — 0 disables overrides altogether (RC_Channel::has_override:
  "overrides are explicitly disabled by a zero value") → error; negative means they never
  expire, so a dead helixd would keep driving → warning; a repeat period not well inside it →
  warning.
* ``RC_OPTIONS`` bit 1 (value 2) "Ignore MAVLink Overrides" (rc_override) → error.
* Per driven channel n (rc_override): the override sets RC *input* n; the scroll's motor
  controller sits on servo output n, which follows RC input n only with
  ``SERVOn_FUNCTION = 50+n`` (RCINn) or 1 (RCPassThru, same number). Any other function means
  ArduPilot drives that output itself (or nothing does) → error. RC inputs only exist for
  passthrough on 1..16. ``MODE_CH`` = n would turn every override into a mode change, and an
  ``RCn_OPTION`` aux function would fire on override values → errors.
* Per driven channel n (servo): DO_SET_SERVO is refused unless ``SERVOn_FUNCTION`` is one of
  :data:`helixd.mav.servo_functions.DO_SET_SERVO_FUNCTIONS` (0, 1, 22, 23, 28, 51–66, 140–155)
  → error; anything but 0 also feeds the output from elsewhere → warning.
* ``FS_GCS_ENABLE`` = 0 → warning: nothing on the autopilot notices a dead helixd.
* The pilot's radio (:func:`judge_radio`): ArduPilot counts every new RC override as fresh RC
  input, so while helixd overrides, a receiver that stops sending is invisible (Rover's radio
  failsafe never times out, SYS_STATUS keeps the receiver healthy; measured on SITL). What
  ArduPilot still sees is a receiver that sends its failsafe frame with the throttle channel
  below ``FS_THR_VALUE``, on a throttle channel (``RCMAP_THROTTLE``) helixd does not
  override. ``FS_THR_ENABLE`` = 0, or helixd overriding ``RCMAP_THROTTLE``'s channel →
  warning (when ``safety.stop_on_rc_loss`` asks helixd to stop on a lost radio).
* helixd-guard (the dead-man switch on the autopilot, :mod:`helixd.mav.guard_script`): its
  parameters say whether it runs (HXG_VERSION exists), in this helixd's version, enabled
  (HXG_ENABLE), guarding every scroll output (HXG_CHAN1..4), and whether helixd refreshes
  ``gcs:last_seen()`` often enough for HXG_TIMEOUT (one lost message tolerated: period × 2.5
  ≤ timeout; with the RC-override backend the override repeats count too). With the servo
  backend a failing check is an error when ``safety.servo_guard`` is ``required`` (a killed
  helixd would leave DO_SET_SERVO outputs driving), a warning with ``warn``; with the
  RC-override backend it is a warning (overrides expire after RC_OVERRIDE_TIME anyway).
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Literal, Protocol, runtime_checkable

from helixd.config.link import LinkConfig
from helixd.config.vehicle import ActuationBackend, ActuationConfig
from helixd.link.wire.ownid import OwnIdSenders
from helixd.mav.guard_script import (
    HXG_CHANS,
    HXG_ENABLE,
    HXG_TIMEOUT,
    HXG_VERSION,
    MAX_OUTPUT,
    PARAM_DEFAULTS,
    SCR_ENABLE,
    VERSION,
    GuardParams,
)
from helixd.mav.servo_functions import (
    DO_SET_SERVO_FUNCTIONS,
    K_GRIPPER,
    K_MANUAL,
    K_NONE,
    K_SPRAYER_PUMP,
    K_SPRAYER_SPINNER,
    RCIN_CHANNELS,
    passthrough_input,
    rcin_function,
)

Severity = Literal["error", "warning"]
ServoGuardPolicy = Literal["required", "warn"]

RC_OPTIONS_IGNORE_OVERRIDES = 2  # bit 1
RECOMMENDED_OVERRIDE_TIME_S = 3.0
# A lost HEARTBEAT must not trip helixd-guard: two periods plus half a period of jitter
# have to fit in its timeout.
GUARD_PERIODS_PER_TIMEOUT = 2.5
INSTALL_GUARD = (
    "install it with `helixd autopilot install-guard --connect URL` and reboot the autopilot "
    "(README: If the process is killed)"
)
# Default system ids of common ground stations: 255 QGroundControl, Mission Planner, MAVProxy
# and pymavlink scripts; 245 MAVSDK in its GroundStation role. helixd must not share them.
GCS_DEFAULT_SYSIDS = {255: "QGroundControl/Mission Planner/MAVProxy", 245: "MAVSDK"}


@dataclass(frozen=True, slots=True)
class PreflightProblem:
    severity: Severity
    message: str
    param: str | None = None

    def __str__(self) -> str:
        return f"{self.severity}: {self.message}"


class ParamGetter(Protocol):
    async def get(
        self, name: str, timeout_s: float | None = ..., retries: int | None = ...
    ) -> float | None: ...


class ParamReader(Protocol):
    """What preflight reads parameters through (the Autopilot's param plugin)."""

    @property
    def param(self) -> ParamGetter: ...


@runtime_checkable
class OwnIdWatch(Protocol):
    """What the link knows about other senders on our system id (see helixd.link.wire.ownid)."""

    @property
    def own_id_senders(self) -> OwnIdSenders: ...

    def own_id_watch_s(self) -> float: ...


LEGACY_GCS_SYSID = "SYSID_MYGCS"
RADIO_PARAMS = ["FS_THR_ENABLE", "RCMAP_THROTTLE", "FS_THR_VALUE"]


def param_names(actuation: ActuationConfig) -> list[str]:
    """Parameters to read (the legacy SYSID_MYGCS only if MAV_GCS_SYSID turns out missing, the
    guard's settings only if HXG_VERSION says it runs)."""
    names = ["MAV_GCS_SYSID", "MAV_GCS_SYSID_HI", "FS_GCS_ENABLE"]
    if actuation.backend is not ActuationBackend.DRY_RUN:
        names += RADIO_PARAMS
    if actuation.backend is not ActuationBackend.DRY_RUN:
        names += [SCR_ENABLE, HXG_VERSION]
    if actuation.backend is ActuationBackend.RC_OVERRIDE:
        names += ["RC_OVERRIDE_TIME", "RC_OPTIONS", "MODE_CH"]
        names += [
            f"RC{ch.channel}_OPTION" for ch in actuation.channels if ch.channel <= RCIN_CHANNELS
        ]
    if actuation.backend is not ActuationBackend.DRY_RUN:
        names += [f"SERVO{ch.channel}_FUNCTION" for ch in actuation.channels]
    return names


async def check_obedience(
    ap: ParamReader,
    actuation: ActuationConfig,
    link: LinkConfig,
    servo_guard: ServoGuardPolicy = "required",
    watch_radio: bool = True,
) -> list[PreflightProblem]:
    """Read the parameters that decide whether we are obeyed; return every problem found."""
    names = param_names(actuation)
    values, _ = await asyncio.gather(
        asyncio.gather(*(ap.param.get(n) for n in names)), _listen_for_own_id(ap, link)
    )
    params: dict[str, float | None] = dict(zip(names, values, strict=True))
    if params["MAV_GCS_SYSID"] is None:  # older firmware: the GCS sysid had another name
        params[LEGACY_GCS_SYSID] = await ap.param.get(LEGACY_GCS_SYSID)
    if params.get(HXG_VERSION) is not None:  # the guard runs: read its settings
        settings = [n for n in PARAM_DEFAULTS if n != HXG_VERSION]
        got = await asyncio.gather(*(ap.param.get(n) for n in settings))
        params.update(zip(settings, got, strict=True))
    problems = judge(params, actuation, link, servo_guard, watch_radio)
    if isinstance(ap, OwnIdWatch):
        problems = judge_own_id(ap.own_id_senders, link) + problems
    return problems


async def _listen_for_own_id(ap: ParamReader, link: LinkConfig) -> None:
    """Give other senders on our id time to show up (a listening window, not a sync).

    Ground stations send HEARTBEAT at 1 Hz, and ArduPilot forwards other links' heartbeats to
    ours only once ours is active: the window counts from our first message.
    """
    if isinstance(ap, OwnIdWatch):
        remaining = link.own_id_watch_s - ap.own_id_watch_s()
        if remaining > 0:
            await asyncio.sleep(remaining)


def judge_own_id(senders: OwnIdSenders, link: LinkConfig) -> list[PreflightProblem]:
    """Error when anyone else sends with helixd's system id (pure)."""
    if not senders:
        return []
    sysid = link.source_system
    return [
        PreflightProblem(
            "error",
            f"another sender uses helixd's system id {sysid} "
            f"({senders.describe(link.source_component)}): while it is there the autopilot's "
            f"GCS failsafe cannot notice a dead helixd and its RC overrides fight helixd's; give "
            f"that ground station / program another system id, or run helixd with an unused "
            f"link.source_system and set MAV_GCS_SYSID to it",
            "MAV_GCS_SYSID",
        )
    ]


def _int(value: float) -> int:
    return round(value)


def judge(
    params: Mapping[str, float | None],
    actuation: ActuationConfig,
    link: LinkConfig,
    servo_guard: ServoGuardPolicy = "required",
    watch_radio: bool = True,
) -> list[PreflightProblem]:
    """The pure part of :func:`check_obedience`."""
    out = _gcs_sysid(params, actuation, link)
    backend = actuation.backend
    if backend is ActuationBackend.RC_OVERRIDE:
        out += _override_params(params, actuation)
        for ch in actuation.channels:
            out += _rc_channel(params, ch.channel)
    elif backend is ActuationBackend.SERVO:
        for ch in actuation.channels:
            out += _servo_channel(params, ch.channel)
    fs = params.get("FS_GCS_ENABLE")
    if fs is not None and _int(fs) == 0:
        out.append(
            PreflightProblem(
                "warning",
                "FS_GCS_ENABLE = 0: the autopilot will not notice if helixd dies; set "
                "FS_GCS_ENABLE = 1 (and FS_ACTION = 2 for HOLD)",
                "FS_GCS_ENABLE",
            )
        )
    if watch_radio:
        out += judge_radio(params, actuation)
    out += judge_guard(params, actuation, link, servo_guard)
    return out


def judge_radio(
    params: Mapping[str, float | None], actuation: ActuationConfig
) -> list[PreflightProblem]:
    """Can anyone notice the pilot's radio is lost while helixd drives? (pure)"""
    if actuation.backend is ActuationBackend.DRY_RUN:
        return []
    enabled, throttle_ch = params.get("FS_THR_ENABLE"), params.get("RCMAP_THROTTLE")
    if enabled is not None and _int(enabled) == 0:
        return [
            PreflightProblem(
                "warning",
                "FS_THR_ENABLE = 0: nobody notices a lost radio (ArduPilot's radio failsafe is "
                "off); set FS_THR_ENABLE = 1 and program the receiver's failsafe to send "
                "throttle below FS_THR_VALUE",
                "FS_THR_ENABLE",
            )
        ]
    overridden = actuation.backend is ActuationBackend.RC_OVERRIDE and throttle_ch is not None
    if overridden and _int(throttle_ch or 0) in {ch.channel for ch in actuation.channels}:
        n = _int(throttle_ch or 0)
        driven = {ch.channel for ch in actuation.channels}
        spare = next((c for c in range(5, RCIN_CHANNELS + 1) if c not in driven), None)
        instead = "a channel helixd does not drive" + ("" if spare is None else f" (e.g. {spare})")
        value = params.get("FS_THR_VALUE")
        below = "FS_THR_VALUE" if value is None else f"FS_THR_VALUE ({_int(value)} µs)"
        return [
            PreflightProblem(
                "warning",
                f"RCMAP_THROTTLE = {n} is a channel helixd overrides: while it drives, "
                f"ArduPilot cannot see a lost radio and nobody could take over; set "
                f"RCMAP_THROTTLE to {instead}, reboot the autopilot, and program the "
                f"receiver's failsafe to send that channel below {below}; to arm, that "
                f"channel must then read its trim (RCn_TRIM ± RCn_DZ: a switch there in its "
                f"middle position, `helixd autopilot check` says what it reads)",
                "RCMAP_THROTTLE",
            )
        ]
    return []


def judge_guard(
    params: Mapping[str, float | None],
    actuation: ActuationConfig,
    link: LinkConfig,
    servo_guard: ServoGuardPolicy = "required",
) -> list[PreflightProblem]:
    """helixd-guard's checks (pure; the module docstring lists them)."""
    backend = actuation.backend
    if backend is ActuationBackend.DRY_RUN:
        return []
    servo = backend is ActuationBackend.SERVO
    severity: Severity = "error" if servo and servo_guard == "required" else "warning"
    risk = (
        "a killed helixd leaves the DO_SET_SERVO outputs driving"
        if servo
        else "a killed helixd's RC overrides drive on until RC_OVERRIDE_TIME"
    )
    version = params.get(HXG_VERSION)
    if version is None:
        why = "helixd-guard does not run on the autopilot (no HXG_VERSION parameter)"
        scr = params.get(SCR_ENABLE)
        if scr is None:
            why += "; the autopilot has no SCR_ENABLE: its firmware has no Lua scripting"
        elif _int(scr) != 1:
            why += f"; SCR_ENABLE = {scr:g}"
        return [PreflightProblem(severity, f"{why}: {risk}; {INSTALL_GUARD}", HXG_VERSION)]
    out: list[PreflightProblem] = []
    if _int(version) != VERSION:
        out.append(
            PreflightProblem(
                severity,
                f"helixd-guard v{_int(version)} runs on the autopilot, this helixd needs "
                f"v{VERSION}: {INSTALL_GUARD}",
                HXG_VERSION,
            )
        )
    guard = GuardParams.from_params({n: v for n, v in params.items() if v is not None})
    if not guard.enabled:
        out.append(
            PreflightProblem(
                severity,
                f"HXG_ENABLE = {guard.enable:g}: helixd-guard is off and {risk}; set "
                "HXG_ENABLE = 1",
                HXG_ENABLE,
            )
        )
    scroll_outputs = [ch.channel for ch in actuation.channels]
    unguarded = [n for n in scroll_outputs if n not in guard.outputs]
    if unguarded:
        chans = ", ".join(f"{v:g}" for v in (guard.chan1, guard.chan2, guard.chan3, guard.chan4))
        fix = (
            f"set HXG_CHAN1..4 = {', '.join(str(n) for n in scroll_outputs)}"
            if max(scroll_outputs) <= MAX_OUTPUT
            else f"drive the scrolls on outputs 1..{MAX_OUTPUT}, which the guard can hold"
        )
        out.append(
            PreflightProblem(
                severity,
                f"helixd-guard does not guard scroll output{'s' if len(unguarded) > 1 else ''} "
                f"{', '.join(str(n) for n in unguarded)} (HXG_CHAN1..4 = {chans}): {fix}",
                HXG_CHANS[0],
            )
        )
    if guard.enabled:
        out += _guard_rate(guard, actuation, link, severity)
    return out


def _guard_rate(
    guard: GuardParams, actuation: ActuationConfig, link: LinkConfig, severity: Severity
) -> list[PreflightProblem]:
    """Does helixd refresh gcs:last_seen() often enough? HEARTBEATs always; the RC-override
    backend's repeated overrides count as well (GCS_Common.cpp sysid_myggcs_seen)."""
    rate_hz = link.heartbeat_rate_hz
    if actuation.backend is ActuationBackend.RC_OVERRIDE:
        rate_hz = max(rate_hz, actuation.repeat_rate_hz)
    period_s = 1.0 / rate_hz
    timeout_s = guard.timeout_ms / 1000.0
    if period_s * GUARD_PERIODS_PER_TIMEOUT <= timeout_s + 1e-9:
        return []
    need_hz = GUARD_PERIODS_PER_TIMEOUT / timeout_s
    need_timeout_s = period_s * GUARD_PERIODS_PER_TIMEOUT
    return [
        PreflightProblem(
            severity if actuation.backend is ActuationBackend.SERVO else "warning",
            f"link.heartbeat_rate_hz = {link.heartbeat_rate_hz:g} is too slow for helixd-guard's "
            f"HXG_TIMEOUT = {timeout_s:g} s: one lost HEARTBEAT leaves helixd silent for "
            f"{2 * period_s:.2f} s and the guard would stop the rover mid-mission; set "
            f"link.heartbeat_rate_hz >= {need_hz:g} or HXG_TIMEOUT >= {need_timeout_s:g}",
            HXG_TIMEOUT,
        )
    ]


def is_gcs(sysid: int, low: int, high: int | None) -> bool:
    """ArduPilot's GCS::sysid_is_gcs (``high`` None: legacy firmware without the range)."""
    if high is None or high <= low:
        return sysid == low
    return low <= sysid <= high


def _gcs_sysid(
    params: Mapping[str, float | None], actuation: ActuationConfig, link: LinkConfig
) -> list[PreflightProblem]:
    name = "MAV_GCS_SYSID" if params.get("MAV_GCS_SYSID") is not None else "SYSID_MYGCS"
    value = params.get(name)
    rc = actuation.backend is ActuationBackend.RC_OVERRIDE
    ours = link.source_system
    out: list[PreflightProblem] = []
    if ours in GCS_DEFAULT_SYSIDS:
        out.append(
            PreflightProblem(
                "warning",
                f"link.source_system = {ours} is the default system id of "
                f"{GCS_DEFAULT_SYSIDS[ours]}: a ground station left on it hides a dead helixd "
                f"from the GCS failsafe and fights its overrides; use an id of helixd's own "
                f"(default {LinkConfig.model_fields['source_system'].default}) and set "
                f"{name} to it",
            )
        )
    if value is None:
        out.append(
            PreflightProblem(
                "error" if rc else "warning",
                "the autopilot has neither MAV_GCS_SYSID nor SYSID_MYGCS: cannot confirm it "
                f"accepts commands from system {ours}",
            )
        )
        return out
    gcs = _int(value)
    hi_value = params.get("MAV_GCS_SYSID_HI") if name == "MAV_GCS_SYSID" else None
    hi = None if hi_value is None else _int(hi_value)
    if is_gcs(ours, gcs, hi):
        if hi is not None and hi > gcs:
            out.append(
                PreflightProblem(
                    "warning",
                    f"MAV_GCS_SYSID_HI = {hi} makes every system {gcs}..{hi} the GCS: a ground "
                    f"station in that range keeps the GCS failsafe quiet when helixd dies and "
                    f"its overrides fight helixd's; set MAV_GCS_SYSID = {ours} and "
                    f"MAV_GCS_SYSID_HI = 0",
                    "MAV_GCS_SYSID_HI",
                )
            )
        return out
    what = (
        "RC overrides from helixd would be silently ignored"
        if rc
        else "the autopilot's GCS failsafe will not see helixd's heartbeats"
    )
    fix = f"set {name} = {ours} (currently {gcs})"
    if hi is not None and hi > gcs:
        fix += f" and MAV_GCS_SYSID_HI = 0 (currently {hi})"
    if gcs in GCS_DEFAULT_SYSIDS:
        fix += (
            f"; {gcs} is the default id of {GCS_DEFAULT_SYSIDS[gcs]}, which helixd must not share"
        )
    else:
        fix += f", or run helixd with link.source_system = {gcs}"
    out.append(PreflightProblem("error" if rc else "warning", f"{what}: {fix}", name))
    return out


def _override_params(
    params: Mapping[str, float | None], actuation: ActuationConfig
) -> list[PreflightProblem]:
    out: list[PreflightProblem] = []
    t = params.get("RC_OVERRIDE_TIME")
    rec = RECOMMENDED_OVERRIDE_TIME_S
    if t is None:
        out.append(
            PreflightProblem(
                "warning",
                "cannot read RC_OVERRIDE_TIME: override expiry unknown",
                "RC_OVERRIDE_TIME",
            )
        )
    elif t == 0:
        out.append(
            PreflightProblem(
                "error",
                "RC_OVERRIDE_TIME = 0 disables RC overrides entirely: set "
                f"RC_OVERRIDE_TIME = {rec:g}",
                "RC_OVERRIDE_TIME",
            )
        )
    elif t < 0:
        out.append(
            PreflightProblem(
                "warning",
                f"RC_OVERRIDE_TIME = {t:g}: overrides never expire, so a dead helixd keeps the "
                f"scrolls turning until the pilot acts; set RC_OVERRIDE_TIME = {rec:g}",
                "RC_OVERRIDE_TIME",
            )
        )
    elif 2.0 / actuation.repeat_rate_hz > t:
        out.append(
            PreflightProblem(
                "warning",
                f"RC_OVERRIDE_TIME = {t:g} s is shorter than two override repeats "
                f"(actuation.repeat_rate_hz = {actuation.repeat_rate_hz:g}): one lost packet "
                f"releases the scrolls; raise RC_OVERRIDE_TIME to {rec:g} or the repeat rate",
                "RC_OVERRIDE_TIME",
            )
        )
    opts = params.get("RC_OPTIONS")
    if opts is not None and _int(opts) & RC_OPTIONS_IGNORE_OVERRIDES:
        v = _int(opts)
        out.append(
            PreflightProblem(
                "error",
                f"RC_OPTIONS = {v} has bit 1 'Ignore MAVLink Overrides' set: set RC_OPTIONS = "
                f"{v & ~RC_OPTIONS_IGNORE_OVERRIDES}",
                "RC_OPTIONS",
            )
        )
    return out


def _rc_channel(params: Mapping[str, float | None], n: int) -> list[PreflightProblem]:
    out: list[PreflightProblem] = []
    mode_ch = params.get("MODE_CH")
    if mode_ch is not None and _int(mode_ch) == n:
        out.append(
            PreflightProblem(
                "error",
                f"MODE_CH = {n}: overriding RC channel {n} would switch flight modes; drive the "
                f"scroll on another channel or set MODE_CH to a channel helixd does not use",
                "MODE_CH",
            )
        )
    option = params.get(f"RC{n}_OPTION")
    if option is not None and _int(option) != 0:
        out.append(
            PreflightProblem(
                "error",
                f"RC{n}_OPTION = {_int(option)}: RC channel {n} is an aux switch and the override "
                f"would trigger it; set RC{n}_OPTION = 0",
                f"RC{n}_OPTION",
            )
        )
    if n > RCIN_CHANNELS:
        out.append(
            PreflightProblem(
                "error",
                f"RC channel {n} cannot reach a servo output (RCIN passthrough exists for 1..16 "
                f"only): map the scroll to a channel in 1..16",
            )
        )
        return out
    name = f"SERVO{n}_FUNCTION"
    f = params.get(name)
    rcin = rcin_function(n)
    if f is None:
        out.append(PreflightProblem("warning", f"cannot read {name}", name))
        return out
    func = _int(f)
    if func in (rcin, K_MANUAL):
        return out
    source = passthrough_input(func)
    if source is not None:
        why = f"makes output {n} follow RC input {source}, not the overridden RC channel {n}"
    elif func == K_NONE:
        why = f"leaves output {n} unused, so the override on RC channel {n} drives nothing"
    else:
        why = f"gives output {n} to ArduPilot itself, so the override on RC channel {n} is lost"
    out.append(
        PreflightProblem("error", f"{name} = {func} {why}: set {name} = {rcin} (RCIN{n})", name)
    )
    return out


def _other_driver(func: int) -> str:
    """Who else moves an output whose function DO_SET_SERVO accepts (other than 0)."""
    if func in (K_SPRAYER_PUMP, K_SPRAYER_SPINNER):
        return "the sprayer"
    if func == K_GRIPPER:
        return "the gripper"
    return "RC input"


def _servo_channel(params: Mapping[str, float | None], n: int) -> list[PreflightProblem]:
    name = f"SERVO{n}_FUNCTION"
    f = params.get(name)
    if f is None:
        return [PreflightProblem("warning", f"cannot read {name}", name)]
    func = _int(f)
    if func == K_NONE:
        return []
    if func in DO_SET_SERVO_FUNCTIONS:
        return [
            PreflightProblem(
                "warning",
                f"{name} = {func}: DO_SET_SERVO is accepted but the output is also driven by "
                f"{_other_driver(func)}; "
                f"{name} = 0 is the clean choice",
                name,
            )
        ]
    return [
        PreflightProblem(
            "error",
            f"{name} = {func}: ArduPilot refuses DO_SET_SERVO on this output; set {name} = 0",
            name,
        )
    ]
