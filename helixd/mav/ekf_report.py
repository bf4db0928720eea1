"""EKF_STATUS_REPORT's flags and variances, the one record the link judges and the simulator
sends (each adds its own: the link its receive time and health judgement, the simulator the
position check of its failsafe)."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any


@dataclass(frozen=True, slots=True)
class EkfReport:
    """The fields of one EKF_STATUS_REPORT: ``flags`` are EKF_STATUS_FLAGS
    (:mod:`helixd.mav.constants`), the variances ArduPilot's innovation test ratios
    (1.0 = at the gate; FS_EKF_THRESH compares them)."""

    flags: int
    velocity_variance: float
    pos_horiz_variance: float
    pos_vert_variance: float
    compass_variance: float
    terrain_alt_variance: float

    @classmethod
    def from_message(cls, msg: Any) -> EkfReport:
        """The report of a pymavlink EKF_STATUS_REPORT, whose field names this record's are
        (a variance that is not finite stays so: the link's judgement refuses it)."""
        variances = (float(getattr(msg, name)) for name in VARIANCE_FIELDS)
        return cls(int(msg.flags), *variances)


VARIANCE_FIELDS = tuple(f.name for f in fields(EkfReport) if f.name != "flags")
