"""helixd.serve.mission: when the service reads the mission again, and what a read leaves
(an autopilot whose mission protocol is a fake, or the mission file)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import Any, cast

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from helixd.base.clock import now_s
from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.link.connection import Autopilot
from helixd.link.services.mission_transfer import MissionTransferError
from helixd.serve.core import ServeState
from helixd.serve.mission import FLIGHT_PLAN_RECEIVED, MISSION_RETRY_S, MissionWatch
from helixd.serve.options import ServeOptions
from tests.serve.test_check import downloaded, waypoints_file

_mav = mavlink.MAVLink(None)
CFG = HelixdConfig.model_validate(
    {"mission": {"ground_station_mode": "roll"}, "serve": {"mission_poll_s": 30.0}}
)


class _Missions:
    """The autopilot's mission protocol: each download returns the next of ``downloads``
    (an exception is raised)."""

    def __init__(self, *downloads: Any) -> None:
        self.downloads = list(downloads)

    async def download(self) -> Any:
        got = self.downloads.pop(0)
        if isinstance(got, Exception):
            raise got
        return got


def _ap(*downloads: Any) -> Autopilot:
    return cast(Autopilot, SimpleNamespace(mission=_Missions(*downloads)))


def _watch(tmp_path: Path, mission_file: Path | None = None) -> MissionWatch:
    # a mission file is prepared from the config file (none here: the defaults) and --mode
    mode = MotionMode.ROLL if mission_file is not None else None
    return MissionWatch(ServeOptions(CFG, None, tmp_path, mode, mission_file=mission_file))


def test_a_new_count_or_a_finished_upload_makes_a_read_due(tmp_path: Path) -> None:
    watch = _watch(tmp_path)
    watch.due = False
    watch.on_message(_mav.mission_current_encode(2, 4), 0.0)
    assert watch.autopilot_item == 2 and not watch.due  # the first count, before any read
    watch.on_message(_mav.mission_current_encode(3, 4), 0.0)
    assert watch.autopilot_item == 3 and not watch.due  # the same count: nothing new
    watch.on_message(_mav.mission_current_encode(0, 6), 0.0)
    assert watch.due  # an upload of another size
    watch.due = False
    watch.on_message(_mav.statustext_encode(6, b"Mission: 1 WP"), 0.0)
    assert not watch.due
    watch.on_message(_mav.statustext_encode(6, FLIGHT_PLAN_RECEIVED.encode()), 0.0)
    assert watch.due


def test_the_first_count_after_a_read_reads_once_more(tmp_path: Path) -> None:
    """An upload between the read and the first count changed nothing it could compare."""
    watch = _watch(tmp_path)
    watch.due, watch.fingerprint = False, "read before"
    watch.on_message(_mav.mission_current_encode(0, 3), 0.0)
    assert watch.due


async def test_a_mission_read_is_news_only_when_it_changed_or_is_rechecked(
    tmp_path: Path,
) -> None:
    items = downloaded(waypoints_file(tmp_path, 30.0, 50.0))
    got = SimpleNamespace(mission=items, fence=())
    watch = _watch(tmp_path)
    ap = _ap(got, got, got)
    verdict = await watch.read(ap, recheck=False)
    assert verdict is not None and verdict.state is ServeState.READY
    assert watch.checked is verdict.checked and watch.fingerprint is not None
    assert not watch.due and not watch.read_due(now_s())  # the next poll is 30 s away
    assert watch.read_due(now_s() + 30.0)
    assert await watch.read(ap, recheck=False) is None  # the same mission: no news
    again = await watch.read(ap, recheck=True)  # IDLE asks for the verdict again
    assert again is not None and again.state is ServeState.READY


async def test_a_failed_read_is_retried_sooner_and_says_why(tmp_path: Path) -> None:
    watch = _watch(tmp_path)
    before_s = now_s()
    verdict = await watch.read(_ap(MissionTransferError("busy: an upload")), recheck=False)
    assert verdict is None and watch.read_error == "busy: an upload"
    assert watch.checked is None
    assert not watch.read_due(before_s)
    assert watch.read_due(now_s() + MISSION_RETRY_S)  # not a whole poll (30 s) later


async def test_the_mission_file_is_read_instead_of_the_autopilots(tmp_path: Path) -> None:
    path = waypoints_file(tmp_path, 30.0, 50.0)
    watch = _watch(tmp_path, mission_file=path)
    ap = _ap()  # no download asked: it would raise IndexError
    verdict = await watch.read(ap, recheck=False)
    assert verdict is not None and verdict.state is ServeState.READY
    assert await watch.read(ap, recheck=True) is None  # the same file: no news
    path.write_text(waypoints_file(tmp_path, 794.0, name="far").read_text(), encoding="utf-8")
    refused = await watch.read(ap, recheck=False)
    assert refused is not None and refused.state is ServeState.REFUSED
    assert watch.checked is None  # nothing flyable now
