"""A quiet autopilot takes several loops in one step (SimCore.quiet_steps, on a simulated
clock): every message still leaves in the loop it is due in, and anything that could move the
rover makes it take its loops one by one again."""

from __future__ import annotations

from helixd.mav.constants import MAV_CMD_COMPONENT_ARM_DISARM, MAV_RESULT_ACCEPTED
from helixd.sim.core import QUIET_STEPS_MAX, SimCore
from tests.support.simcore import command, make_core, run


def sent(core: SimCore, seconds: float, quiet: bool) -> tuple[list[tuple[float, int, str]], int]:
    """(loop time, link, message type) of every message sent in ``seconds``; the steps taken."""
    out: list[tuple[float, int, str]] = []
    end_n = round((core.now_s + seconds) / core.dt_s())
    steps = 0
    while (left := end_n - round(core.now_s / core.dt_s())) > 0:
        core.tick(min(core.quiet_steps() if quiet else 1, left))
        steps += 1
        out += [(round(core.now_s, 3), lk or 0, m.get_type()) for lk, m in core.drain_outbox()]
    return out, steps


def booted() -> SimCore:
    core = make_core(home_delay_s=0.5, prearm_delay_s=0.5)
    run(core, 4.0)
    return core


def test_a_quiet_autopilot_sends_every_message_in_its_own_loop() -> None:
    fine, fine_steps = sent(booted(), 20.0, quiet=False)
    coarse, coarse_steps = sent(booted(), 20.0, quiet=True)
    assert fine and coarse == fine  # the same messages, each in the same loop
    assert fine_steps == 1000 and coarse_steps <= fine_steps // 4, coarse_steps


def test_armed_or_touched_it_takes_its_loops_one_by_one() -> None:
    core = booted()
    core.tick()
    core.drain_outbox()
    assert 1 <= core.quiet_steps() <= QUIET_STEPS_MAX
    core.set_rc(3, 1500)  # an input: the next loop is its own
    assert core.quiet_steps() == 1
    core.tick()
    assert command(core, 0, MAV_CMD_COMPONENT_ARM_DISARM, 1) == MAV_RESULT_ACCEPTED
    for _ in range(3):
        core.tick()
        core.drain_outbox()
        assert core.quiet_steps() == 1  # armed in MANUAL: the pilot's sticks drive
