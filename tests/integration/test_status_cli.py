"""`helixd status` against the simulator over UDP: read-only, and it says what it sees."""

from __future__ import annotations

import subprocess
import sys

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.harness import running_sim

pytestmark = pytest.mark.integration


def test_status_once() -> None:
    with running_sim(speedup=5.0) as (server, url):
        server.wait_for(lambda s: not s.booting and s.sim_time_s > 6.0, 20.0)
        res = subprocess.run(
            [sys.executable, "-m", "helixd", "status", "--connect", url],
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        snap = server.snapshot()
    assert res.returncode == 0, res.stderr
    out = res.stdout
    assert "mode      : MANUAL  (disarmed)" in out
    assert "pose      : N " in out and "(NED, clockwise from North)" in out
    assert "ekf       : EKF healthy" in out
    assert "rc in µs  : 1500" in out
    assert not snap.armed and not any(snap.overrides_active)  # read-only


def test_status_bad_url_is_one_clear_line() -> None:
    res = subprocess.run(
        [sys.executable, "-m", "helixd", "status", "--connect", "bogus://x"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert res.returncode == ExitCode.USAGE  # a bad command line, not a failed connection
    assert "Traceback" not in res.stderr
    assert res.stderr.count("error:") == 1 and "bogus://x" in res.stderr
