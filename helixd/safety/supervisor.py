"""The safety supervisor's fall-back: the one place that stops the rover.

Sequence, started within one control tick of detection and bounded in time:
1. command all scrolls to neutral and release every override we hold (``sink.stop()``) —
   HOLD alone does not stop an RC-passthrough output (DESIGN §3), so this comes first;
2. request HOLD, re-sent until acknowledged or ``hold_retry_bound_s`` passes;
3. optionally disarm;
4. log one ``fallback`` event naming the cause and the pose.
The pilot's radio is in charge afterwards. The navigator never stops anything itself.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import structlog

from helixd.config import SafetyConfig
from helixd.safety.watchdogs import Fault

log = structlog.get_logger(__name__)

HOLD_MODE = "HOLD"


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
        report.stopped_after_s = time.monotonic() - detected_s
    if autopilot is not None:
        report.hold_requested_after_s = time.monotonic() - detected_s
        deadline = time.monotonic() + cfg.hold_retry_bound_s
        while time.monotonic() < deadline:
            try:
                # short tries, re-sent here until the bound: one ACK lost must not cost seconds
                remaining = max(0.05, deadline - time.monotonic())
                await autopilot.set_mode(HOLD_MODE, timeout_s=min(0.3, remaining), retries=0)
                report.hold_acked = True
                break
            except Exception as exc:  # retry until acknowledged or the bound passes
                report.errors.append(f"HOLD request: {exc}")
                if abandon():
                    break
        if (cfg.disarm_on_fault if disarm is None else disarm) and not abandon():
            try:
                await autopilot.disarm()
                report.disarmed = True
            except Exception as exc:
                report.errors.append(f"disarm: {exc}")
    emit = log.info if fault is None else log.warning
    emit(
        "vehicle_secured" if fault is None else "fallback",
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


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 3)
