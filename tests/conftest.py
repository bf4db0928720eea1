"""Fixtures shared by every test package (tests/support holds shared helpers to import)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import structlog

from helixd.recorder import logging_setup


@pytest.fixture
def reset_logging() -> Iterator[None]:
    """After the test: detach any run events file and undo structlog's configuration, so a
    test that configured logging leaves nothing behind. Modules whose tests configure logging
    use it for all of them: ``pytestmark = pytest.mark.usefixtures("reset_logging")``."""
    yield
    logging_setup.detach_events_file()
    structlog.reset_defaults()
