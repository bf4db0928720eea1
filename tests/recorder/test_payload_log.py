"""payload.csv: readings placed at their autopilot time's pose (helixd/recorder/payload_log.py)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.frames import NedPose
from helixd.config.recorder import PayloadConfig, PayloadSource
from helixd.link.payload_msgs import Reading
from helixd.link.vehicle import PoseSample
from helixd.recorder.payload_log import (
    COLUMNS,
    CSV_COMMENT,
    PayloadCsvError,
    PayloadLog,
    PayloadPlacer,
    read_payload_quantity,
)


def reading(value: float = 1.0) -> Reading:
    return Reading("DISTANCE_SENSOR", "depth_m", value, None, 0, 0, value)


def test_a_reading_between_two_poses_is_placed_on_the_line_between_them() -> None:
    p = PayloadPlacer(max_gap_s=1.0)
    assert p.pose(10.0, 0.0, 0.0, 0.0) == []
    assert p.reading(10.05, reading()) == []  # waits for the next pose
    (placed,) = p.pose(10.1, 1.0, 2.0, 0.2)
    assert placed.t_boot_s == 10.05
    assert math.isclose(placed.north_m, 0.5) and math.isclose(placed.east_m, 1.0)
    assert math.isclose(placed.yaw_ned_rad, 0.1)


def test_yaw_is_interpolated_the_short_way_round() -> None:
    p = PayloadPlacer(max_gap_s=1.0)
    p.pose(0.0, 0.0, 0.0, math.pi - 0.1)
    p.pose(0.2, 0.0, 0.0, -math.pi + 0.1)
    (placed,) = p.reading(0.1, reading())  # a pose after it is known: placed at once
    assert math.isclose(abs(placed.yaw_ned_rad), math.pi, abs_tol=1e-9)


def test_no_pose_within_the_gap_places_nothing() -> None:
    p = PayloadPlacer(max_gap_s=0.5)
    p.pose(0.0, 0.0, 0.0, 0.0)
    p.reading(1.0, reading())
    assert p.pose(2.0, 5.0, 5.0, 0.0) == []  # poses 2 s apart: not interpolated
    assert p.dropped == 1
    p.reading(2.3, reading())
    (flushed,) = p.flush()  # at close: the last pose, 0.3 s before it
    assert (flushed.north_m, flushed.east_m) == (5.0, 5.0)
    p.reading(3.0, reading())
    assert p.flush() == [] and p.dropped == 2


def test_a_reboot_starts_the_poses_again() -> None:
    p = PayloadPlacer(max_gap_s=1.0)
    p.pose(100.0, 9.0, 9.0, 0.0)
    p.pose(1.0, 0.0, 0.0, 0.0)  # time_boot_ms went back: a reboot
    p.reading(1.05, reading())
    (placed,) = p.pose(1.1, 1.0, 0.0, 0.0)
    assert math.isclose(placed.north_m, 0.5)


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.floats(0.0, 100.0), min_size=2, max_size=20, unique=True),
    st.floats(0.0, 100.0),
)
def test_placed_positions_lie_between_the_bracketing_poses(times: list[float], t: float) -> None:
    """On a straight track north = 2·t, every reading inside the poses' span and gaps is placed
    exactly on it."""
    times.sort()
    p = PayloadPlacer(max_gap_s=1000.0)
    for ti in times:
        p.pose(ti, 2.0 * ti, 0.0, 0.0)
    out = p.reading(t, reading())
    if times[0] <= t <= times[-1]:
        (placed,) = out
        assert math.isclose(placed.north_m, 2.0 * t, rel_tol=1e-9, abs_tol=1e-9)
    elif t < times[0]:
        assert out == [] and p.dropped == 1


def _write(path: Path, rows: list[str], header: str = ",".join(COLUMNS)) -> Path:
    path.write_text(CSV_COMMENT + "\n" + header + "\n" + "\n".join(rows) + "\n")
    return path


def _row(lat: str, lon: str, quantity: str, value: str) -> str:
    return (
        f"1.000,0.0,0.0,0.0,{lat},{lon},water,MANUAL,DISTANCE_SENSOR,{quantity},{value},0,0,{value}"
    )


def test_the_reader_takes_one_quantity_and_skips_rows_without_place_or_value(
    tmp_path: Path,
) -> None:
    path = _write(
        tmp_path / "payload.csv",
        [
            _row("53.5", "-113.5", "depth_m", "1.25"),
            _row("nan", "nan", "depth_m", "1.0"),  # no origin yet: no place
            _row("53.5", "-113.5", "depth_m", "inf"),
            _row("95.0", "-113.5", "depth_m", "1.0"),  # off the Earth
            _row("53.5", "-113.5", "nv_wtemp", "17.0"),
            "garbage,row",
        ],
    )
    got = read_payload_quantity([path], "depth_m")
    assert got.value.tolist() == [1.25] and got.skipped == 3
    assert got.lat_deg.tolist() == [53.5]


def test_a_file_that_is_not_a_payload_csv_is_refused_naming_it(tmp_path: Path) -> None:
    bad = _write(tmp_path / "flight.csv", [], header="t_boot_s,north_m")
    with pytest.raises(PayloadCsvError) as err:
        read_payload_quantity([bad], "depth_m")
    assert "flight.csv" in err.value.problems[0]
    with pytest.raises(PayloadCsvError):
        read_payload_quantity([tmp_path / "missing.csv"], "depth_m")


class _State:
    def __init__(self) -> None:
        self.pose: PoseSample | None = None
        self.gps_origin: tuple[float, float] | None = (53.5, -113.5)
        self.mode = "MANUAL"


class _Link:
    """The part of the Autopilot the log uses: its state and its listeners."""

    def __init__(self) -> None:
        self.state = _State()
        self.listeners: list[Any] = []

    def add_message_listener(self, cb: Any) -> None:
        self.listeners.append(cb)

    def remove_message_listener(self, cb: Any) -> None:
        self.listeners.remove(cb)

    def receive(self, msg: Any) -> None:
        if msg.get_type() == "LOCAL_POSITION_NED":  # as the link's state would accept it
            self.state.pose = PoseSample(
                NedPose(msg.x, msg.y, 0.0), msg.time_boot_ms, 0.0, 0.0, 0.0, 0.0
            )
        for cb in list(self.listeners):
            cb(msg, 0.0)


def test_the_log_writes_placed_readings_counts_the_rest_and_lets_go(tmp_path: Path) -> None:
    link = _Link()
    cfg = PayloadConfig(
        sources=[
            PayloadSource(message="DISTANCE_SENSOR", quantity="depth_m", offset_m=0.1),
            PayloadSource(message="RANGEFINDER", quantity="range_m"),
        ]
    )
    plog = PayloadLog.attach(link, cfg, tmp_path)  # type: ignore[arg-type]
    assert plog is not None and link.listeners
    lpn = mavlink.MAVLink_local_position_ned_message
    link.receive(lpn(1000, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    ds = mavlink.MAVLink_distance_sensor_message
    link.receive(ds(1010, 20, 3000, 150, 1, 0, 25, 0, 0.0, 0.0, [0.0] * 4, 0))
    link.receive(ds(1015, 20, 3000, 5, 1, 0, 25, 0, 0.0, 0.0, [0.0] * 4, 0))  # too close
    link.receive(mavlink.MAVLink_rangefinder_message(2.0, 0.0))  # no time: the latest (1015)
    link.receive(lpn(1020, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    plog.close()
    assert not link.listeners
    rows = read_payload_quantity([tmp_path / "payload.csv"], "depth_m")
    assert rows.value.tolist() == [pytest.approx(1.6)]
    assert rows.lat_deg[0] == pytest.approx(53.5 + 1.0 / 111_318.845, abs=1e-8)  # 1 m north
    text = (tmp_path / "payload.csv").read_text()
    assert "RANGEFINDER,range_m,2.0000" in text and ",MANUAL," in text
    assert plog.rows == 2 and plog.rejected == {"DISTANCE_SENSOR": 1}
    assert PayloadLog.attach(link, PayloadConfig(enabled=False), tmp_path) is None  # type: ignore[arg-type]
