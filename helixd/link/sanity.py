"""Edge checks on decoded messages (pure): a pose field that is not finite never gets in.

A CRC only proves the bytes arrived as sent, not that the sender's numbers make sense. NaN or
±inf in the fields helixd steers by (ATTITUDE yaw, LOCAL_POSITION_NED position/velocity)
would become a NaN pose; such a message is dropped here, so the pose simply goes stale and the
stale-pose watchdog acts. Finite but absurd values (1e30 m) pass: range is the geofence's and
the guidance's business. EKF_STATUS_REPORT is not filtered: the vehicle state already reads a
non-finite variance as unhealthy, which is the signal we want.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["POSE_FIELDS", "non_finite_fields"]

POSE_FIELDS: dict[str, tuple[str, ...]] = {
    "ATTITUDE": ("roll", "pitch", "yaw", "rollspeed", "pitchspeed", "yawspeed"),
    "LOCAL_POSITION_NED": ("x", "y", "z", "vx", "vy", "vz"),
}


def non_finite_fields(msg: Any) -> list[str]:
    """Names of the checked fields of ``msg`` that are not finite numbers (empty: fine)."""
    names = POSE_FIELDS.get(str(msg.get_type()), ())
    bad: list[str] = []
    for name in names:
        value = getattr(msg, name, None)
        if not isinstance(value, int | float) or not math.isfinite(value):
            bad.append(name)
    return bad
