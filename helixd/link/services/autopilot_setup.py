"""Is the autopilot set up so that a Helix arms honestly? (``helixd autopilot check``)

A normal arm (no force, every PreArm check made) needs, besides GPS/EKF/battery/fence/RC:

* **the motor-output check** (``AP_MotorsUGV::pre_arm_check``, :mod:`helixd.mav.arming`):
  RC-passthrough scroll outputs (51..54) or function-0 ones (DO_SET_SERVO) are no motor
  outputs to ArduPilot, which then refuses "PreArm: no motor, sail or scripting outputs
  defined". The Helix setup: one spare output, with nothing connected, set to
  ``SERVOn_FUNCTION = 94`` (Script1). No script drives it.
* **no checks skipped**: ``ARMING_SKIPCHK = 0`` (current firmware; -1 skips all of them,
  the motor-output check too) or ``ARMING_CHECK = 1`` (older firmware; 0 skips all).
* **the throttle channel at its trim** (``AP_Arming::rc_arm_checks``, made at every arm
  once a receiver sends): ``RCMAP_THROTTLE``'s channel n must read ``RCn_TRIM ± RCn_DZ``,
  or "Arm: Throttle (RCn) is not neutral". The line says what it must read and what it reads
  (RC_CHANNELS), and to move the stick or switch there — never to force the arm.
* what preflight checks before every run (:func:`helixd.link.services.preflight.judge`): the scroll
  outputs as the backend needs them (RC passthrough RCINn for ``rc_override``, function 0 for
  ``servo``), helixd's system id as the GCS id, RC_OVERRIDE_TIME, FS_GCS_ENABLE, the guard.

:func:`judge_setup` is pure (a dict of parameter values → one :class:`SetupLine` per topic);
:func:`read_setup` reads the parameters.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

from helixd.config.link import LinkConfig
from helixd.config.vehicle import ActuationBackend, ActuationConfig
from helixd.link.services.preflight import (
    LEGACY_GCS_SYSID,
    RADIO_PARAMS,
    ParamReader,
    PreflightProblem,
    ServoGuardPolicy,
    judge,
    param_names,
)
from helixd.mav.arming import (
    K_MAST_ROTATION,
    K_SCRIPTING1,
    K_STEERING,
    K_THROTTLE,
    K_THROTTLE_LEFT,
    K_THROTTLE_RIGHT,
    NO_OUTPUTS_TEXT,
    PREARM_PREFIX,
    SAIL_FUNCTIONS,
    motor_prearm_failure,
    rc_reading,
    servo_functions,
    throttle_must_read,
    throttle_neutral,
)
from helixd.mav.guard_script import HXG_VERSION, PARAM_DEFAULTS

Status = Literal["ok", "warning", "error"]

SKIPCHK = "ARMING_SKIPCHK"  # current ArduPilot: bitmask of checks to skip, -1 = all
LEGACY_CHECK = "ARMING_CHECK"  # older firmware: bitmask of checks made, 1 = all, 0 = none
FRAME_TYPE = "FRAME_TYPE"
SPARE_LAST_OUTPUT = 16  # every board with 16 outputs' worth of SERVOn parameters has it
OUTPUTS_ALWAYS_READ = 16  # SERVO1..16 exist on every board; 17..32 where NUM_SERVO_CHANNELS 32
OUTPUTS_MAX = 32
OPTIONAL_RETRIES = 1  # parameters that may not exist: do not wait 4 tries for each
MOTOR_FUNCTIONS = frozenset(
    {K_THROTTLE, K_THROTTLE_LEFT, K_THROTTLE_RIGHT, K_STEERING, *SAIL_FUNCTIONS}
)
FUNCTION_NAMES = {
    K_THROTTLE: "Throttle",
    K_THROTTLE_LEFT: "ThrottleLeft",
    K_THROTTLE_RIGHT: "ThrottleRight",
    K_STEERING: "GroundSteering",
    K_SCRIPTING1: "Script1",
    K_MAST_ROTATION: "MastRotation",
}


@dataclass(frozen=True, slots=True)
class SetupLine:
    status: Status
    topic: str
    message: str
    param: str | None = None  # the parameter to change, when one would fix it

    def __str__(self) -> str:
        return f"{self.status:<7} {self.topic}: {self.message}"


def spare_output(functions: Mapping[int, int], scroll_channels: set[int]) -> int | None:
    """The output to make Script1: the highest-numbered one up to 16 whose function is 0
    (nothing assigned; a SERVOn_FUNCTION that was read) and that drives no scroll."""
    for n in range(SPARE_LAST_OUTPUT, 0, -1):
        if functions.get(n) == 0 and n not in scroll_channels:
            return n
    return None


def judge_motor_outputs(
    params: Mapping[str, float | None], actuation: ActuationConfig
) -> SetupLine:
    """Will a normal arm pass AP_MotorsUGV::pre_arm_check? If not, what to set."""
    topic = "arming (motor outputs)"
    functions = servo_functions(params)
    frame = params.get(FRAME_TYPE)
    failure = motor_prearm_failure(functions, 0 if frame is None else round(frame))
    scrolls = {ch.channel for ch in actuation.channels}
    if failure is None:
        counted = sorted(n for n, f in functions.items() if f in MOTOR_FUNCTIONS | {K_SCRIPTING1})
        what = ", ".join(
            f"SERVO{n}_FUNCTION = {functions[n]} ({FUNCTION_NAMES.get(functions[n], 'sail')})"
            for n in counted
        )
        return SetupLine("ok", topic, f"a normal arm passes the motor-output check ({what})")
    refused = f"a normal arm is refused: '{PREARM_PREFIX}{failure}'"
    if failure == NO_OUTPUTS_TEXT:
        spare = spare_output(functions, scrolls)
        if spare is None:
            return SetupLine(
                "error",
                topic,
                f"{refused}; no output up to {SPARE_LAST_OUTPUT} is free (function 0) to "
                f"become Script1: free one and set its SERVOn_FUNCTION = {K_SCRIPTING1}",
            )
        name = f"SERVO{spare}_FUNCTION"
        return SetupLine(
            "error",
            topic,
            f"{refused}; set {name} = {K_SCRIPTING1} (Script1) on this spare output with nothing "
            f"connected to it: ArduPilot then counts a scripting output (no script drives it) "
            f"and every other PreArm check is still made",
            name,
        )
    own = ", ".join(
        f"SERVO{n}_FUNCTION = {f}" for n, f in sorted(functions.items()) if f in MOTOR_FUNCTIONS
    )
    return SetupLine(
        "error",
        topic,
        f"{refused}; ArduPilot's own motor functions are half set up ({own or 'FRAME_TYPE'}): "
        f"helixd drives the scrolls, so set those outputs to 0 (and FRAME_TYPE = 0) and give "
        f"one spare output SERVOn_FUNCTION = {K_SCRIPTING1}",
    )


def judge_skipped_checks(params: Mapping[str, float | None]) -> SetupLine:
    """Are PreArm checks skipped (so an arm would not be honest)?"""
    topic = "arming (checks)"
    skip = params.get(SKIPCHK)
    if skip is not None:
        value = round(skip)
        if value == 0:
            return SetupLine("ok", topic, f"{SKIPCHK} = 0: every PreArm check is made")
        what = "every PreArm check" if value == -1 else f"the checks in bitmask {value}"
        return SetupLine(
            "error",
            topic,
            f"{SKIPCHK} = {value} skips {what}: arming would not say when GPS, EKF, battery "
            f"or fence are not ready; set {SKIPCHK} = 0",
            SKIPCHK,
        )
    legacy = params.get(LEGACY_CHECK)
    if legacy is not None:
        value = round(legacy)
        if value == 1:
            return SetupLine("ok", topic, f"{LEGACY_CHECK} = 1: every PreArm check is made")
        what = "every PreArm check" if value == 0 else "some PreArm checks"
        return SetupLine(
            "error",
            topic,
            f"{LEGACY_CHECK} = {value} skips {what}; set {LEGACY_CHECK} = 1",
            LEGACY_CHECK,
        )
    return SetupLine(
        "warning",
        topic,
        f"neither {SKIPCHK} nor {LEGACY_CHECK} could be read: cannot tell whether checks "
        "are skipped",
    )


def judge_throttle(
    params: Mapping[str, float | None], rc_inputs_us: Sequence[int] = ()
) -> SetupLine | None:
    """Will AP_Arming::rc_arm_checks find the throttle channel neutral? (pure) None when
    RCMAP_THROTTLE could not be read."""
    topic = "arming (throttle)"
    mapped = params.get("RCMAP_THROTTLE")
    if mapped is None:
        return None
    n = round(mapped)
    trim, dz = params.get(f"RC{n}_TRIM"), params.get(f"RC{n}_DZ")
    reading = rc_reading(rc_inputs_us, n)
    need = throttle_must_read(n, trim, dz, reading)
    if reading is None:
        return SetupLine(
            "ok", topic, f"{need} (no RC input seen: ArduPilot checks it once a receiver sends)"
        )
    if trim is not None and throttle_neutral(reading, round(trim), round(dz or 0)):
        return SetupLine("ok", topic, need)
    return SetupLine(
        "error",
        topic,
        f"a normal arm is refused: 'Arm: Throttle (RC{n}) is not neutral'; {need}",
        f"RC{n}_TRIM",
    )


def _topic(problem: PreflightProblem) -> str:
    param = problem.param or ""
    if param.startswith(("MAV_GCS_SYSID", LEGACY_GCS_SYSID)):
        return "GCS system id"
    if param.startswith(("SERVO", "RC", "MODE_CH")) and param not in (
        "RC_OVERRIDE_TIME",
        *RADIO_PARAMS,
    ):
        return "scroll outputs"
    if param.startswith(("HXG_", "SCR_")):
        return "helixd-guard"
    if param in RADIO_PARAMS:
        return "pilot's radio"
    return "link and failsafe"


def _radio_fine(params: Mapping[str, float | None]) -> str:
    ch, value = params.get("RCMAP_THROTTLE"), params.get("FS_THR_VALUE")
    return (
        f"ArduPilot's radio failsafe is on and reads channel {_shown(ch)}, which helixd does "
        f"not override: a receiver whose failsafe sends it below {_shown(value)} µs is seen "
        "while helixd drives (a receiver that just stops sending is not)"
    )


def judge_setup(
    params: Mapping[str, float | None],
    actuation: ActuationConfig,
    link: LinkConfig,
    servo_guard: ServoGuardPolicy = "required",
    rc_inputs_us: Sequence[int] = (),
) -> list[SetupLine]:
    """One line per topic: ok, or each problem with what to change (pure). ``rc_inputs_us``:
    the last RC_CHANNELS (µs, channel 1 first), empty when none came."""
    lines = [judge_skipped_checks(params), judge_motor_outputs(params, actuation)]
    if (throttle := judge_throttle(params, rc_inputs_us)) is not None:
        lines.append(throttle)
    problems = judge(params, actuation, link, servo_guard)
    by_topic: dict[str, list[PreflightProblem]] = {}
    for p in problems:
        by_topic.setdefault(_topic(p), []).append(p)
    sysid = params.get("MAV_GCS_SYSID")
    sysid_name = "MAV_GCS_SYSID"
    if sysid is None:
        sysid, sysid_name = params.get(LEGACY_GCS_SYSID), LEGACY_GCS_SYSID
    shown = "?" if sysid is None else f"{round(sysid)}"
    fine = {
        "GCS system id": f"{sysid_name} = {shown} is helixd's link.source_system "
        f"({link.source_system}): the autopilot obeys its overrides and counts its heartbeats",
        "scroll outputs": _scrolls_fine(params, actuation),
        "link and failsafe": _failsafe_fine(params, actuation),
    }
    if actuation.backend is not ActuationBackend.DRY_RUN:
        fine["pilot's radio"] = _radio_fine(params)
    if actuation.backend is not ActuationBackend.DRY_RUN:
        fine["helixd-guard"] = f"v{_shown(params.get(HXG_VERSION))} runs and guards every scroll"
    for topic, text in fine.items():
        found = by_topic.pop(topic, [])
        if not found:
            lines.append(SetupLine("ok", topic, text))
        lines += [SetupLine(p.severity, topic, p.message, p.param) for p in found]
    for topic, found in by_topic.items():
        lines += [SetupLine(p.severity, topic, p.message, p.param) for p in found]
    return lines


def _scrolls_fine(params: Mapping[str, float | None], actuation: ActuationConfig) -> str:
    outputs = ", ".join(
        f"SERVO{ch.channel}_FUNCTION = {_shown(params.get(f'SERVO{ch.channel}_FUNCTION'))}"
        for ch in actuation.channels
    )
    if actuation.backend is ActuationBackend.RC_OVERRIDE:
        return f"{outputs}: RC passthrough, as the rc_override backend needs"
    if actuation.backend is ActuationBackend.SERVO:
        return f"{outputs}: free for DO_SET_SERVO, as the servo backend needs"
    return "dry_run backend: helixd drives no output"


def _failsafe_fine(params: Mapping[str, float | None], actuation: ActuationConfig) -> str:
    text = f"FS_GCS_ENABLE = {_shown(params.get('FS_GCS_ENABLE'))}"
    if actuation.backend is ActuationBackend.RC_OVERRIDE:
        text += f", RC_OVERRIDE_TIME = {_shown(params.get('RC_OVERRIDE_TIME'))} s"
    return text


def _shown(value: float | None) -> str:
    return "?" if value is None else f"{value:g}"


def failed(lines: list[SetupLine]) -> bool:
    """Anything that keeps the Helix from arming honestly or being obeyed (exit 3)."""
    return any(line.status == "error" for line in lines)


def setup_param_names(actuation: ActuationConfig) -> list[str]:
    """Parameters :func:`read_setup` reads for sure (they exist on every current Rover)."""
    names = param_names(actuation)
    names += ["RC_OVERRIDE_TIME", "FS_GCS_ENABLE", "SCR_ENABLE"]
    names += [f"SERVO{n}_FUNCTION" for n in range(1, OUTPUTS_ALWAYS_READ + 1)]
    return list(dict.fromkeys(names))


async def read_setup(ap: ParamReader, actuation: ActuationConfig) -> dict[str, float | None]:
    """Read what :func:`judge_setup` needs; parameters that may not exist (the ARMING_* pair,
    the legacy SYSID_MYGCS, outputs 17..32) cost one short try each."""
    names = setup_param_names(actuation)
    optional = [SKIPCHK, LEGACY_CHECK, FRAME_TYPE, f"SERVO{OUTPUTS_ALWAYS_READ + 1}_FUNCTION"]
    sure, maybe = await asyncio.gather(
        asyncio.gather(*(ap.param.get(n) for n in names)),
        asyncio.gather(*(ap.param.get(n, retries=OPTIONAL_RETRIES) for n in optional)),
    )
    params: dict[str, float | None] = dict(zip(names, sure, strict=True))
    params.update(zip(optional, maybe, strict=True))
    more: list[str] = []
    if params["MAV_GCS_SYSID"] is None:
        more.append(LEGACY_GCS_SYSID)
    if params[f"SERVO{OUTPUTS_ALWAYS_READ + 1}_FUNCTION"] is not None:
        more += [f"SERVO{n}_FUNCTION" for n in range(OUTPUTS_ALWAYS_READ + 2, OUTPUTS_MAX + 1)]
    if params.get(HXG_VERSION) is not None:
        more += [n for n in PARAM_DEFAULTS if n != HXG_VERSION]
    mapped = params.get("RCMAP_THROTTLE")
    if mapped is not None:  # what the throttle channel must read to arm
        more += [f"RC{round(mapped)}_TRIM", f"RC{round(mapped)}_DZ"]
    got = await asyncio.gather(*(ap.param.get(n) for n in more))
    params.update(zip(more, got, strict=True))
    return params
