"""Re-export of :mod:`helixd.base.geometry` (the old import path; new code imports the base)."""

from helixd.base.geometry import BodyVelocity, NonFiniteError, Pose2D, require_finite

__all__ = ["BodyVelocity", "NonFiniteError", "Pose2D", "require_finite"]
