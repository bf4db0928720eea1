"""The safety supervisor: it owns the watchdogs while flying (:class:`Supervisor`, a
:class:`helixd.safety.watchdogs.SafetyMonitor` fed from the vehicle state each tick) and the
fall-back (:func:`fall_back`), the one place that stops the rover.

Sequence, started within one control tick of detection and bounded in time:
1. command all scrolls to neutral and release every override we hold (``sink.stop()``) —
   HOLD alone does not stop an RC-passthrough output (docs/ardupilot.md), so this comes first;
2. request HOLD, re-sent until acknowledged or ``hold_retry_bound_s`` passes — except when the
   crew ended a flight of the autopilot's AUTO by choosing a mode the pilot drives
   (``released``: MANUAL, ACRO, STEERING), where HOLD would take the rover from the pilot;
3. optionally disarm;
4. log one ``fallback`` event naming the cause and the pose.
The pilot's radio is in charge afterwards. The navigator never stops anything itself.
"""

from __future__ import annotations

import asyncio
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import structlog

from helixd.base.clock import now_s
from helixd.base.frames import NedPose
from helixd.config.safety import SafetyConfig
from helixd.link.vehicle import PoseSample, VehicleState
from helixd.safety.autopilot_failsafe import FailsafeEvidence, classify_mode_change
from helixd.safety.watchdogs import (
    HANDED_CAUSES,
    Fault,
    FaultCause,
    SafetyInputs,
    SafetyMonitor,
)

log = structlog.get_logger(__name__)

HOLD_MODE = "HOLD"


@dataclass(frozen=True, slots=True)
class Motion:
    """What the control loop commanded and measured (for the stall and time watchdogs)."""

    commanded_speed_mps: float
    commanded_yaw_rate_radps: float
    measured_yaw_rate_radps: float
    mission_elapsed_s: float  # driving time (helixd.safety.mission_clock)
    mission_paused_s: float = 0.0  # held for the crew: not counted
    # the crawl watch applies (rolling: see SafetyInputs.crawl_watch)
    crawl_watch: bool = True


def safety_inputs(
    now_s: float,
    state: VehicleState,
    pose: PoseSample | None,
    start_ned: NedPose,
    expected_mode: str,
    motion: Motion,
) -> SafetyInputs:
    """The watchdogs' snapshot from the vehicle state, the latest pose and the loop's motion
    (pure)."""
    ekf = state.ekf
    ekf_healthy = None if ekf is None else ekf.healthy
    return SafetyInputs(
        now_s=now_s,
        last_heartbeat_s=state.last_heartbeat_s,
        pose_rx_s=pose.rx_monotonic_s if pose else None,
        ekf_healthy=ekf_healthy,
        # the text only matters when the watchdog reports it: not built while healthy
        ekf_detail="" if ekf is None or ekf_healthy else ekf.describe(),
        mode=state.mode,
        expected_mode=expected_mode,
        armed=state.armed,
        rc_inputs_us=state.rc_inputs_us,
        north_m=pose.ned.north_m if pose else None,
        east_m=pose.ned.east_m if pose else None,
        start_north_m=start_ned.north_m,
        start_east_m=start_ned.east_m,
        mission_elapsed_s=motion.mission_elapsed_s,
        mission_paused_s=motion.mission_paused_s,
        commanded_speed_mps=motion.commanded_speed_mps,
        crawl_watch=motion.crawl_watch,
        measured_speed_mps=math.hypot(pose.vn_mps, pose.ve_mps) if pose else 0.0,
        commanded_yaw_rate_radps=motion.commanded_yaw_rate_radps,
        measured_yaw_rate_radps=motion.measured_yaw_rate_radps,
        rc_receiver_healthy=state.rc_receiver_healthy,
        pose_invalid_since_s=state.pose_invalid_since_s,
        pose_invalid_detail=state.pose_invalid_reason,
        vehicle_time_s=pose.time_boot_ms / 1000.0 if pose else None,
        gps_monitored=True,
        gps_rx_s=state.gps_rx_s,
        gps_fix_rx_s=state.gps_fix_rx_s,
        gps_fix_type=state.gps_fix_type,
        gps_satellites=state.gps_satellites,
        link_lost_cause=state.link_lost_cause if state.link_lost else None,
        last_rx_s=state.last_rx_s,
    )


def failsafe_evidence(state: VehicleState) -> FailsafeEvidence:
    """What the vehicle state says about ArduPilot's own failsafes (pure)."""
    return FailsafeEvidence(
        texts=state.statustexts,
        system_status=state.system_status,
        fence_breached=state.fence_breached,
        battery_failsafe=state.battery_failsafe,
    )


def late_failsafe(
    fault: Fault | None, detected_s: float | None, state: VehicleState, window_s: float
) -> Fault | None:
    """A takeover by mode change that ArduPilot's failsafe turns out to have made (pure).

    ArduPilot queues its failsafe text in the loop that changes the mode, but on a busy link
    the text can come after the HEARTBEAT that shows the new mode. The fall-back does not wait
    for it; once it is done, the daemon asks again here with what arrived meanwhile (texts up
    to ``window_s`` after the detection). The named fault, or None when it stays a takeover.
    """
    if fault is None or detected_s is None:
        return None
    modes = fault.mode_change
    if modes is None:
        return None
    return classify_mode_change(
        *modes,
        failsafe_evidence(state),
        detected_s,
        window_s,
        until_s=detected_s + window_s,
    )


class Supervisor:
    """Owns the watchdogs of one flight: the flight loop asks it once per tick, before any
    command; the first fault it returns ends the flight (and :func:`fall_back` runs).

    A mode change is named here: ArduPilot's own failsafe (``autopilot_*``, a fault) when
    what the autopilot reported around it says so
    (:func:`helixd.safety.autopilot_failsafe.classify_mode_change`), else the watchdog's
    ``pilot_takeover``. An autopilot failsafe ends the flight even with
    ``safety.takeover.on_mode_change`` off."""

    def __init__(self, cfg: SafetyConfig, start_ned: NedPose, expected_mode: str) -> None:
        self.monitor = SafetyMonitor(cfg)
        self.start_ned = start_ned
        self.expected_mode = expected_mode
        self.failsafe_window_s = cfg.autopilot_failsafe_window_s

    def check(
        self, now_s: float, state: VehicleState, pose: PoseSample | None, motion: Motion
    ) -> Fault | None:
        fault = self.monitor.check(
            safety_inputs(now_s, state, pose, self.start_ned, self.expected_mode, motion)
        )
        if state.mode != self.expected_mode and (
            fault is None or fault.cause is FaultCause.PILOT_TAKEOVER
        ):
            named = classify_mode_change(
                state.mode,
                self.expected_mode,
                failsafe_evidence(state),
                now_s,
                self.failsafe_window_s,
            )
            if named is not None:
                return named
        return fault


class Stoppable(Protocol):
    async def stop(self) -> None: ...


class ModeSetter(Protocol):
    async def set_mode(
        self, name: str, timeout_s: float | None = None, retries: int | None = None
    ) -> None: ...

    async def disarm(self, force: bool = False) -> None: ...


@dataclass
class FallbackReport:
    cause: str
    detail: str
    stopped_after_s: float | None = None  # neutral + release sent, seconds after detection
    hold_requested_after_s: float | None = None  # first HOLD request sent
    hold_acked: bool = False
    disarmed: bool = False
    errors: list[str] = field(default_factory=list)


async def fall_back(
    fault: Fault | None,
    *,
    sink: Stoppable | None,
    autopilot: ModeSetter | None,
    cfg: SafetyConfig,
    detected_s: float,
    pose_text: str,
    disarm: bool | None = None,
    abandon: Callable[[], bool] = lambda: False,
) -> FallbackReport:
    """Run the fall-back sequence. Never raises (except CancelledError); errors are reported.

    ``fault`` None is the normal end of a completed mission: the same stop, release and HOLD,
    logged as ``vehicle_secured`` instead of ``fallback``.

    ``abandon`` is polled between HOLD retries: a second SIGINT makes the daemon stop waiting
    for the acknowledgement once the request has been sent.
    """
    report = (
        FallbackReport(cause="completed", detail="mission complete")
        if fault is None
        else FallbackReport(cause=fault.cause.value, detail=fault.detail)
    )
    if sink is not None:
        try:
            await asyncio.wait_for(sink.stop(), timeout=cfg.fallback_deadline_s)
        except TimeoutError:
            report.errors.append(
                f"stopping the scrolls took longer than {cfg.fallback_deadline_s} s"
            )
        except Exception as exc:  # the fall-back must go on to HOLD whatever happened
            report.errors.append(f"stopping the scrolls failed: {exc!r}")
        report.stopped_after_s = now_s() - detected_s
    # the pilot drives, or the crew moved the autopilot's AUTO to another item, or gave it
    # another place or mode helixd drives in: no HOLD
    released = fault is not None and fault.cause in HANDED_CAUSES
    if autopilot is not None and not released:
        report.hold_requested_after_s = now_s() - detected_s
        tries: list[str] = []
        deadline = now_s() + cfg.hold_retry_bound_s
        while now_s() < deadline:
            try:
                # short tries, re-sent here until the bound: one ACK lost must not cost seconds
                remaining = max(0.05, deadline - now_s())
                await autopilot.set_mode(HOLD_MODE, timeout_s=min(0.3, remaining), retries=0)
                report.hold_acked = True
                break
            except Exception as exc:  # retry until acknowledged or the bound passes
                tries.append(str(exc))
                if abandon():
                    break
        report.errors.extend(counted("HOLD request", tries))
        if (cfg.disarm_on_fault if disarm is None else disarm) and not abandon():
            try:
                await autopilot.disarm()
                report.disarmed = True
            except Exception as exc:
                report.errors.append(f"disarm: {exc}")
    # a completed mission and an operator's pause are no faults: info, each by its name
    paused = fault is not None and fault.cause is FaultCause.PAUSED
    emit = log.info if fault is None or paused or released else log.warning
    event = "vehicle_secured" if fault is None else "fallback"
    emit(
        "paused" if paused else "released" if released else event,
        cause=report.cause,
        detail=report.detail,
        pose=pose_text,
        stopped_after_s=_round(report.stopped_after_s),
        hold_requested_after_s=_round(report.hold_requested_after_s),
        hold_acked=report.hold_acked,
        disarmed=report.disarmed,
        errors=report.errors or None,
    )
    return report


def counted(what: str, errors: list[str]) -> list[str]:
    """Each different error once, in order, with how many tries ended so: ``HOLD request:
    no answer (10 tries)`` rather than the same line ten times (pure)."""
    counts: dict[str, int] = {}
    for e in errors:
        counts[e] = counts.get(e, 0) + 1
    return [f"{what}: {e}" + (f" ({n} tries)" if n > 1 else "") for e, n in counts.items()]


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 3)
