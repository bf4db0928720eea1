"""Fixtures shared by every test package (tests/support holds shared helpers to import)."""

from __future__ import annotations

import gc
import os
from collections.abc import Iterator

import pytest
import structlog
from hypothesis import HealthCheck, settings

from helixd.config.load import CONFIG_ENV
from helixd.recorder import logging_setup

# Without -c a command reads $HELIXD_CONFIG, else /etc/helixd/helixd.yaml where it exists (a
# rover): the tests read the built-in defaults on any machine unless they point it elsewhere.
os.environ[CONFIG_ENV] = ""

# A property's verdict is its examples', never the machine's speed: hypothesis's default 200 ms
# deadline per example and its too_slow health check failed tests on a loaded 2-core machine
# (tests/control/test_totality.py at load 10). Each test's own settings() still sets its count.
settings.register_profile(
    "helixd",
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
settings.load_profile("helixd")


def pytest_collection_finish(session: pytest.Session) -> None:
    """Every module and fixture the run will use is imported: put it out of the collector's
    reach (as the daemon does at start, helixd.runtime.eventloop.settle_collector)."""
    gc.collect()
    gc.freeze()


@pytest.fixture(autouse=True)
def _no_collector_pause_in_a_test() -> Iterator[None]:
    """No full collector pass inside a test body. The pytest process holds a few hundred MB
    after two thousand tests; a full pass over it stalled the in-process simulator's pose
    stream for 0.35-0.5 s (measured), past the daemon's 0.5 s pose watchdog, and flights
    that were not about staleness ended ``pose_stale``. Cycles are collected between tests."""
    gc.disable()
    try:
        yield
    finally:
        gc.enable()
        gc.collect()


@pytest.fixture
def reset_logging() -> Iterator[None]:
    """After the test: detach any run events file and undo structlog's configuration, so a
    test that configured logging leaves nothing behind. Modules whose tests configure logging
    use it for all of them: ``pytestmark = pytest.mark.usefixtures("reset_logging")``."""
    yield
    logging_setup.detach_events_file()
    structlog.reset_defaults()
