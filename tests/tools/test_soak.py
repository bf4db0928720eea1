"""The soak (tools/soak.py): seeded crew days of ``helixd serve`` on the simulated clock, the
rules checked from the simulator's truth. Short days here; ``make soak`` runs the long ones.

Every verdict is in simulated time: a slower machine takes longer, never decides otherwise.
"""

from __future__ import annotations

import asyncio
import json
import tracemalloc
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.sim.snapshot import History, HistoryEntry
from tests.support import soak_day
from tests.support.soak_day import (
    HEARTBEAT_LIMIT_S,
    RSS_SLACK_MB,
    STOP_LIMIT_S,
    Crew,
    Rules,
    nav_successors,
    run_day,
)
from tests.support.soak_plan import CREW_ACTIONS, FAULT_KINDS, DayPlan, Item, Step, plan_day
from tests.support.soak_resume import KILL_TOLD_WITHIN_S, KillsTold, ResumeRule, navs_from
from tests.support.tools import load_tool

soak = load_tool("soak")

SHORT_DAY_H = 0.011  # 40 simulated seconds of presses and faults, then the evening
WP = mavlink.MAV_CMD_NAV_WAYPOINT


@pytest.mark.timeout(900)
def test_twenty_short_days_break_no_rule(tmp_path: Path) -> None:
    results = [soak.one_day(seed, SHORT_DAY_H) for seed in range(1, 21)]
    broken = [(r.seed, r.violation) for r in results if r.violation is not None]
    assert not broken, "\n".join(f"seed {s}: {v}" for s, v in broken)
    sec = soak.section(results, 0.0, SHORT_DAY_H)
    assert sec["days"] == 20 and sec["violations"] == []
    # the crew pressed most buttons and the faults came: the days did something
    assert sum(sec["actions"].values()) >= 150, sec["actions"]
    assert sum(1 for n in sec["actions"].values() if n > 0) >= len(CREW_ACTIONS) - 2
    assert sum(sec["faults"].values()) >= 10, sec["faults"]
    path = soak.write_section("soak", sec, tmp_path)
    written = json.loads(path.read_text())["soak"]
    assert written["days"] == 20 and set(written["faults"]) == set(FAULT_KINDS)


def test_a_day_is_drawn_from_its_seed_alone() -> None:
    assert plan_day(7, 7200.0) == plan_day(7, 7200.0)
    assert plan_day(7, 7200.0) != plan_day(8, 7200.0)


def test_long_days_press_every_button_and_inject_every_fault() -> None:
    plans = [plan_day(seed, 7200.0) for seed in range(1, 41)]
    pressed = {s.name for p in plans for s in p.steps if s.kind == "crew"}
    injected = {s.name for p in plans for s in p.steps if s.kind == "fault"}
    assert pressed == set(CREW_ACTIONS) and injected == set(FAULT_KINDS)
    # mostly idle with bursts: the last step well before the day's end is no rule, but the
    # steps are seconds apart inside a session and minutes apart between them
    gaps = [b.at_s - a.at_s for p in plans for a, b in zip(p.steps, p.steps[1:], strict=False)]
    assert min(gaps) >= 2.0 and max(gaps) >= 300.0


def test_a_thousand_days_press_every_button_and_inject_every_fault_a_hundred_times() -> None:
    # the coverage goal, from the plans alone (a day performs every step it plans
    # unless a rule stops it): a hundred two-hour days give each kind at least ten
    counts: dict[str, int] = dict.fromkeys((*CREW_ACTIONS, *FAULT_KINDS), 0)
    for seed in range(1, 101):
        for step in plan_day(seed, 7200.0).steps:
            counts[step.name] += 1
    rare = {name: n for name, n in counts.items() if n < 10}
    assert not rare, rare
    assert min(counts.values()) * 10 >= 1000, min(counts.items(), key=lambda kv: kv[1])


def test_the_items_may_follow_the_mission_and_its_jumps() -> None:
    items = (
        Item(WP), Item(WP, 5, 0), Item(WP, 5, 5),
        Item(mavlink.MAV_CMD_DO_CHANGE_SPEED, params=(1.0, 0.5)),
        Item(mavlink.MAV_CMD_DO_JUMP, params=(1.0, 2.0)), Item(WP, 0, 5),
    )  # fmt: skip
    assert nav_successors(items) == {0: {1}, 1: {2}, 2: {1, 5}, 5: set()}


def straight_day(seed: int) -> DayPlan:
    """Start a 30 m leg, press Pause (HOLD) while it drives."""
    mission = (Item(WP), Item(WP, 30.0, 0.0))
    steps = (
        Step(0, 6.0, "crew", "upload", (("items", 0),)),
        Step(1, 10.0, "crew", "speed_helixd", (("speed_mps", 0.5),)),
        Step(2, 12.0, "crew", "start"),
        Step(3, 20.0, "crew", "pause"),
    )
    return DayPlan(seed, 40.0, steps, (mission,), switch=False)


@pytest.mark.timeout(600)
def test_the_referee_sees_a_pause_not_obeyed_and_shrinks_to_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    plan = straight_day(5)
    assert run_day(plan, tmp_path / "obeyed").violation is None

    obeying = Crew.mode

    async def deaf(self: Crew, name: str) -> None:  # QGC's Pause lost on the way
        if name != "HOLD":
            await obeying(self, name)

    monkeypatch.setattr(Crew, "mode", deaf)
    failed = run_day(plan, tmp_path / "lost")
    assert failed.violation is not None and failed.violation.rule == "driven_after_stop"
    assert failed.violation.at_s == pytest.approx(20.5, abs=0.1)  # the limit, on the dot
    small = soak.shrink(plan, failed, budget=8)
    names = [s.name for s in small.steps]
    assert "pause" in names and "speed_helixd" not in names and len(names) <= 3, names


def card_day(seed: int) -> DayPlan:
    """A 30 m leg started; the card full for 6 s while it drives (flight.csv written)."""
    mission = (Item(WP), Item(WP, 30.0, 0.0))
    steps = (
        Step(0, 6.0, "crew", "upload", (("items", 0),)),
        Step(1, 10.0, "crew", "start"),
        Step(2, 16.0, "fault", "full_card", (("duration_s", 6.0),)),
    )
    return DayPlan(seed, 40.0, steps, (mission,), switch=False)


@pytest.mark.timeout(600)
def test_a_full_card_mid_flight_is_told_once_and_the_day_goes_on(tmp_path: Path) -> None:
    got = run_day(card_day(9), tmp_path)
    assert got.violation is None, got.violation
    assert got.faults == {"full_card": 1}
    log = (tmp_path / "serve.log").read_text()
    assert log.count("event=record_cut ") == 1
    runs = [p for p in (tmp_path / "runs").iterdir() if p.is_dir()]
    summary = json.loads((runs[0] / "summary.json").read_text())
    assert summary["record_cut_files"] == ["flight.csv"]
    # memory measured at midday and at the end, within the rule's slack
    assert got.rss_mb[0] > 0.0 and got.rss_mb[1] <= got.rss_mb[0] + RSS_SLACK_MB


def full_history_mb(entries: int) -> float:
    """What a simulator history of ``entries`` keeps once full of the entries a driving day
    logs most (a scroll output's change: time, channel, pulse)."""
    tracemalloc.start()
    try:
        history = History(entries)
        for i in range(entries + 10):
            t = 0.02 * i + 0.001
            history.append(
                HistoryEntry(t, t, "output", {"channel": 1 + i % 2, "pwm_us": 1100 + i % 800})
            )
        return tracemalloc.get_traced_memory()[0] / 1e6
    finally:
        tracemalloc.stop()


@pytest.mark.timeout(600)
def test_the_days_simulator_keeps_no_record_that_grows_with_the_day(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # seed 101: the simulator's history of a 2 h day grew by 120 000 output entries (40 MB)
    # over its second hour, beyond the memory rule's slack; the soak reads none of it
    served: list[Any] = []
    serve = soak_day.simulated_serve

    def keep(*args: Any, **kwargs: Any) -> Any:
        served.append(serve(*args, **kwargs))
        return served[-1]

    monkeypatch.setattr(soak_day, "simulated_serve", keep)
    got = run_day(card_day(9), tmp_path)
    assert got.violation is None, got.violation
    server = served[0].server
    cap = server.config.history_max_entries
    assert len(server.history) <= cap
    # however long the day, what the simulator keeps of it is a sliver of the rule's slack
    assert full_history_mb(cap) < RSS_SLACK_MB / 20


def referee() -> Rules:
    """A referee fed no snapshot: its bookkeeping of the crew's words and the faults."""
    return Rules(SimpleNamespace(console=SimpleNamespace(lines=[])))  # type: ignore[arg-type]


# The referee's own mistakes the first soaks found (each a failing seed of its day, none a
# helixd fault): pinned here without flying the day again.


def test_manual_picked_in_manual_is_no_word() -> None:
    # seed 4: a flight the switch started drives in MANUAL; QGC's MANUAL changes nothing
    rules = referee()
    rules.word("manual", "MANUAL")
    rules.word("radio_mode", "MANUAL", "MANUAL")
    assert rules.stop_at is None
    rules.word("radio_mode", "MANUAL", "HOLD")
    assert rules.stop_at is not None and rules.stop_limit_s == HEARTBEAT_LIMIT_S


def test_arming_in_a_driving_mode_is_a_go_word() -> None:
    # seed 27: disarmed in AUTO, armed again: ArduPilot (and helixd) drive the mission
    rules = referee()
    rules.word("disarm", "AUTO")
    assert rules.stop_at is not None
    rules.word("arm", "HOLD")
    assert rules.stop_at is not None
    rules.word("arm", "AUTO")
    assert rules.stop_at is None


def test_a_stop_in_auto_is_seen_at_once_elsewhere_in_the_heartbeat() -> None:
    # seeds 6 and 7: HOLD during a flight helixd drives in MANUAL shows in the 1 Hz HEARTBEAT
    rules = referee()
    rules.word("pause", "AUTO")
    assert rules.stop_limit_s == STOP_LIMIT_S
    rules = referee()
    rules.word("pause", "MANUAL")
    assert rules.stop_limit_s == HEARTBEAT_LIMIT_S


def test_a_second_battery_failsafe_is_no_news_until_a_reboot() -> None:
    # seed 19: ArduPilot's battery failsafe acts once
    rules = referee()
    rules.fault("battery_low", True, {})
    rules.fault("battery_low", True, {})
    assert [k for k, _, _ in rules.pending] == ["battery_low"]
    rules.fault("reboot", False, {})
    rules.fault("battery_low", True, {})
    assert [k for k, _, _ in rules.pending] == ["battery_low", "battery_low"]


def test_a_receiver_that_only_stops_is_not_a_fault_helixd_can_see() -> None:
    # seed 7: README "Safety": invisible while helixd overrides
    rules = referee()
    rules.fault("rc_loss", True, {"kind": "no_pulses"})
    assert rules.fault_at is None and not rules.pending
    rules.fault("rc_loss", True, {"kind": "failsafe_values"})
    assert rules.fault_at is not None


def test_a_full_card_told_twice_or_never_breaks_its_rule() -> None:
    lines: list[str] = []
    rules = Rules(SimpleNamespace(console=SimpleNamespace(lines=lines)))  # type: ignore[arg-type]
    lines += ["ts=1 level=info event=serve_state state=flying hx_state=3",
              "ts=1 level=info event=helixd_start mission=m run_dir=/r/a"]  # fmt: skip
    rules._lines(0.0)
    rules.full_card(5.0)  # never told
    rules._lines(now_s() + 10.0)
    assert rules.broken is not None and rules.broken.rule == "card_full_reported"
    rules = Rules(SimpleNamespace(console=SimpleNamespace(lines=lines)))  # type: ignore[arg-type]
    lines += ['ts=2 level=warning event=record_cut path=/r/a/flight.csv note="x y"'] * 2
    rules._lines(0.0)
    assert rules.broken is not None and rules.broken.rule == "card_full_once"


# Seeds whose day broke a rule in helixd (fixed since), flown again up to just past the step
# that broke it: (seed, day hours, seconds into the day).
FOUND = [
    # a fence breach in a flight of AUTO taken for the crew's Pause (helixd/runtime/flight.py,
    # _autopilot_failsafe; tests/integration/test_serve_autopilot_failsafe.py)
    (201, 0.1, 75.0),
    # a continue after a kill of a flight of AUTO, with the crew's set current to the next
    # item made before it, flew the previous item again (helixd/prepare/builder.py
    # continue_commands: the autopilot's own step; tests/prepare/test_builder.py)
    (23, 0.25, 885.0),
]


@pytest.mark.timeout(600)
@pytest.mark.parametrize(("seed", "hours", "until_s"), FOUND)
def test_the_seeds_that_found_a_fault_break_no_rule_again(
    tmp_path: Path, seed: int, hours: float, until_s: float
) -> None:
    plan = plan_day(seed, hours * 3600.0)
    cut = replace(plan, steps=tuple(s for s in plan.steps if s.at_s < until_s), length_s=until_s)
    assert any(s.kind == "fault" for s in cut.steps)
    got = run_day(cut, tmp_path)
    assert got.violation is None, got.violation


def test_the_soak_section_renders_beside_the_benchmarks(tmp_path: Path) -> None:
    sec = {"days": 2, "simulated_hours": 0.2, "wall_s": 5.0, "cpu_s": 4.0,
           "violations": [{"seed": 3, "rule": "item_order"}],
           "actions": {"pause": 4}, "faults": {"stall": 1}}  # fmt: skip
    soak.write_section("soak", sec, tmp_path)
    soak.write_section("planning", {"cases": {}}, tmp_path)  # another bench keeps it
    md = (tmp_path / "latest.md").read_text()
    assert "## Soak" in md and "seed 3: item_order" in md and "| pause | 4 |" in md
    assert json.loads((tmp_path / "latest.json").read_text())["soak"]["days"] == 2


def test_pause_in_hold_is_no_word() -> None:
    # seed 423: QGC's Pause while helixd's own fall-back HOLD holds changes nothing helixd
    # can see (the next flight it was preparing set MANUAL and drove)
    rules = referee()
    rules.word("pause", "HOLD")
    assert rules.stop_at is None


def test_a_fault_too_short_to_see_or_overlapped_by_another_is_not_judged() -> None:
    # seed 400: a 2.5 s stall (helixd needs 4 s to see one), then a reboot named link_lost
    rules = referee()
    rules.fault("stall", True, {"duration_s": 2.5})
    assert rules.fault_at is None and not rules.pending
    rules.fault("stall", True, {"duration_s": 8.0})
    rules.fault("reboot", True, {})
    assert [k for k, _, _ in rules.pending] == ["stall", "reboot"]
    rules._named("stall", *rules.pending[0][1:])  # the reboot came within the stall's window
    assert rules.broken is None


def test_a_disarm_of_a_disarmed_rover_is_no_word() -> None:
    # seed 619: pressed while helixd's flight was still in its preflight, the rover disarmed
    rules = referee()
    rules.word("disarm", "AUTO", armed=False)
    assert rules.stop_at is None


def test_a_go_word_ends_a_faults_window() -> None:
    # seed 623: a stall named, then the crew's RTL: the new flight met the stall again
    rules = referee()
    rules.fault("stall", True, {"duration_s": 12.6})
    rules.word("rtl", "HOLD")
    ((kind, at, by),) = rules.pending
    rules.st.console.lines.extend(["event=fallback cause=stall", "event=fallback cause=stall"])
    rules.log_times.extend([at + 0.1 * (rules.go_times[0] - at), by])
    rules._named(kind, at, by)
    assert rules.broken is None


def test_a_stop_word_lets_helixd_show_the_item_it_stopped_at() -> None:
    # seed 604: a flight helixd drives in MANUAL shows the interrupted item when paused
    rules = referee()
    assert rules.free_until < now_s()
    rules.word("pause", "MANUAL")
    assert rules.free_until > now_s()


def test_helixd_showing_its_own_item_after_the_crews_set_current_in_manual_is_in_order() -> None:
    # seed 102: a flight the start switch started (MANUAL) shows item 1; the crew sets 4, then
    # 7 (the last); helixd flies its own walk and shows its next item, 3: no skip, no repeat
    lines: list[str] = []
    rules = Rules(SimpleNamespace(console=SimpleNamespace(lines=lines)))  # type: ignore[arg-type]
    speed = Item(mavlink.MAV_CMD_DO_CHANGE_SPEED, params=(1.0, 0.9))
    rules.mission((Item(WP), Item(WP, 5, 0), speed, *(Item(WP, 5, 5 * k) for k in range(1, 6))))
    rules.free_until = 0.0
    lines += ["ts=1 level=info event=serve_state state=flying hx_state=4",
              "ts=1 level=info event=mission_current_set seq=1"]  # fmt: skip
    later = now_s() + 10.0

    def shows(seq: int, t: float = later) -> None:  # the crew's moves: at once
        rules._lines(t)
        rules._items(t, SimpleNamespace(mission_current_seq=seq, mode="MANUAL"))  # type: ignore[arg-type]

    shows(1)
    rules.word("set_current", "MANUAL")
    shows(4, now_s())
    rules.word("set_current", "MANUAL")
    shows(7, now_s())
    lines.append("ts=2 level=info event=mission_current_set seq=3")
    shows(3)
    assert rules.broken is None, rules.broken
    shows(5)  # helixd's own display skipping an item breaks the rule as before
    assert rules.broken is not None and rules.broken.rule == "item_order"


def test_the_item_moving_back_with_nobody_setting_it_breaks_the_rule() -> None:
    rules = referee()
    rules.mission((Item(WP), Item(WP, 5, 0), Item(WP, 5, 5), Item(WP, 0, 5)))
    rules.free_until = 0.0
    later = now_s() + 10.0
    for seq in (1, 3, 2):  # in MANUAL too: no crew's set current to take back
        rules._items(later, SimpleNamespace(mission_current_seq=seq, mode="MANUAL"))  # type: ignore[arg-type]
    assert rules.broken is not None and rules.broken.rule == "item_order"


def test_the_radio_mode_switch_put_where_it_stands_is_no_word() -> None:
    # seed 102: the switch to HOLD, then modes from QGC, then to HOLD again: ArduPilot reads
    # a move of the switch only (RC_Channel::read_mode_switch), the mode stays MANUAL
    rules = referee()
    rules.word("radio_mode", "MANUAL", "HOLD")
    assert rules.stop_at is not None
    rules.word("continue", "HOLD")
    assert rules.stop_at is None
    rules.word("radio_mode", "MANUAL", "HOLD")
    assert rules.stop_at is None
    rules.word("radio_mode", "MANUAL", "MANUAL")
    rules.word("radio_mode", "MANUAL", "HOLD")
    assert rules.stop_at is not None


def kill_day(seed: int) -> DayPlan:
    """Three waypoints started through helixd (driven in MANUAL, its item shown as the
    autopilot's current); helixd killed on the way; the crew's continue after the restart."""
    mission = (Item(WP), Item(WP, 12.0, 0.0), Item(WP, 12.0, 12.0), Item(WP, 0.0, 12.0))
    steps = (
        Step(0, 6.0, "crew", "upload", (("items", 0),)),
        Step(1, 10.0, "crew", "start_helixd"),
        Step(2, 40.0, "fault", "kill"),
        Step(3, 60.0, "crew", "continue_helixd"),
    )
    return DayPlan(seed, 120.0, steps, (mission,), switch=False)


@pytest.mark.timeout(600)
def test_a_kill_mid_flight_is_told_once_and_the_continue_goes_on_from_its_item(
    tmp_path: Path,
) -> None:
    got = run_day(kill_day(11), tmp_path)
    assert got.violation is None, got.violation
    assert got.faults == {"kill": 1}
    log = (tmp_path / "serve.log").read_text()
    assert log.count("event=serve_flight_cut ") == 1
    assert log.count("event=serve_start ") == 2
    runs = sorted(p for p in (tmp_path / "runs").iterdir() if p.is_dir())
    cut = json.loads((runs[0] / "summary.json").read_text())
    assert cut["fault"].startswith("killed:"), cut
    resumed = json.loads((runs[1] / "summary.json").read_text())
    assert resumed["resumed_from"]["path"] == str(runs[0].resolve())
    assert resumed["completed"] is True, resumed


def test_a_continue_driving_another_item_than_the_interrupted_one_breaks_its_rule() -> None:
    rule = ResumeRule()
    rule.interrupted(True, 3)
    rule.word("continue_helixd", 10.0)
    assert rule.driven(10.5, 3, False, {}) is None  # not driving yet
    assert rule.driven(11.0, 2, True, {}) is not None  # drove with item 2 current
    rule.interrupted(True, 3)
    rule.word("set_current", 12.0)  # the crew moved it: nothing to judge
    rule.word("continue", 13.0)
    assert rule.driven(14.0, 2, True, {}) is None
    rule.interrupted(True, 4)
    rule.word("disarm", 15.0)  # the autopilot restarts its mission: AUTO not judged
    rule.word("continue", 16.0)
    assert rule.driven(17.0, 1, True, {}) is None
    rule.word("continue_helixd", 18.0)  # helixd's own continue still is (its state file)
    assert rule.driven(19.0, 4, True, {}) is None
    rule.interrupted(False, 2)  # nothing flying: nothing interrupted
    rule.word("continue_helixd", 20.0)
    assert rule.driven(21.0, 1, True, {}) is None
    # seed 15: the autopilot's mission completed (item 5 within its WP_RADIUS) as the crew
    # paused; AUTO again starts it from item 1, as ArduPilot does
    rule.interrupted(True, 5)
    rule.autopilot_done()
    rule.word("continue", 25.0)
    assert rule.driven(25.5, 1, True, {}) is None
    rule.autopilot_done()  # completed before the crew's pause: the same
    rule.interrupted(True, 5)
    rule.word("continue", 26.0)
    assert rule.driven(26.5, 1, True, {}) is None
    # seed 104: AUTO again within item 1's radius moves on to item 3 before it drives
    successors = {1: {3}, 3: {4}, 4: set()}
    rule.interrupted(True, 1)
    rule.word("continue", 30.0)
    assert rule.driven(30.2, 3, False, successors) is None
    assert rule.driven(30.4, 3, True, successors) is None
    rule.interrupted(True, 1)  # helixd's own continue: the item it flies first, strictly
    rule.word("continue_helixd", 40.0)
    assert rule.driven(40.2, 3, False, successors) is None
    assert rule.driven(40.4, 3, True, successors) is not None


def test_a_kill_is_told_once_when_it_cut_a_flight_and_never_else() -> None:
    told = "ts=… level=warning event=serve_flight_cut run_dir=/r closed=true"
    kills = KillsTold()
    kills.kill(100.0, 0, True)
    assert kills.due(101.0, []) is None  # not yet judged
    assert kills.due(100.0 + KILL_TOLD_WITHIN_S + 0.1, ["x"]) is not None  # never told
    kills.kill(200.0, 1, True)
    assert kills.due(200.0 + KILL_TOLD_WITHIN_S + 0.1, ["x", told]) is None
    kills.kill(300.0, 0, False)  # an idle service killed: nothing to tell
    assert kills.due(300.0 + KILL_TOLD_WITHIN_S + 0.1, [told]) is not None


def test_a_flight_to_a_place_or_of_a_plan_uploaded_over_interrupts_no_mission_item() -> None:
    # seed 24: an AUTO flight of the old plan handed over to GUIDED after an upload, a fault
    # in the flight to the place, then the continue flew the new plan from item 1: right
    rules = referee()
    rules.serve_state, rules.flight_request, rules.flight_at = "flying", "auto", now_s()
    rules.last_seq = 4
    assert rules.mission_flying()
    rules.mission((Item(WP), Item(WP, 5.0, 0.0)))  # the crew's upload during it
    assert not rules.mission_flying()
    rules.word("goto", "AUTO")
    assert rules.resume.item is None
    rules.flight_request, rules.flight_at = "goto", now_s() + 1.0
    assert not rules.mission_flying()  # a fault now interrupts no mission item


def test_a_stall_of_a_rover_creeping_onto_a_waypoint_is_not_judged() -> None:
    # seed 100: a 5.8 s stall 0.09 m from a waypoint, helixd commanding less than its stall
    # watch's 0.2 m/s; the rover drove on once it was over
    rules = referee()
    snap = SimpleNamespace(speed_mps=0.0, scroll_pwm_us=(1530, 1530, 1470, 1470))
    st = SimpleNamespace(snapshot=lambda: snap, inject=lambda *_, **__: None)
    crew = Crew(st, None, rules, kill_day(1))  # type: ignore[arg-type]
    asyncio.run(crew.perform(Step(0, 1.0, "fault", "stall", (("duration_s", 5.8),))))
    assert rules.pending == [] and rules.fault_at is None
    snap.speed_mps = 0.5  # moving: judged
    asyncio.run(crew.perform(Step(1, 2.0, "fault", "stall", (("duration_s", 5.8),))))
    assert [kind for kind, _, _ in rules.pending] == ["stall"]


def test_an_interrupted_do_item_is_continued_at_the_waypoint_after_it() -> None:
    # seed 10's hour: the autopilot's current item was DO_CHANGE_SPEED item 4; helixd's
    # continue ran it again and drove to item 5, showing 5
    items = (
        Item(WP), Item(WP, 2.0, 2.0), Item(mavlink.MAV_CMD_DO_CHANGE_SPEED, params=(1.0, 0.3)),
        Item(WP, 5.0, 5.0), Item(mavlink.MAV_CMD_DO_JUMP, params=(1.0, 1.0)),
    )  # fmt: skip
    assert navs_from(items, 2) == {3} and navs_from(items, 3) == {3}
    assert navs_from(items, 4) == {1}
    rule = ResumeRule()
    rule.interrupted(True, 2, navs_from(items, 2))
    rule.word("start_helixd", 1.0)
    assert rule.driven(2.0, 3, True, {}) is None


def test_a_flight_goes_on_with_its_own_plans_jumps_after_an_upload() -> None:
    # seed 282: the crew uploaded another plan while a flight flew; its DO_JUMP took the item
    # from 9 back to 2 as its own plan says, until it ended
    rules = referee()
    jump = Item(mavlink.MAV_CMD_DO_JUMP, params=(2.0, 2.0))
    rules.mission((Item(WP), Item(WP, 5, 0), Item(WP, 5, 5), Item(WP, 0, 5), Item(WP, 1, 5), jump))
    rules.serve_state = "flying"
    new = (Item(WP), Item(WP, 1, 1), Item(WP, 2, 2), Item(WP, 3, 3))
    rules.mission(new)  # uploaded during the flight
    rules.free_until = 0.0
    later = now_s() + 10.0
    for seq in (2, 3, 4, 2):  # 4 → 2: the old plan's jump
        rules._items(later, SimpleNamespace(mission_current_seq=seq, mode="MANUAL"))  # type: ignore[arg-type]
    assert rules.broken is None, rules.broken
    rules.st.console.lines.append("level=info event=serve_flight_start request=start")
    rules._lines(later)  # a new flight: the new plan's order only
    for seq in (3, 2):  # 3 → 2: back, with nobody setting it
        rules._items(later, SimpleNamespace(mission_current_seq=seq, mode="MANUAL"))  # type: ignore[arg-type]
    assert rules.broken is not None and rules.broken.rule == "item_order"


def test_a_waypoint_reached_as_the_flight_stops_moves_the_interrupted_item() -> None:
    # seed 312: the crew's HOLD, waypoint 1 reached 0.02 s later before helixd saw the mode;
    # helixd showed item 2 and its continue went on from there: right
    rule = ResumeRule()
    rule.interrupted(True, 1, frozenset(), 100.0)
    assert rule.driven(100.3, 2, False, {}) is None  # helixd shows item 2 as it stops
    assert rule.driven(103.0, 1, False, {}) is None  # later moves are not the flight's
    rule.word("start_helixd", 110.0)
    assert rule.driven(111.0, 2, True, {}) is None


def test_a_fault_helixd_cannot_see_interrupts_no_item() -> None:
    # seed 4001: a receiver's silence (no pulses) while helixd flew item 1; it flew on,
    # reached item 1 and showed 2, then the crew's AUTO: not a continue of item 1
    rules = referee()
    rules.serve_state, rules.flight_request, rules.flight_at = "flying", "start", now_s()
    rules.last_seq = 1
    rules.fault("rc_loss", True, {"kind": "no_pulses", "duration_s": 16.7})
    assert rules.resume.item is None
    rules.fault("stall", True, {"duration_s": 2.5})  # over before the stall watch may see it
    assert rules.resume.item is None
    rules.fault("rc_loss", True, {"kind": "failsafe_values", "duration_s": 16.7})
    assert rules.resume.item == 1  # one helixd sees interrupts the flight at its item


def test_an_item_the_autopilot_counts_reached_at_the_stop_may_be_flown_again() -> None:
    # seed 4002: a flight of AUTO disarmed 1.9 m from item 4, the autopilot's WP_RADIUS
    # counted it reached and showed 5 at once; helixd's radius had not: its continue went
    # on from 4. Either item is the interrupted one; an item further back is not.
    rule = ResumeRule()
    rule.interrupted(True, 4, frozenset(), 100.0)
    assert rule.driven(100.01, 5, False, {}) is None  # the autopilot's own reach
    rule.word("start_helixd", 150.0)
    assert rule.driven(151.0, 4, True, {}) is None
    rule = ResumeRule()
    rule.interrupted(True, 4, frozenset(), 100.0)
    assert rule.driven(100.01, 5, False, {}) is None
    rule.word("start_helixd", 150.0)
    assert rule.driven(151.0, 5, True, {}) is None  # the autopilot's item: right too
    rule = ResumeRule()
    rule.interrupted(True, 4, frozenset(), 100.0)
    assert rule.driven(100.01, 5, False, {}) is None
    rule.word("start_helixd", 150.0)
    assert rule.driven(151.0, 3, True, {}) is not None  # further back: broken
