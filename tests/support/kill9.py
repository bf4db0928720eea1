"""kill -9 of an in-process ``helixd serve`` on the simulated clock (tests.support.simulated).

A killed process does nothing more: no fall-back, no summary, no state file update, no log
line, no MAVLink frame; the kernel closes its sockets and files; what it had written but
not flushed is lost. In this process the service is cancelled instead, and its cleanup runs
(it cannot be skipped), so everything that cleanup could reach is taken back:

* the wire: the simulator drops every datagram from the killed service's socket from the
  kill on (:meth:`helixd.sim.server.SimServer.cut_peer`), so no HOLD, no release, no
  STATUSTEXT of its cleanup reaches the autopilot or the ground station;
* the disk: :class:`DiskImage` records the run root (its files' sizes, the small ones' whole
  contents) at the kill, on the kernel's side of Python's buffers (``os.stat``), and puts it
  back once the cleanup ended: files created since removed, appended ones truncated (a torn
  last line where the kill fell mid-row), replaced ones (the state file) restored;
* the console: the killed service's log lines after the kill are dropped, and the run's
  events file it held is let go (structlog's handler, as the kernel closes the file).

Then systemd's ``RestartSec`` (:data:`RESTART_S`) passes before the next start.
"""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass, field
from pathlib import Path

RESTART_S = 5.0  # systemd/helixd.service's RestartSec
KILLED_CODE = -9  # what the in-process harness reports as a killed start's exit (signal 9)
WHOLE_BYTES = 262_144  # files up to this size are kept whole (a replace is put back)


@dataclass
class DiskImage:
    """What a tree of files held at one moment, for :meth:`restore`."""

    root: Path
    sizes: dict[Path, int] = field(default_factory=dict)
    whole: dict[Path, bytes] = field(default_factory=dict)
    dirs: set[Path] = field(default_factory=set)

    @classmethod
    def take(cls, root: Path) -> DiskImage:
        image = cls(root)
        if not root.is_dir():
            return image
        for here, dirs, files in os.walk(root):
            base = Path(here)
            image.dirs.add(base)
            image.dirs.update(base / d for d in dirs)
            for name in files:
                path = base / name
                try:
                    size = path.stat().st_size
                    image.sizes[path] = size
                    if size <= WHOLE_BYTES:
                        image.whole[path] = path.read_bytes()
                except OSError:
                    continue
        return image

    def restore(self) -> list[str]:
        """The tree as it was; what was changed back (for the test's log)."""
        changed: list[str] = []
        if not self.root.is_dir():
            return changed
        for here, dirs, files in os.walk(self.root, topdown=True):
            base = Path(here)
            for d in list(dirs):
                if base / d not in self.dirs:
                    shutil.rmtree(base / d, ignore_errors=True)
                    dirs.remove(d)
                    changed.append(f"removed {base / d}")
            for name in files:
                path = base / name
                if path not in self.sizes:
                    path.unlink(missing_ok=True)
                    changed.append(f"removed {path}")
                elif path in self.whole:
                    if path.read_bytes() != self.whole[path]:
                        path.write_bytes(self.whole[path])
                        changed.append(f"restored {path}")
                elif path.stat().st_size > self.sizes[path]:
                    os.truncate(path, self.sizes[path])
                    changed.append(f"truncated {path}")
        for path, data in self.whole.items():  # removed by the cleanup: back
            if not path.exists() and path.parent.is_dir():
                path.write_bytes(data)
                changed.append(f"restored {path}")
        return changed


__all__ = ["KILLED_CODE", "RESTART_S", "WHOLE_BYTES", "DiskImage"]
