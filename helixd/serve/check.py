"""``helixd serve``'s verdict on the mission it would fly: the autopilot's downloaded mission
(or ``serve.mission_file``), checked as ``helixd check`` and ``helixd run`` check it
(:func:`helixd.prepare.builder.prepare_flight`).

Each function returns a :class:`Verdict` — the checked mission, or the state and the texts
the service tells the ground station; the service (:mod:`helixd.serve.service`) applies and
logs it. Nothing here touches the link.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import structlog

from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.files.models import as_items
from helixd.mission.expand import ExpandOptions
from helixd.mission.formats.items import GcsMission
from helixd.mission.model import Mission
from helixd.mission.resume import sha256_text
from helixd.planning.mapfile import OccupancyMap
from helixd.prepare.autopilot_mission import MissionRefused, convert_download, ground_station_mode
from helixd.prepare.builder import AutopilotMission, MissionFile, prepare_flight
from helixd.prepare.inputs import InputsRefused
from helixd.prepare.planned import Flight
from helixd.serve.core import ServeState

log = structlog.get_logger(__name__)

MAX_REFUSAL_TEXTS = 4  # STATUSTEXT lines per refused mission (the log has them all)


@dataclass(frozen=True)
class ReadyMission:
    """The autopilot's mission, checked and ready to fly."""

    fingerprint: str
    flight: Flight
    cfg: HelixdConfig  # with the mission's own limits
    last_item: int  # the mission's last item number
    waypoints: int

    @property
    def name(self) -> str:
        """Which plan, in a few characters the crew can compare: ``plan 1a2b3c: 3 waypoints``
        (the first hex digits of its fingerprint: a same-size re-upload reads differently)."""
        return f"{plan_id(self.fingerprint)}: {count_text(self.flight.mission, self.waypoints)}"


def plan_id(fingerprint: str) -> str:
    """The short name of a mission read: ``plan`` and its fingerprint's first 6 hex digits."""
    return f"plan {fingerprint[:6]}"


@dataclass(frozen=True)
class Verdict:
    """What the service does with a mission it read: READY with ``checked``, REFUSED with
    the first problem as ``detail`` and the next ones as ``more`` (each a GCS text), or IDLE
    (nothing to fly)."""

    state: ServeState
    detail: str
    checked: ReadyMission | None = None
    more: list[str] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)  # a refusal's, each for the log
    fence: GcsMission | None = None  # the autopilot's fence, when it was converted


@dataclass(frozen=True)
class CheckInputs:
    """What a check needs besides the mission: the service's config and options."""

    cfg: HelixdConfig
    config_path: Path | None
    mode: MotionMode | None  # --mode; else mission.ground_station_mode
    options: ExpandOptions
    occupancy: OccupancyMap | None


def operator_waypoints(msn: Mission) -> int:
    return sum(not w.via for w in msn.waypoints)


def count_text(msn: Mission, n: int) -> str:
    """``6 waypoints``; a mission with commands: ``5 items``, as the ground station counts
    them."""
    return f"{n} items" if msn.has_commands() else f"{n} waypoints"


def _refused(problems: list[str], source: str, fence: GcsMission | None = None) -> Verdict:
    problems = [as_items(p) for p in problems]  # the autopilot's mission: its items
    shown = [p.removeprefix(f"{source}: ") for p in problems]
    more = [f"refused: {p}" for p in shown[1:MAX_REFUSAL_TEXTS]]
    return Verdict(ServeState.REFUSED, "; ".join(shown[:1]), None, more, problems, fence)


def check_download(
    mission: tuple[Any, ...], fence: tuple[Any, ...], fingerprint: str, inp: CheckInputs
) -> Verdict:
    """``helixd check``'s checks of the mission downloaded from the autopilot."""
    cfg = inp.cfg
    source = f"autopilot at {cfg.link.url}"
    mode = ground_station_mode(cfg, inp.mode)
    if mode is None:
        return _refused(
            [
                "the autopilot's mission carries no motion mode: set "
                "mission.ground_station_mode in the config (or serve --mode)"
            ],
            source,
        )
    if len(mission) <= 1:
        return Verdict(ServeState.IDLE, "no mission on the autopilot")
    try:
        got = convert_download(mission, fence, source=source, cfg=cfg, mode=mode)
    except MissionRefused as exc:
        return _refused(list(exc.problems), source)
    for note in got.notes:
        log.info("mission_note", note=note)
    try:
        prepared = prepare_flight(
            AutopilotMission(got, cfg, inp.options), inp.config_path, inp.occupancy
        )
    except (MissionRefused, InputsRefused) as exc:  # a flight to a place still knows the fence
        return _refused(list(exc.problems), source, got.fence)
    for note in prepared.notes:
        log.info("mission_note", note=note)
    n = operator_waypoints(got.mission)
    checked = ReadyMission(fingerprint, prepared.flight, prepared.cfg, len(mission) - 1, n)
    return Verdict(ServeState.READY, f"{checked.name} checked", checked, fence=got.fence)


def check_file(path: Path, inp: CheckInputs) -> tuple[str, Verdict]:
    """The mission file (``serve.mission_file``, ``--mission``), checked as ``helixd run``
    checks it: (its fingerprint, the verdict). A refusal's fingerprint is its problems, so a
    file refused the same way again is no news."""
    try:
        got = prepare_flight(MissionFile(path, inp.mode), inp.config_path, inp.occupancy)
    except InputsRefused as exc:
        fingerprint = "refused:" + "; ".join(exc.problems)
        problems = list(exc.problems)
        return fingerprint, Verdict(ServeState.REFUSED, problems[0], problems=problems)
    fingerprint = sha256_text(got.flight.mission_yaml)
    cfg = got.cfg.model_copy(update={"link": inp.cfg.link})
    n = operator_waypoints(got.mission)
    checked = ReadyMission(fingerprint, got.flight, cfg, len(got.mission.waypoints), n)
    detail = f"{got.path.name} checked, {count_text(got.mission, n)}"
    return fingerprint, Verdict(ServeState.READY, detail, checked)
