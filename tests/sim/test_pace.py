"""Does the machine keep the asked speed-up? (helixd.sim.pace and the wall-clock shell)

Before: at ``--sim-speedup 10`` an amphibious flight fell apart without a word (898 s
against a 548 s estimate, loops in the water): the machine could not keep the simulated
autopilot and the control loop at that pace. The judge is tested with the wake-ups it is fed,
and the shell with a slow loop injected through its seam, never by loading the machine."""

from __future__ import annotations

import time

import pytest
import structlog.testing

from helixd.sim.pace import PaceJudge
from helixd.sim.server import SimServer, start_embedded
from tests.support.harness import (
    FORCE_ARM,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_RESULT_ACCEPTED,
    client,
    sim_config,
)

DT_S = 0.02  # the simulator's 50 Hz loop


def feed(
    judge: PaceJudge, speedup: float, loops: list[int], flying: bool = True, start: float = 0.0
) -> list[object]:
    """Wake-ups each running ``loops[i]`` loops, simulated time kept at ``speedup``."""
    verdicts = []
    sim_s, wall_s = start, start / speedup
    for n in loops:
        sim_s += n * DT_S
        wall_s += n * DT_S / speedup
        verdict = judge.wake(wall_s, sim_s, n, speedup, flying)
        if verdict is not None:
            verdicts.append(verdict)
    return verdicts


def test_a_machine_on_time_keeps_its_speed_up() -> None:
    assert feed(PaceJudge(DT_S), 10.0, [1] * 2000) == []
    assert feed(PaceJudge(DT_S), 10.0, [1, 1, 2, 1] * 500) == []  # the odd late wake-up


def test_one_stall_among_punctual_wake_ups_is_not_a_slow_machine() -> None:
    """A garbage collection: 50 loops at once, once; counted as 5."""
    assert feed(PaceJudge(DT_S), 10.0, [1] * 60 + [50] + [1] * 2000) == []


def test_late_wake_ups_lower_the_speed_up_to_what_was_kept() -> None:
    judge = PaceJudge(DT_S)
    verdicts = feed(judge, 10.0, [4] * 200)  # every pose of four goes out late, in a burst
    assert verdicts, "not judged"
    first = verdicts[0]
    assert first.asked == 10.0 and first.loops_per_wakeup == pytest.approx(4.0)  # type: ignore[attr-defined]
    assert first.speedup == pytest.approx(2.5)  # type: ignore[attr-defined]
    assert "cannot keep speed-up 10" in first.reason()  # type: ignore[attr-defined]


def test_one_late_window_is_not_yet_a_verdict() -> None:
    judge = PaceJudge(DT_S)
    late_window = [4] * 30  # 2.4 simulated seconds
    assert feed(judge, 10.0, late_window + [1] * 200 + late_window + [1] * 200) == []


def test_simulated_time_falling_behind_is_not_kept_either() -> None:
    judge = PaceJudge(DT_S)
    verdicts = []
    sim_s = wall_s = 0.0
    for _ in range(400):  # one loop per wake-up, but at 3x the wall instead of 10x
        sim_s += DT_S
        wall_s += DT_S / 3.0
        verdict = judge.wake(wall_s, sim_s, 1, 10.0, True)
        if verdict is not None:
            verdicts.append(verdict)
    assert verdicts and verdicts[0].speedup == pytest.approx(3.0)
    assert verdicts[0].achieved == pytest.approx(3.0)


def test_only_a_flight_is_judged_and_real_time_is_not_lowered() -> None:
    assert feed(PaceJudge(DT_S), 10.0, [4] * 400, flying=False) == []
    (verdict, *_) = feed(PaceJudge(DT_S), 1.0, [4] * 400)
    assert verdict.speedup == verdict.asked == 1.0  # type: ignore[attr-defined]


def test_a_simulator_slower_than_its_speed_up_says_so_at_once_and_lowers_it() -> None:
    """The shell with a slow machine injected: every loop costs 4 ms of wall time more, so at
    most 5x can be kept (20 ms of simulated time per loop), whatever the machine."""
    server, url = start_embedded(sim_config(speedup=10.0), judge_pace=True)
    try:
        with client(url) as c, structlog.testing.capture_logs() as events:
            c.expect("HEARTBEAT", 10.0, lambda m: int(m.custom_mode) != 16)  # booted
            assert c.command(MAV_CMD_COMPONENT_ARM_DISARM, 1, FORCE_ARM) == MAV_RESULT_ACCEPTED
            slow_from = server.wait_for(lambda s: s.armed, 10.0).sim_time_s
            server.after_tick = lambda: time.sleep(0.004)  # the seam: a slow machine
            server.wait_for(lambda _: server.history.first("pace") is not None, 60.0)
    finally:
        server.stop()
    lowered = server.history.first("pace")
    assert lowered is not None
    assert lowered.details["asked_speedup"] == 10.0
    assert 1.0 <= float(str(lowered.details["speedup"])) <= 5.0
    assert server.speedup == lowered.details["speedup"]
    # at once: two windows of 2 simulated seconds late, the first perhaps begun on time
    assert lowered.sim_time_s - slow_from <= 3 * 2.0 + 0.1
    warned = [e for e in events if e["event"] == "sim_speedup_lowered"]
    assert len(warned) >= 1 and warned[0]["log_level"] == "warning"
    assert "cannot keep speed-up 10" in str(warned[0]["why"])


def test_a_simulator_not_asked_to_judge_its_pace_keeps_its_speed_up() -> None:
    server = SimServer(["udpin:127.0.0.1:0"], sim_config(speedup=10.0))
    assert server.speedup == 10.0 and not server._judge
