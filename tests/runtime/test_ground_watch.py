"""The flight loop's watch on the ground: what the ground station reads of a change."""

from __future__ import annotations

import pytest

from helixd.base.plan import MotionMode
from helixd.control.ground_check import GroundVerdict
from helixd.mav.constants import MAV_SEVERITY_WARNING
from helixd.report.gcs_report import PREFIX, chunk_statustext
from helixd.runtime.ground_watch import GroundChange


@pytest.mark.parametrize(
    "verdict",
    [
        GroundVerdict(MotionMode.SCROLL, True, 1.0),  # the longest percentages
        GroundVerdict(MotionMode.SCROLL, True, 0.05),
        GroundVerdict(MotionMode.ROLL, False, 0.45),
        GroundVerdict(MotionMode.OMNI, True, 0.999),
    ],
)
def test_a_change_of_mode_costs_one_statustext(verdict: GroundVerdict) -> None:
    change = GroundChange(verdict, MotionMode.ROLL, 3, 10.0, 0.0)
    text = change.text()
    assert len(chunk_statustext(MAV_SEVERITY_WARNING, PREFIX + text, 1)) == 1, text
    assert verdict.mode.value in text and f"{round(100 * verdict.fraction)}%" in text
