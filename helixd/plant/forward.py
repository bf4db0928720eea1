"""The simulator's own Helix-25 forward kinematics: thesis eq. 1, written out term by term.

    v_x = r/4 · ( ω1 + ω2 − ω3 − ω4)
    v_y = r/4 · ( ω1 − ω2 − ω3 + ω4)                 (eq. 1, no slip)
    v_θ = r/(4(l_x + l_y)) · ( ω1 + ω2 + ω3 + ω4)

Body frame as in the thesis (Fig. 2/3): x = ROLL axis, y = SCROLL axis, z up, v_θ
counter-clockwise positive; ω in rad/s, scrolls 1..4 in the thesis's numbering.

Deliberately independent of the controller (:mod:`helixd.control.kinematics` builds eq. 1
and eq. 2 as matrices): the simulator is the oracle the controller is tested against, so a
sign error in the controller's kinematics makes the simulated rover go the wrong way instead
of being mirrored by the plant (``tests/plant/test_forward.py``). Only the plain types and
checks of :mod:`helixd.base` are shared.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from helixd.base.geometry import BodyVelocity, require_finite

RPM_PER_RADPS = 60.0 / (2.0 * math.pi)


def rpm_to_radps(rpm: float) -> float:
    return rpm / RPM_PER_RADPS


def radps_to_rpm(radps: float) -> float:
    return radps * RPM_PER_RADPS


def body_velocity(
    omega_radps: Sequence[float], radius_m: float, lx_m: float, ly_m: float
) -> BodyVelocity:
    """Eq. 1: four scroll speeds (rad/s) → no-slip body velocity (m/s, m/s, rad/s CCW).

    Raises :class:`helixd.base.geometry.NonFiniteError` on a non-finite speed."""
    w1, w2, w3, w4 = (float(w) for w in omega_radps)
    require_finite("scroll speeds", w1, w2, w3, w4)
    v_x = radius_m / 4.0 * (w1 + w2 - w3 - w4)
    v_y = radius_m / 4.0 * (w1 - w2 - w3 + w4)
    v_theta = radius_m / (4.0 * (lx_m + ly_m)) * (w1 + w2 + w3 + w4)
    return BodyVelocity(v_x, v_y, v_theta)


__all__ = ["RPM_PER_RADPS", "body_velocity", "radps_to_rpm", "rpm_to_radps"]
