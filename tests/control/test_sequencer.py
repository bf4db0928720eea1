"""The mission sequencer, stepped with numbers: holds, waits, conditions and dropped items as
AP_Mission::update and Rover's verify_command run them."""

from __future__ import annotations

import math

import pytest

from helixd.base.plan import ActionKind, MissionAction, NavStep, Program
from helixd.control.sequencer import Sequencer


def send(item: int) -> MissionAction:
    return MissionAction(item, 183, ActionKind.SEND, text=f"servo {item}")


def wait_time(item: int, s: float) -> MissionAction:
    return MissionAction(item, 112, ActionKind.WAIT_TIME, s)


def wait_distance(item: int, m: float) -> MissionAction:
    return MissionAction(item, 114, ActionKind.WAIT_DISTANCE, m)


def step(
    item: int,
    wp: int | None,
    hold_s: float = 0.0,
    actions: tuple[MissionAction, ...] = (),
    forever: bool = False,
) -> NavStep:
    return NavStep(item, 16, wp, wp, hold_s, actions, 0.5, f"step {item}", forever)


def test_a_moving_step_ends_when_its_waypoint_is_reached() -> None:
    seq = Sequencer(Program((step(1, 0), step(2, 1))))
    out = seq.start(0.0)
    assert not out.holding and out.step == 0
    assert seq.update(1.0, None, 5.0).step == 0
    assert seq.update(2.0, 1, 0.0).step == 0  # not its waypoint
    out = seq.update(3.0, 0, 0.2)
    assert out.step == 1 and not out.done
    out = seq.update(9.0, 1, 0.1)
    assert out.done and not out.holding


def test_a_hold_keeps_the_rover_stopped_for_its_time_then_goes_on() -> None:
    seq = Sequencer(Program((step(1, 0, hold_s=5.0), step(2, 1))))
    seq.start(0.0)
    out = seq.update(10.0, 0, 0.0)
    assert out.holding and any(e.kind == "hold_started" for e in out.events)
    assert seq.update(14.9, None, 0.0).holding
    out = seq.update(15.0, None, 0.0)  # whole hold waited
    assert not out.holding and out.step == 1


def test_in_place_steps_hold_from_the_start() -> None:
    seq = Sequencer(Program((step(1, None, hold_s=3.0), step(2, None), step(3, 0))))
    out = seq.start(100.0)
    assert out.holding and out.step == 0
    out = seq.update(103.0, None, 0.0)
    assert not out.holding and out.step == 2  # the 0 s step completes at once


def test_do_items_run_in_order_and_a_delay_holds_the_rest() -> None:
    """CONDITION_DELAY is verified when strictly more time than its value has passed since it
    started (verify_wait_delay); the items after it then run."""
    actions = (send(2), wait_time(3, 2.0), send(4))
    seq = Sequencer(Program((step(1, 0), step(5, 1, actions=actions))))
    seq.start(0.0)
    out = seq.update(10.0, 0, 0.0)
    assert [a.item for a in out.actions] == [2]
    assert seq.update(12.0, None, 4.0).actions == ()  # exactly 2 s: not yet
    assert [a.item for a in seq.update(12.1, None, 4.0).actions] == [4]


def test_a_distance_condition_waits_until_close_enough() -> None:
    actions = (wait_distance(3, 2.0), send(4))
    seq = Sequencer(Program((step(1, 0), step(5, 1, actions=actions))))
    seq.start(0.0)
    seq.update(1.0, 0, 10.0)
    assert seq.update(2.0, None, 2.0).actions == ()  # verify_within_distance: strictly less
    assert [a.item for a in seq.update(3.0, None, 1.9).actions] == [4]


def test_items_still_waiting_when_the_step_ends_are_dropped() -> None:
    actions = (wait_time(3, 60.0), send(4))
    seq = Sequencer(Program((step(1, 0, actions=actions), step(5, 1))))
    seq.start(0.0)
    out = seq.update(5.0, 0, 0.0)
    assert out.step == 1
    dropped = [e for e in out.events if e.kind == "item_dropped"]
    assert [e.item for e in dropped] == [3, 4]
    assert all(a.item != 4 for a in out.actions)


def test_final_actions_run_when_the_last_step_completes() -> None:
    seq = Sequencer(Program((step(1, 0),), final_actions=(send(2),)))
    seq.start(0.0)
    out = seq.update(1.0, 0, 0.0)
    assert out.done and [a.item for a in out.actions] == [2]


def test_a_loiter_without_end_never_completes() -> None:
    seq = Sequencer(Program((step(1, 0, forever=True),)))
    seq.start(0.0)
    assert seq.update(1.0, 0, 0.0).holding
    out = seq.update(1e6, None, 0.0)
    assert out.holding and not out.done


def test_an_operators_continue_ends_a_loiter_without_end() -> None:
    seq = Sequencer(Program((step(1, 0), step(2, 1, forever=True), step(3, 2))))
    seq.start(0.0)
    assert not seq.release_hold()  # not at the loiter: nothing to continue
    seq.update(1.0, 0, 0.0)
    assert seq.update(2.0, 1, 0.0).holding and seq.holding_forever
    assert seq.update(1e6, None, 0.0).holding  # still there
    assert seq.release_hold()
    out = seq.update(1e6 + 0.1, None, 0.0)
    assert not out.holding and not seq.holding_forever and out.step == 2
    assert not seq.release_hold()


def test_skipped_items_are_reported_when_their_step_starts() -> None:
    s = NavStep(3, 16, 0, 0, 0.0, (), 0.5, "step 3", skipped=("item 2 NAV_TAKEOFF: skipped",))
    seq = Sequencer(Program((s,)))
    out = seq.start(0.0)
    assert [e.kind for e in out.events] == ["item_skipped", "step_started"]


def test_time_must_be_finite() -> None:
    seq = Sequencer(Program((step(1, 0),)))
    with pytest.raises(ValueError):
        seq.start(math.nan)
    seq.start(0.0)
    with pytest.raises(ValueError):
        seq.update(math.inf, None, 0.0)
