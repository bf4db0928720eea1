"""helixd.serve.status: the state word told in three places at once (systemd's status line,
a STATUSTEXT, NAMED_VALUE_INT hx_state), with fakes for the three."""

from __future__ import annotations

from typing import Any, cast

from helixd.base.clock import now_s
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.mav.constants import MAV_SEVERITY_ERROR, MAV_SEVERITY_NOTICE
from helixd.report.gcs_feed import GcsFeed
from helixd.report.notify import ServiceNotifier
from helixd.serve.core import ServeState
from helixd.serve.status import HX_STATE_NAME, ServeStatus


class _Seen:
    """systemd's status line, the ground station's pane and the link, as they were told."""

    def __init__(self) -> None:
        self.systemd: list[str] = []
        self.pane: list[tuple[str, int]] = []
        self.sent: list[Any] = []

    def status(self, text: str) -> bool:
        self.systemd.append(text)
        return True

    def say(self, text: str, severity: int) -> None:
        self.pane.append((text, severity))

    def send_message(self, msg: Any) -> None:
        self.sent.append(msg)

    def hx_states(self) -> list[int]:
        assert all(m.name == HX_STATE_NAME.decode() for m in self.sent)
        return [int(m.value) for m in self.sent]


def _status(rate_hz: float = 2.0) -> tuple[ServeStatus, _Seen]:
    seen = _Seen()
    cfg = HelixdConfig.model_validate({"serve": {"state_rate_hz": rate_hz}})
    status = ServeStatus(cfg, cast(ServiceNotifier, seen), cast(GcsFeed, seen))
    status.ap = cast(Autopilot, seen)
    return status, seen


def test_a_new_state_is_told_everywhere_once() -> None:
    status, seen = _status()
    status.set(ServeState.REFUSED, "too far", MAV_SEVERITY_ERROR)
    status.set(ServeState.REFUSED, "too far", MAV_SEVERITY_ERROR)  # no news: told once
    assert seen.systemd == ["refused: too far"]
    assert seen.pane == [("refused: too far", MAV_SEVERITY_ERROR)]
    assert seen.hx_states() == [ServeState.REFUSED]
    status.set(ServeState.READY)
    assert seen.pane[-1] == ("ready", MAV_SEVERITY_NOTICE)  # no severity: a notice
    assert (status.state, status.detail) == (ServeState.READY, "")


def test_a_quiet_state_is_not_said_to_the_ground_station_but_sent_as_hx_state() -> None:
    """Between two flights of one press of the crew (a handover): the next flight says
    where it goes; systemd and hx_state still follow."""
    status, seen = _status()
    status.set(ServeState.PAUSED, "1/2 waypoints", quiet=True)
    assert seen.pane == [] and seen.systemd == ["paused: 1/2 waypoints"]
    assert seen.hx_states() == [ServeState.PAUSED]


def test_a_held_flight_shows_paused_while_the_service_stays_flying() -> None:
    status, seen = _status()
    status.set(ServeState.FLYING, "start by system 255")
    status.hold(True, "mode HOLD")
    assert status.state is ServeState.FLYING and status.shown is ServeState.PAUSED
    assert seen.systemd[-1] == "paused: mode HOLD"
    status.hold(True, "mode HOLD")  # no change: nothing told again
    assert seen.hx_states() == [ServeState.FLYING, ServeState.PAUSED]
    status.hold(False)
    assert status.shown is ServeState.FLYING
    assert seen.systemd[-1] == "flying: start by system 255"
    assert seen.hx_states()[-1] == ServeState.FLYING
    assert len(seen.pane) == 1  # the flight tells the pane itself ("paused: mode HOLD, …")


def test_a_hold_outside_a_flight_changes_nothing_and_a_new_state_ends_it() -> None:
    status, seen = _status()
    status.set(ServeState.READY)
    status.hold(True, "mode HOLD")
    assert status.shown is ServeState.READY and seen.hx_states() == [ServeState.READY]
    status.set(ServeState.FLYING)
    status.hold(True, "mode HOLD")
    status.set(ServeState.FLYING)  # the same state, held: told again, no longer held
    assert status.shown is ServeState.FLYING and seen.hx_states()[-1] == ServeState.FLYING


def test_hx_state_is_due_again_one_period_after_it_was_sent() -> None:
    status, seen = _status(rate_hz=2.0)
    before_s = now_s()
    status.send()
    assert seen.hx_states() == [ServeState.CONNECTING]
    assert before_s + 0.5 <= status.next_send_s <= now_s() + 0.5
    assert not status.due(status.next_send_s - 0.01)
    assert status.due(status.next_send_s)


def test_without_a_link_nothing_is_sent() -> None:
    status, seen = _status()
    status.ap = None
    status.set(ServeState.CONNECTING, "link: no route")
    assert seen.sent == [] and seen.systemd == ["connecting: link: no route"]
