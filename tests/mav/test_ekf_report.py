"""helixd.mav.ekf_report: EKF_STATUS_REPORT as one record, read by its wire field names."""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.vehicle import EkfStatus
from helixd.mav.constants import EKF_ATTITUDE, EKF_CONST_POS_MODE, EKF_GPS_GLITCHING
from helixd.mav.ekf_report import VARIANCE_FIELDS, EkfReport


def report_message(flags: int, *variances: float) -> mavlink.MAVLink_ekf_status_report_message:
    return mavlink.MAVLink_ekf_status_report_message(flags, *variances, 0.0)  # airspeed last


def test_every_variance_is_read_from_its_own_field() -> None:
    msg = report_message(EKF_ATTITUDE, 0.1, 0.2, 0.3, 0.4, 0.5)
    report = EkfReport.from_message(msg)
    assert report == EkfReport(EKF_ATTITUDE, 0.1, 0.2, 0.3, 0.4, 0.5)
    for name in VARIANCE_FIELDS:
        assert getattr(report, name) == getattr(msg, name)
    assert len(VARIANCE_FIELDS) == 5


def test_a_non_finite_variance_is_kept_for_the_link_to_refuse() -> None:
    report = EkfReport.from_message(report_message(0x1 | 0x2 | 0x8, math.nan, 0, 0, 0, 0))
    assert math.isnan(report.velocity_variance)
    status = EkfStatus(report, rx_monotonic_s=1.0, variance_max=0.8)
    assert not status.healthy
    assert "velocity variance nan" in status.describe()


def test_the_flags_are_mavlinks_ekf_status_flags() -> None:
    assert (EKF_ATTITUDE, EKF_CONST_POS_MODE, EKF_GPS_GLITCHING) == (
        mavlink.EKF_ATTITUDE,
        mavlink.EKF_CONST_POS_MODE,
        mavlink.EKF_GPS_GLITCHING,
    )
