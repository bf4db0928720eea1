"""A card that fills up: an opener whose ``flight.csv`` raises ENOSPC after some bytes (no
root, no tiny filesystem needed)."""

from __future__ import annotations

import errno
from pathlib import Path
from typing import IO

from helixd.recorder.rundir import default_opener


class FullAfter:
    """An opener (``RunRecorder.create(opener=...)``) whose ``name`` file raises
    ``OSError(ENOSPC)`` once ``limit`` characters have been written to it."""

    def __init__(self, limit: int, name: str = "flight.csv") -> None:
        self.limit = limit
        self.name = name

    def __call__(self, path: Path, mode: str) -> IO[str]:
        fh = default_opener(path, mode)
        if path.name != self.name:
            return fh
        limit = self.limit
        written = 0
        real_write = fh.write

        def write(text: str) -> int:
            nonlocal written
            written += len(text)
            if written > limit:
                raise OSError(errno.ENOSPC, "No space left on device", str(path))
            return real_write(text)

        fh.write = write  # type: ignore[method-assign]
        return fh
