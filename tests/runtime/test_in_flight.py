"""The flight loop's callbacks, turned into what the crew and the record see: an arrival into
the summary, the ground station's "reached" and the host's next item; the autopilot's mode
into a pause told once; a lost radio told once; plan indices into mission indices past the
media map's stops. Real collaborators (the GCS feed on a clock of its own, the summary, the
display off a terminal, serve's host); the autopilot is its vehicle state alone."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace
from typing import Any, cast

from helixd.base.plan import Numbering, Plan
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.vehicle import VehicleState
from helixd.mission.model import Mission
from helixd.mission.resolve import resolve_plan
from helixd.recorder.summary import SummaryBuilder
from helixd.report.display import ProgressDisplay
from helixd.report.gcs_feed import GcsFeed
from helixd.runtime.host import ServeHost
from helixd.runtime.in_flight import InFlight
from helixd.runtime.mode_gate import Gate
from helixd.runtime.signals import StopRequest

CFG = HelixdConfig()


def plan_of(n: int) -> Plan:
    wps = [{"x": 10.0 * (k + 1), "y": 0.0} for k in range(n)]
    mission = Mission.model_validate(
        {"name": "t", "mode": "roll", "frame": "start", "waypoints": wps}
    )
    return resolve_plan(mission, CFG.control, CFG.mission, None)


class Seen:
    """What the flight told the crew: the GCS texts, the host's items and pauses."""

    def __init__(self) -> None:
        self.sent: list[Any] = []
        self.items: list[int] = []
        self.pauses: list[tuple[bool, str]] = []
        self.now_s = 100.0  # the GCS feed's clock

    def texts(self, gcs: GcsFeed) -> list[str]:
        gcs.pump()
        return [str(m.text) for m in self.sent if m.get_type() == "STATUSTEXT"]


def in_flight(plan: Plan, cfg: HelixdConfig = CFG) -> tuple[InFlight, Seen, VehicleState]:
    seen, state = Seen(), VehicleState()
    ap = cast(Autopilot, SimpleNamespace(state=state, feed=lambda: None))
    host = ServeHost(
        ap,
        StopRequest(),
        set_item=seen.items.append,
        on_pause=lambda held, mode: seen.pauses.append((held, mode)),
    )
    gcs = GcsFeed(cfg.gcs_report, lambda: seen.now_s)
    gcs.start_sync(lambda m: seen.sent.append(m) or True)
    vias = [w.via for w in plan.waypoints]
    flight = InFlight(
        cfg,
        plan,
        Numbering.of(vias),
        ap,
        host,
        gcs,
        ProgressDisplay(False),
        SummaryBuilder("t", "roll", len(plan.waypoints)),
        None,
    )
    return flight, seen, state


def test_an_arrival_is_summarised_told_and_moves_the_host_to_the_next_item() -> None:
    flight, seen, _ = in_flight(plan_of(3))
    flight.on_arrival(0, 12.0, 0.3)
    flight.on_arrival(1, 20.0, 0.2)
    flight.on_arrival(2, 31.0, 0.1)
    assert flight.summary.waypoints_reached == 3
    assert seen.items == [2, 3]  # after 1/3 the host flies item 2, then 3; none after the last
    assert [t for t in seen.texts(flight.gcs) if "reached" in t] == [
        "helixd: reached WP 1/3",
        "helixd: reached WP 2/3",
        "helixd: reached WP 3/3",
    ]


def test_a_hold_pauses_the_host_and_tells_the_ground_station_where_it_goes_on() -> None:
    flight, seen, _ = in_flight(plan_of(2))
    flight.on_gate(Gate.HOLD, "HOLD")
    flight.on_gate(Gate.DRIVE, "MANUAL")
    flight.on_gate(Gate.RELEASE, "ACRO")
    assert seen.pauses == [(True, "HOLD"), (False, "MANUAL")]  # a release is no pause
    assert seen.texts(flight.gcs) == [  # a STATUSTEXT holds 50 characters: chunked
        "helixd: paused: mode HOLD, scrolls held at neutral",
        "helixd: until MANUAL",
        "helixd: continuing in MANUAL",
        "helixd: released: mode ACRO, the pilot drives",
    ]


def test_a_lost_radio_is_told_once_per_loss_when_helixd_drives_on() -> None:
    cfg = CFG.model_copy(
        update={"safety": CFG.safety.model_copy(update={"stop_on_rc_loss": False})}
    )
    flight, seen, state = in_flight(plan_of(1), cfg)
    state.rc_receiver_healthy = False
    flight.tell_radio_lost()
    flight.tell_radio_lost()
    state.rc_receiver_healthy = True
    flight.tell_radio_lost()
    seen.now_s += cfg.gcs_report.repeat_window_s + 1.0  # the GCS feed would drop a repeat
    state.rc_receiver_healthy = False
    flight.tell_radio_lost()
    lost = [t for t in seen.texts(flight.gcs) if "radio lost" in t]
    assert lost == ["helixd: radio lost: driving on, no safety pilot"] * 2


def test_a_lost_radio_is_not_told_when_the_loss_stops_the_flight() -> None:
    flight, seen, state = in_flight(plan_of(1))
    assert CFG.safety.stop_on_rc_loss  # the default: the watchdog ends the flight instead
    state.rc_receiver_healthy = False
    flight.tell_radio_lost()
    assert not [t for t in seen.texts(flight.gcs) if "radio lost" in t]


def test_mission_indices_skip_the_media_maps_stops() -> None:
    plan = plan_of(3)
    wps = list(plan.waypoints)
    stop = replace(wps[1], media_stop=True)  # a stop the media map inserted before waypoint 2
    plan = replace(plan, waypoints=(wps[0], stop, *wps[1:]))
    flight, _, _ = in_flight(plan)
    assert flight.inserted_before == (0, 0, 1, 1)
    assert [flight.mission_index(i) for i in range(4)] == [0, None, 1, 2]
    assert flight.mission_index(7) == 7  # beyond the plan: as it came
