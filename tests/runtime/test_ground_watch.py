"""The flight loop's watch on the ground: what the ground station reads of a change."""

from __future__ import annotations

import pytest

from helixd.base.plan import MotionMode
from helixd.config.media import MediaConfig
from helixd.control.ground_check import GroundVerdict
from helixd.mav.constants import MAV_SEVERITY_WARNING
from helixd.report.gcs_report import PREFIX, chunk_statustext
from helixd.runtime.ground_watch import GroundChange, check_params


@pytest.mark.parametrize(
    "verdict",
    [
        GroundVerdict(MotionMode.SCROLL, True, 1.0, MotionMode.ROLL),  # the longest percentages
        GroundVerdict(MotionMode.SCROLL, True, 0.05, MotionMode.ROLL),
        GroundVerdict(MotionMode.ROLL, False, 0.45, MotionMode.SCROLL),
        GroundVerdict(MotionMode.OMNI, True, 0.999, MotionMode.ROLL),
        GroundVerdict(MotionMode.ROLL, False, 0.999, MotionMode.OMNI),
    ],
)
def test_a_change_of_mode_costs_one_statustext(verdict: GroundVerdict) -> None:
    change = GroundChange(verdict, MotionMode.ROLL, 3, 10.0, 0.0)
    text = change.text()
    assert len(chunk_statustext(MAV_SEVERITY_WARNING, PREFIX + text, 1)) == 1, text
    assert verdict.mode.value in text and f"{round(100 * verdict.fraction)}%" in text
    assert f"of {verdict.judged.value})" in text  # the mode whose delivery was judged


def test_the_checks_modes_are_the_mode_policys() -> None:
    """The check's firm and soft modes are media.modes' for hard ground and mud: what the
    config ships (ROLL, SCROLL), or what the crew set; its thresholds are media's."""
    shipped = check_params(MediaConfig())
    assert (shipped.firm_mode, shipped.soft_mode) == (MotionMode.ROLL, MotionMode.SCROLL)
    media = MediaConfig.model_validate({"modes": {"mud": "omni"}, "detect_window_m": 2.0})
    own = check_params(media)
    assert (own.firm_mode, own.soft_mode, own.window_m) == (MotionMode.ROLL, MotionMode.OMNI, 2.0)
    learned = check_params(MediaConfig(modes="learned"))  # the profile is the plan's
    assert (learned.firm_mode, learned.soft_mode) == (MotionMode.ROLL, MotionMode.SCROLL)
