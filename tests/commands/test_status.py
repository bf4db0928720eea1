"""helixd.commands.status: the lines `helixd status` prints (pure)."""

from __future__ import annotations

import pytest

from helixd.base.frames import NedPose
from helixd.commands.status import HeldLog, format_status, guard_text, log_lines
from helixd.link.vehicle import PoseSample, VehicleState
from helixd.mav.guard_script import VERSION
from tests.support.cli import run_main
from tests.support.harness import running_sim


def test_gps_battery_and_lat_lon_are_shown() -> None:
    st = VehicleState()
    assert "gps       : no GPS_RAW_INT" in format_status(st, 0.0)
    assert "battery   : not reported" in format_status(st, 0.0)
    st.gps_fix_type, st.gps_satellites = 6, 17
    st.battery_voltage_v, st.battery_remaining_pct = 24.0, 63
    st.gps_origin = (53.52325, -113.52632)
    st.pose = PoseSample(NedPose(0.0, 0.0, 0.0), 1000, 1.0, 0.0, 0.0, 0.0)
    lines = format_status(st, 1.0)
    assert "gps       : RTK fixed, 17 satellites" in lines
    assert "battery   : 24.00 V, 63 %" in lines
    assert "position  : 53.5232500°, -113.5263200° (the EKF pose through its origin)" in lines
    st.gps_origin = None
    assert "origin    : none reported (no GPS_GLOBAL_ORIGIN: no GPS fix yet?)" in format_status(
        st, 1.0
    )


def test_the_guard_line_says_whether_it_runs_and_is_enabled() -> None:
    """Before: `status` did not show whether helixd-guard is installed and enabled."""
    running = {"SCR_ENABLE": 1.0, "HXG_VERSION": float(VERSION), "HXG_ENABLE": 1.0}
    running |= {"HXG_CHAN1": 1.0, "HXG_CHAN2": 3.0, "HXG_CHAN3": 0.0, "HXG_CHAN4": 0.0}
    assert guard_text(running) == (
        f"helixd-guard v{VERSION} runs, enabled (HXG_ENABLE = 1), holds outputs 1, 3"
    )
    assert "DISABLED (HXG_ENABLE = 0)" in guard_text({**running, "HXG_ENABLE": 0.0})
    assert "this helixd needs" in guard_text({**running, "HXG_VERSION": float(VERSION + 1)})
    absent = {n: None for n in ("HXG_VERSION", "HXG_ENABLE", "HXG_CHAN1")}
    assert guard_text({**absent, "SCR_ENABLE": 0.0}) == (
        "helixd-guard not running (SCR_ENABLE = 0): helixd autopilot install-guard --reboot"
    )
    assert "installed since the last boot" in guard_text({**absent, "SCR_ENABLE": 1.0})
    assert "no Lua scripting" in guard_text({**absent, "SCR_ENABLE": None})


def test_status_shows_the_guard_of_a_simulated_autopilot(
    capsys: pytest.CaptureFixture[str],
) -> None:
    with running_sim(guard_installed=True) as (server, url):
        server.wait_for(lambda s: s.guard_version is not None, 20.0)
        code, out, err = run_main(["status", "--connect", url], capsys)
    assert code == 0, err
    guard = [line for line in out.splitlines() if line.startswith("guard     :")]
    assert guard == [
        f"guard     : helixd-guard v{VERSION} runs, enabled (HXG_ENABLE = 1), holds outputs "
        "1, 2, 3, 4"
    ]


def test_held_log_gives_whole_lines_only() -> None:
    held = HeldLog()
    held.write("a=1 event=one\nb=2 ev")
    assert held.drain() == ["a=1 event=one"]
    held.write("ent=two\n")
    assert log_lines(held.drain()) == ["log       : b=2 event=two"]
    assert held.drain() == []


def test_status_log_lines_come_after_the_report_not_among_it(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """Before: a warning while reading (here SCHED_LOOP_RATE out of range) was printed on
    stderr between the report's lines. Now the report is whole, then its `log` lines."""
    with running_sim(params={"SCHED_LOOP_RATE": 5000}) as (_, url):
        code, out, err = run_main(["status", "--connect", url], capsys)
    assert code == 0, err
    lines = out.splitlines()
    logged = [n for n, line in enumerate(lines) if line.startswith("log       : ")]
    assert logged, out
    assert any("stream_loop_rate_invalid" in lines[n] for n in logged)
    assert lines[logged[0] - 1].startswith("servo µs  :")  # the report's last line
    assert logged == list(range(logged[0], len(lines)))  # nothing of the report after them
    assert "stream_loop_rate_invalid" not in err
