"""Fixtures shared by every test package (tests/support holds shared helpers to import)."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
import structlog

from helixd.config import CONFIG_ENV
from helixd.recorder import logging_setup

# Without -c a command reads $HELIXD_CONFIG, else /etc/helixd/helixd.yaml where it exists (a
# rover): the tests read the built-in defaults on any machine unless they point it elsewhere.
os.environ[CONFIG_ENV] = ""


@pytest.fixture
def reset_logging() -> Iterator[None]:
    """After the test: detach any run events file and undo structlog's configuration, so a
    test that configured logging leaves nothing behind. Modules whose tests configure logging
    use it for all of them: ``pytestmark = pytest.mark.usefixtures("reset_logging")``."""
    yield
    logging_setup.detach_events_file()
    structlog.reset_defaults()
