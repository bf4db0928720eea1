"""Re-export of :mod:`helixd.base.angles` (the old import path; new code imports the base)."""

from helixd.base.angles import TWO_PI, shortest_angular_distance, wrap_pi

__all__ = ["TWO_PI", "shortest_angular_distance", "wrap_pi"]
