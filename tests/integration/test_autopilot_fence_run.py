"""``helixd run`` reads the autopilot's own fence in preflight and refuses (exit 3, nothing
armed) a route the autopilot would stop; a route inside it flies.

Before: ``run`` never looked at the autopilot's fence: a mission leaving it was stopped by
ArduPilot's FENCE_ACTION mid-flight."""

from __future__ import annotations

from pathlib import Path

import pytest

from helixd.base.exitcodes import ExitCode
from tests.support.gcs import QGC_SYSID, fence_circle, upload_fence
from tests.support.harness import SPEEDUP, client, daemon, running_sim

pytestmark = pytest.mark.integration


def test_a_route_out_of_the_autopilot_s_fence_is_refused(tmp_path: Path) -> None:
    with running_sim(speedup=SPEEDUP, params={"FENCE_ENABLE": 1.0}) as (server, url):
        with client(url, sysid=QGC_SYSID) as gcs:
            gcs.heartbeat()
            upload_fence(gcs, [fence_circle(0, 0.0, 0.0, 5.0, inclusion=True)])
        with daemon(tmp_path, url, "square") as d:
            code = d.wait_exit(60.0)
            log = d.log_text()
        assert not server.snapshot().armed
    assert code == ExitCode.PREFLIGHT, log[-3000:]
    assert "outside the autopilot's inclusion circle 1" in log
    assert "waypoint 1 (N 10.0 m, E 0.0 m)" in log


def test_a_route_inside_the_autopilot_s_fence_passes_preflight(tmp_path: Path) -> None:
    with running_sim(speedup=SPEEDUP) as (_server, url):
        with client(url, sysid=QGC_SYSID) as gcs:
            gcs.heartbeat()
            upload_fence(
                gcs,
                [
                    fence_circle(0, 0.0, 0.0, 50.0, inclusion=True),
                    fence_circle(1, 30.0, 30.0, 3.0, inclusion=False),
                ],
            )
        with daemon(tmp_path, url, "square") as d:
            judged = d.wait_line("autopilot_fence_judged", 60.0)
            d.wait_line("event=phase_end phase=preflight ok=true", 60.0)
    assert "circles=2" in judged and "problems=0" in judged
