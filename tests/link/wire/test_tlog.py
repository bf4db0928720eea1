"""helixd.link.wire.tlog: written .tlog files read back by pymavlink's own reader."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.link.wire.tlog import TlogWriter, tlog_record
from tests.support.mavmsgs import read_tlog

T0 = 1_763_900_000.0  # a UNIX time in 2025


def frames() -> list[tuple[bytes, float, str]]:
    ours = mavlink.MAVLink(None, srcSystem=247, srcComponent=191)
    theirs = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    hb = mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(ours)
    att = mavlink.MAVLink_attitude_message(1000, 0.1, 0.2, 0.3, 0, 0, 0).pack(theirs)
    v1 = mavlink.MAVLink_system_time_message(0, 5).pack(theirs, force_mavlink1=True)
    return [(bytes(hb), T0, "HEARTBEAT"), (bytes(att), T0 + 0.25, "ATTITUDE"),
            (bytes(v1), T0 + 0.5, "SYSTEM_TIME")]  # fmt: skip


def test_round_trip_through_pymavlink(tmp_path: Path) -> None:
    path = tmp_path / "link.tlog"
    w = TlogWriter(path, 1024 * 1024)
    for frame, t, _ in frames():
        assert w.write(frame, t)
    assert path.stat().st_size == 0  # buffered, not yet written
    w.flush()
    w.close()
    got = read_tlog(path)
    assert [m.get_type() for m in got] == [kind for _, _, kind in frames()]
    assert [round(m._timestamp, 6) for m in got] == [T0, T0 + 0.25, T0 + 0.5]
    assert (got[0].get_srcSystem(), got[1].get_srcSystem()) == (247, 1)
    assert abs(got[1].roll - 0.1) < 1e-6


def test_size_cap_stops_on_a_whole_record(tmp_path: Path) -> None:
    path = tmp_path / "cap.tlog"
    frame, t, _ = frames()[1]
    rec = len(tlog_record(frame, t) or b"")
    w = TlogWriter(path, rec * 3 + rec // 2)
    results = [w.write(frame, t + i) for i in range(6)]
    w.flush()
    assert results == [True, True, True, False, False, False]
    assert not w.active and w.dropped_records == 3
    w.close()
    assert path.stat().st_size == rec * 3
    assert len(read_tlog(path)) == 3


def test_disk_error_fails_soft_once(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    w = TlogWriter(Path("/dev/full"), 1024 * 1024)
    frame, t, _ = frames()[0]
    assert w.write(frame, t)
    w.flush()  # ENOSPC: logged, stopped, no exception
    assert not w.active
    assert not w.write(frame, t)
    w.flush()
    w.close()
    missing = TlogWriter(tmp_path / "no" / "such" / "dir.tlog", 1024)
    assert not missing.active and not missing.write(frame, t)
    missing.close()


def test_garbage_is_not_logged(tmp_path: Path) -> None:
    w = TlogWriter(tmp_path / "g.tlog", 4096)
    frame, t, _ = frames()[0]
    assert not w.write(b"\x00" * 20, t)
    assert not w.write(frame, float("nan"))
    assert not w.write(frame, -1.0)
    assert not w.write(b"\xfd" * 400, t)
    assert w.buffered_bytes == 0 and w.dropped_records == 4
    w.close()


def test_appends_to_existing_and_counts_its_size(tmp_path: Path) -> None:
    path = tmp_path / "a.tlog"
    frame, t, _ = frames()[0]
    w = TlogWriter(path, 4096)
    w.write(frame, t)
    w.close()
    w2 = TlogWriter(path, 4096)
    assert w2.written_bytes == path.stat().st_size > 0
    w2.write(frame, t + 1)
    w2.close()
    assert len(read_tlog(path)) == 2


def test_disk_error_goes_to_on_error_once(capsys: pytest.CaptureFixture[str]) -> None:
    """With ``on_error`` set (the run recorder's record cut) the error is handed over once
    instead of logged as tlog_error."""
    w = TlogWriter(Path("/dev/full"), 1024 * 1024)
    told: list[tuple[Path, int | None]] = []
    w.on_error = lambda path, exc: told.append((path, exc.errno))
    frame, t, _ = frames()[0]
    assert w.write(frame, t)
    w.flush()
    w.close()
    assert told == [(Path("/dev/full"), 28)]  # ENOSPC
    assert "tlog_error" not in capsys.readouterr().err
