"""check's flight table: one line per step, the do items under it, each step's end by the
estimate (legs at their own speed, holds waited), and the total equal to the plan's."""

from __future__ import annotations

import pytest

from helixd.config.root import HelixdConfig
from helixd.mission.describe import program_lines, step_end_times_s
from helixd.mission.model import Mission
from helixd.mission.resolve import resolve

CFG = HelixdConfig()


def test_step_ends_count_each_legs_speed_and_the_holds() -> None:
    m = Mission.model_validate(
        {
            "name": "d",
            "mode": "omni",  # no turns in place: the times are the legs and the holds alone
            "frame": "start",
            "waypoints": [
                {"x": 6, "y": 0},
                {"command": "DO_CHANGE_SPEED", "speed_mps": 0.3},
                {"x": 6, "y": 3, "hold_s": 10},
                {"command": "DO_SET_SERVO", "channel": 9, "pwm_us": 1900},
                {"x": 0, "y": 3},
            ],
        }
    )
    plan = resolve(m, CFG.control, CFG.mission).plan
    ends = step_end_times_s(plan, CFG.control.max_yaw_rate_radps, (0.0, 0.0))
    assert ends == pytest.approx([10.0, 30.0, 50.0])  # 6 m at 0.6; 3 m at 0.3 + 10 s; 6 m at 0.3
    lines = program_lines(plan, CFG.control.max_yaw_rate_radps, (0.0, 0.0))
    assert lines[2].split()[:3] == ["1", "1", "NAV_WAYPOINT"]
    assert "hold 10 s" in lines[3] and lines[3].rstrip().endswith("30s")
    assert "+ DO_CHANGE_SPEED → 0.30 m/s" in lines[4]
    assert "+ DO_SET_SERVO channel 9, pwm_us 1900" in lines[6]
