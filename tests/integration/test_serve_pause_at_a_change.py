"""A pause just before a change of mode, then Continue, under ``helixd serve`` with a media map
(on the simulated clock): the crew pauses (HOLD) about a metre before the roll → scroll stop
on the bank, then continues (AUTO). The rover must re-enter the plan where it stands: before
the stop it drives on to it and turns there; one that coasted past it turns where it stands
while the ground there still lets it (the map's medium under it is the one it was rolling
on), without driving back past the stop or flipping modes; then it scrolls across and rolls
out as it would without the pause."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from helixd.base.media import MediaArea, MediaFrame, MediaMap, Medium
from helixd.recorder.rows import read_flight_columns
from tests.support.harness import guard_installed
from tests.support.loop_gcs import set_mode, simulated_crew, upload, upload_and_start
from tests.support.loop_mav import LoopMav
from tests.support.serve import flight_summaries
from tests.support.simulated import Steer

WATER_N = (10.0, 30.0)  # the water band's south and north edges (m north)
STOP_N = WATER_N[0] - 1.0  # the roll → scroll stop, media.transition_margin_m before it


def water_map(path: Path) -> Path:
    ring = [[-30, WATER_N[0]], [30, WATER_N[0]], [30, WATER_N[1]], [-30, WATER_N[1]]]
    data = {
        "type": "FeatureCollection", "frame": "local_ned", "default_medium": "hard",
        "features": [{"type": "Feature", "properties": {"medium": "water"},
                      "geometry": {"type": "Polygon", "coordinates": [[*ring, ring[0]]]}}],
    }  # fmt: skip
    path.write_text(json.dumps(data), encoding="utf-8")
    return path


def config(tmp_path: Path) -> dict[str, Any]:
    return {
        "startup": {"start_switch_channel": None},
        "link": {"own_id_watch_s": 0.5},
        "media": {"media_map": str(water_map(tmp_path / "water.geojson"))},
    }


WORLD = MediaMap(
    MediaFrame.LOCAL_NED,
    (MediaArea(Medium.WATER, ((WATER_N[0], -30.0), (WATER_N[0], 30.0), (WATER_N[1], 30.0),
                              (WATER_N[1], -30.0))),),
    Medium.HARD,
)  # fmt: skip


def modes_in_order(modes: np.ndarray) -> list[str]:
    out: list[str] = []
    for m in modes:
        if not out or out[-1] != m:
            out.append(str(m))
    return out


# (where the crew pauses, how far the rover rolled on while held): the simulator's rover
# stops within 0.2 m of the HOLD, so rolling on is made a jump of the reported position
# while held (the navigator sees what the EKF reports, as it would a rover that coasted)
CASES = [(STOP_N - 1.0, 0.0), (STOP_N - 0.45, 0.0), (STOP_N - 1.0, 1.4), (STOP_N - 0.3, 0.6)]


@pytest.mark.parametrize(("pause_at_n", "rolled_on_m"), CASES)
def test_a_pause_before_the_roll_to_scroll_stop_continues_into_the_plan(
    tmp_path: Path, pause_at_n: float, rolled_on_m: float
) -> None:
    async def crew(st: Steer, gcs: LoopMav) -> tuple[float, float]:
        await upload_and_start(st, gcs, lambda: upload(gcs, [(40.0, 0.0)]))
        await st.until(lambda s: s.north_m >= pause_at_n, 60.0)
        await set_mode(gcs, "HOLD")  # Pause
        await st.until(lambda s: s.speed_mps < 0.02, 20.0)
        if rolled_on_m > 0.0:
            st.inject("gps_jump", distance_m=rolled_on_m, bearing_deg=0.0, variance=0.0)
        t_hold = st.snapshot().sim_time_s
        await st.until(lambda s: s.sim_time_s >= t_hold + 3.0, 20.0)
        held_n = st.snapshot().est_north_m
        t_continue = st.snapshot().sim_time_s
        await set_mode(gcs, "AUTO")  # Continue
        if rolled_on_m > 0.0:  # mid-water the reported position is the truth again
            await st.until(lambda s: s.est_north_m >= 20.0, 120.0)
            st.inject("gps_jump", distance_m=rolled_on_m, bearing_deg=180.0, variance=0.0)
        await st.line("event=serve_state state=completed", 240.0)
        return held_n, t_continue

    served = simulated_crew(
        tmp_path, config(tmp_path), crew, media=WORLD, noise="low", seed=3, **guard_installed(1.0)
    )
    assert served.code == 0, served.log[-3000:]
    ((held_n, t_continue),) = served.steered
    (summary,) = flight_summaries(tmp_path)
    assert summary["completed"], summary
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    c = read_flight_columns(runs[0] / "flight.csv")
    driving = np.hypot(c["vx_cmd_mps"], c["vy_cmd_mps"]) > 0.0
    order = modes_in_order(c["motion_mode"][driving])
    print(f"\npaused at {pause_at_n:.2f} m, stood at {held_n:.2f} m; modes {order}")
    assert order == ["roll", "scroll", "roll"], order
    assert "ground_changed" not in served.log  # no flip on ground the map has right
    first_scroll = int(np.argmax(c["motion_mode"] == "scroll"))
    resumed = c["north_m"][(c["t_boot_s"] >= t_continue) & (np.arange(len(driving)) < first_scroll)]
    # on from where it stood: never back across the stop, never rolled into the water
    assert resumed.size and float(np.min(resumed)) > held_n - 0.3, (float(np.min(resumed)), held_n)
    assert float(np.max(c["north_m"][:first_scroll])) < WATER_N[0]
    # turned where it stood (before the stop: at the stop; past it: where it stood)
    turn_n = float(c["north_m"][first_scroll])
    assert turn_n == pytest.approx(max(STOP_N, held_n), abs=0.35), (turn_n, held_n)
    assert float(np.max(c["north_m"])) == pytest.approx(40.0, abs=0.5)
