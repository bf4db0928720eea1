"""Old import path of the daemon helpers, kept while other branches still import it: the
harness is :mod:`tests.integration.harness` (import from there; set
``harness.KEEP_NOTIFY_SOCKET`` there, not here)."""

from tests.integration.harness import (
    BASE_CONFIG,
    MISSIONS,
    NEUTRAL_TOLERANCE_US,
    NEUTRAL_US,
    ROOT,
    SPEEDUP,
    DaemonProc,
    Trace,
    daemon,
    deep_merge,
    overrides_released,
    record_until,
    scrolls_neutral,
    secured,
    sim_and_daemon,
    time_until,
    wait_moving,
)

__all__ = [
    "BASE_CONFIG",
    "MISSIONS",
    "NEUTRAL_TOLERANCE_US",
    "NEUTRAL_US",
    "ROOT",
    "SPEEDUP",
    "DaemonProc",
    "Trace",
    "daemon",
    "deep_merge",
    "overrides_released",
    "record_until",
    "scrolls_neutral",
    "secured",
    "sim_and_daemon",
    "time_until",
    "wait_moving",
]
