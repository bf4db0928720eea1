"""Quick to answer: a start and a continue drive the scrolls within 0.5 s, also on an autopilot
without helixd-guard (a parameter the autopilot lacks used to cost a read timeout at every
start): the parameters are read while the service is idle, kept fresh by PARAM_VALUE, and a
missing one is remembered. The latencies are printed (run with ``-s``)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from helixd.mav.constants import (
    MAV_CMD_DO_PAUSE_CONTINUE,
    MAV_CMD_MISSION_START,
    MAV_RESULT_ACCEPTED,
)
from helixd.sim.snapshot import SimSnapshot
from tests.support.gcs import command, upload
from tests.support.harness import scrolls_neutral, time_until
from tests.support.serve import serving_crew

CONFIG: dict[str, Any] = {
    "startup": {"start_switch_channel": None},
    "link": {"own_id_watch_s": 0.5},
}
# the goal is 0.5 s (measured here: 0.23 s start, 0.50 s continue, an arm of 0.2 s in each;
# 4.2 s and 4.5 s before the parameters were kept); bound with room for a loaded machine
LATENCY_MAX_S = 1.0


def driving(s: SimSnapshot) -> bool:
    return s.armed and not scrolls_neutral(s)


def test_start_and_continue_drive_within_half_a_second_without_the_guard(
    tmp_path: Path,
) -> None:
    with serving_crew(tmp_path, CONFIG) as (server, gcs, d):  # no helixd-guard
        d.wait_line("no mission on the autopilot", 60.0)
        warm = d.wait_line("event=params_warm", 60.0)
        assert "HXG_VERSION" in warm  # missing: remembered, not read at each start
        upload(gcs, [(12.0, 0.0), (12.0, -6.0)])
        d.wait_line("event=serve_state state=ready", 30.0)
        t_start = time.monotonic()
        assert command(gcs, MAV_CMD_MISSION_START, 1, 0) == MAV_RESULT_ACCEPTED
        start_s = time_until(server, driving, t_start, 10.0)
        mark = d.mark()
        assert command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 0) == MAV_RESULT_ACCEPTED
        d.wait_line("event=serve_state state=paused", 30.0, after=mark)
        server.wait_for(lambda s: scrolls_neutral(s) and not s.armed, 10.0)
        t_continue = time.monotonic()
        assert command(gcs, MAV_CMD_DO_PAUSE_CONTINUE, 1) == MAV_RESULT_ACCEPTED
        continue_s = time_until(server, driving, t_continue, 10.0)
        print(f"\nStart → scrolls driven: {start_s:.3f} s; Continue → {continue_s:.3f} s")
        assert start_s <= LATENCY_MAX_S and continue_s <= LATENCY_MAX_S, (start_s, continue_s)
        assert "event=param_timeout" not in d.log_text()
