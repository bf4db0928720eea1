"""Process exit codes of ``helixd run`` (documented in the README)."""

from __future__ import annotations

from enum import IntEnum


class ExitCode(IntEnum):
    OK = 0  # every waypoint reached, vehicle left stopped and released
    INTERNAL_ERROR = 1  # a bug: unhandled exception (fall-back to HOLD still ran)
    USAGE = 2  # bad command line, config or mission file
    PREFLIGHT = 3  # the autopilot would not obey / is not ready; nothing was armed
    # a watchdog fired mid-mission, or ArduPilot's own failsafe (battery, fence, radio, GCS,
    # EKF) changed the mode; scrolls stopped, overrides released, HOLD asked
    FAULT = 4
    OPERATOR_STOP = 5  # SIGINT/SIGTERM or a person's takeover ended the mission
    LINK = 6  # could not connect to the autopilot at all
