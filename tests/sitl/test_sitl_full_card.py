"""The companion's card fills mid-flight on real ArduPilot Rover SITL (opt-in:
``HELIXD_SITL_BIN``; mounting the small card needs root).

The run directory is on a real 1 MiB tmpfs: preflight warns that it is below one flight's
record, the reserved space for ``summary.json`` is taken when the run starts, and the tlog and
``flight.csv`` fill the rest some seconds into the square. What must hold, as on the
simulator (``tests/integration/test_record_cut.py``): the flight goes on and completes (exit
0); one ``record_cut`` WARNING, at once, in the log and at the ground station (a STATUSTEXT
that a QGroundControl-like client on SITL's SERIAL2 receives); ``summary.json`` written,
saying from when and which files the record is missing. Printed: when the card filled and
what was cut.
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

from helixd.base.exitcodes import ExitCode
from helixd.recorder.rundir import RESERVE_FILE

if TYPE_CHECKING:
    from tests.sitl.conftest import DaemonRun, SitlVehicle
from tests.support import sitl_steps as crew

pytestmark = [pytest.mark.sitl, pytest.mark.timeout(900)]

CARD_SIZE = "1m"  # the reserve (256 KiB) and a few seconds of the square's record
FLIGHT_WALL_S = 400.0  # connect, preflight, arm and the square at speed-up 1


@contextlib.contextmanager
def small_card(path: Path) -> Iterator[Path]:
    """A real tmpfs of CARD_SIZE mounted at ``path`` (root only), unmounted afterwards."""
    if os.geteuid() != 0:
        pytest.skip("mounting a small tmpfs as the card needs root")
    path.mkdir()
    mount = ["mount", "-t", "tmpfs", "-o", f"size={CARD_SIZE}", "tmpfs", str(path)]
    done = subprocess.run(mount, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield path
    finally:
        subprocess.run(["umount", "-l", str(path)], check=False)


def test_a_full_card_mid_flight_is_told_once_and_the_flight_completes(
    sitl: SitlVehicle, launch_helixd: Callable[[str], DaemonRun], tmp_path: Path
) -> None:
    gcs = crew.ground_station(sitl)
    with small_card(tmp_path / "runs"), contextlib.closing(gcs):  # launch_helixd's run root
        started = time.monotonic()
        daemon = launch_helixd("rc_override")
        code = daemon.wait_exit(FLIGHT_WALL_S)
        log = daemon.log_text()
        assert code == ExitCode.OK, log[-4000:]
        run_dir = daemon.run_dir()
        summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
        leftover_reserve = (run_dir / RESERVE_FILE).exists()
    print(
        f"full card on SITL: record cut at {summary.get('record_cut_at_s')} s of "
        f"{summary.get('duration_s')} s, files {summary.get('record_cut_files')}; "
        f"flight completed, exit {code}, {time.monotonic() - started:.0f} s wall"
    )
    assert "event=disk_space_low" in log  # preflight: below one flight's record
    assert summary["completed"] is True and summary["waypoints_reached"] == 4
    assert summary["record_cut_files"], summary
    assert 0.0 < summary["record_cut_at_s"] < summary["duration_s"], summary
    assert not leftover_reserve
    cuts = [ln for ln in log.splitlines() if "event=record_cut " in ln]
    assert len(cuts) == 1 and "level=warning" in cuts[0], cuts
    texts = gcs.helixd_texts
    assert sum("record cut" in t for t in texts) == 1, texts  # the flight is over: all arrived
