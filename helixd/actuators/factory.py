"""The actuator backend ``actuation.backend`` names (see :mod:`helixd.actuators`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from helixd.actuators.base import ActuatorSink
from helixd.actuators.dry_run import DryRunSink
from helixd.actuators.rc_override import RcOverrideSink
from helixd.actuators.servo import ServoSink
from helixd.config.vehicle import ActuationBackend, ActuationConfig, VehicleConfig

if TYPE_CHECKING:
    from helixd.link.connection import Autopilot


def make_sink(
    actuation: ActuationConfig, vehicle: VehicleConfig, ap: Autopilot | None
) -> ActuatorSink:
    """The configured backend. ``ap`` may be None only for ``dry_run``."""
    if actuation.backend is ActuationBackend.DRY_RUN:
        return DryRunSink(actuation, vehicle)
    if ap is None:
        raise ValueError(f"actuation.backend {actuation.backend.value!r} needs an autopilot link")
    if actuation.backend is ActuationBackend.SERVO:
        return ServoSink(actuation, vehicle, ap.action)
    return RcOverrideSink(actuation, vehicle, ap.action)
