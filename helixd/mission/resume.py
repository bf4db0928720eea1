"""Resuming an interrupted mission (``helixd run --resume RUN_DIR``). Pure: no I/O.

Every run directory holds ``inputs.json`` (:class:`RunInputs`), written at run start: the
SHA-256 of its ``mission.yaml`` text and of the loaded config (canonical YAML dump, so a
comment or a reordering is not a change, a value is), the whole mission's identity and size,
and where this run's waypoint 0 sits in the whole mission (a resume of a resume counts
waypoints of the original mission).

A resume flies ``mission.yaml``'s waypoints from the first one not reached (the navigator
reaches waypoints strictly in order, so that is the highest reached index + 1), with the
waypoint before it as the start of the first leg: line guidance re-enters the interrupted leg
from wherever the rover is, instead of cutting across to the waypoint.

``start``-frame missions are refused: their frame is the rover's pose at arming, which the old
run does not record in any frame a later run can use (after a battery swap the autopilot
reboots and its local NED frame may be re-originated), so "waypoint 12" would designate a
different place. Fly such surveys in ``local_ned`` or, best for battery swaps, ``global``.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from helixd.base.plan import MissionFrameKind, Numbering, Plan
from helixd.base.run_files import INPUTS_FILE
from helixd.config.control import ControlConfig
from helixd.config.mission import MissionLimits
from helixd.mission.expand import ExpandOptions
from helixd.mission.model import Mission, WaypointSpec
from helixd.mission.resolve import resolve_plan

INPUTS_FORMAT = 1
WAYPOINT_REACHED_EVENT = "waypoint_reached"
RUN_RESUMED_EVENT = "run_resumed"
MISSION_STEP_EVENT = "mission_step"  # a flight of a mission with commands: kind, step, item
STEP_STARTED = "step_started"


class ResumeRefused(ValueError):
    """The run cannot be resumed; ``str()`` is the one-line reason for the operator."""


def sha256_text(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ResumedFrom(_Strict):
    """The run a resumed run continues (recorded in the new run's inputs and summary)."""

    path: str = Field(description="run directory that was resumed")
    mission_sha256: str = Field(description="SHA-256 of that run's mission.yaml")
    config_sha256: str = Field(description="SHA-256 of the config it was flown with")
    first_waypoint: int = Field(
        ge=0, description="whole-mission index (0-based) of the first waypoint flown now"
    )


class WalkStart(_Strict):
    """Where a flight of a mission with commands started its walk through the mission, when
    not simply at item 1 (``helixd serve``: AUTO from the autopilot's item, MISSION_START
    from an item, a continue): what a later continue of it walks from."""

    first_item: int = Field(ge=1, description="the mission item the walk started at")
    jumps_taken: tuple[tuple[int, int], ...] = Field(
        (), description="the jump counters it started with: (DO_JUMP item, times taken)"
    )
    speed_mps: float | None = Field(
        None, gt=0, description="the cruise speed it started with (None: the configured one)"
    )
    reverse: bool = Field(False, description="it started driving backwards")


class RunInputs(_Strict):
    """``inputs.json``: what a run was started with, to check a later resume against."""

    format: int = Field(INPUTS_FORMAT, description="inputs.json format version")
    mission_sha256: str = Field(description="SHA-256 of this run's mission.yaml text")
    config_sha256: str = Field(description="SHA-256 of the loaded config (canonical YAML)")
    root_mission_sha256: str = Field(
        description="SHA-256 of the whole mission's YAML (= mission_sha256 unless resumed)"
    )
    frame: MissionFrameKind
    index_offset: int = Field(0, ge=0, description="whole-mission index of this run's waypoint 0")
    waypoints_total: int = Field(ge=1, description="waypoints in the whole mission")
    leg_start: WaypointSpec | None = Field(
        None, description="waypoint before this run's first (start of its first leg), if any"
    )
    operator_offset: int = Field(
        0,
        ge=0,
        description="the operator's waypoints (via points not counted) of the whole mission "
        "before this run's first",
    )
    operator_total: int | None = Field(
        None,
        ge=1,
        description="the operator's waypoints in the whole mission (None: recorded before "
        "via points were told apart: every waypoint counts)",
    )
    resumed_from: ResumedFrom | None = None
    walk: WalkStart | None = Field(
        None, description="a mission with commands walked from a later item (None: item 1)"
    )

    def numbering(self, vias: Sequence[bool]) -> Numbering:
        """The operator's numbering of this run's plan (``vias``: its via flags)."""
        if self.operator_total is None:  # older record: every waypoint was counted
            return Numbering.of(vias, self.index_offset + 1, self.waypoints_total)
        return Numbering.of(vias, self.operator_offset + 1, self.operator_total)

    def to_json(self) -> str:
        return self.model_dump_json(indent=2, exclude_none=True) + "\n"


def fresh_inputs(mission_yaml: str, config_sha256: str, mission: Mission) -> RunInputs:
    """Inputs record of a run that starts a mission from its beginning."""
    digest = sha256_text(mission_yaml)
    return RunInputs(
        mission_sha256=digest,
        config_sha256=config_sha256,
        root_mission_sha256=digest,
        frame=mission.frame,
        waypoints_total=len(mission.waypoints),
        operator_total=max(1, sum(not w.via for w in mission.waypoints)),
    )


def parse_inputs(text: str) -> RunInputs:
    """``inputs.json`` text → :class:`RunInputs`; garbage → :class:`ResumeRefused`."""
    try:
        inputs = RunInputs.model_validate_json(text)
    except ValidationError as exc:
        first = exc.errors()[0]
        where = ".".join(str(p) for p in first.get("loc", ())) or "file"
        raise ResumeRefused(f"{INPUTS_FILE} is corrupt ({where}: {first.get('msg')})") from None
    if inputs.format != INPUTS_FORMAT:
        raise ResumeRefused(f"{INPUTS_FILE} format {inputs.format} is not {INPUTS_FORMAT}")
    return inputs


def first_not_reached(events: list[dict[str, Any]], waypoints: int) -> int:
    """Index of the first waypoint of the run's mission not reached, from its events.

    ``waypoint_reached`` events with an integer ``index`` count; order and duplicates do not
    matter (the navigator reaches waypoints in order: the answer is the highest index + 1).
    Events of other kinds and torn/garbled fields are ignored; an index outside the mission
    means the events belong to another mission: refused."""
    highest = -1
    for ev in events:
        if not isinstance(ev, dict) or ev.get("event") != WAYPOINT_REACHED_EVENT:
            continue
        index = ev.get("index")
        if not isinstance(index, int) or isinstance(index, bool):
            continue
        if not 0 <= index < waypoints:
            raise ResumeRefused(
                f"events.jsonl reports waypoint index {index}, but mission.yaml has "
                f"{waypoints} waypoints: the run directory does not belong together"
            )
        highest = max(highest, index)
    return highest + 1


@dataclass(frozen=True, slots=True)
class ResumePoint:
    """What a resumed run flies: the remaining mission and the start of its first leg."""

    mission: Mission  # the remaining waypoints (mission.yaml of the new run)
    inputs: RunInputs  # inputs.json of the new run (its mission_sha256 is filled in later)
    first_index: int  # whole-mission index of the remaining mission's waypoint 0


def check_inputs(
    inputs: RunInputs,
    mission_yaml: str,
    config_sha256: str,
    explicit_mission_sha256: str | None = None,
) -> None:
    """Refuse when the run directory's mission.yaml, the config or the given mission changed
    since the run started."""
    if sha256_text(mission_yaml) != inputs.mission_sha256:
        raise ResumeRefused(
            "mission.yaml in the run directory changed since the run started (hash mismatch)"
        )
    if config_sha256 != inputs.config_sha256:
        raise ResumeRefused(
            "the config changed since the run started (hash mismatch): resume with the "
            "config the run was flown with"
        )
    if explicit_mission_sha256 is not None and explicit_mission_sha256 != (
        inputs.root_mission_sha256
    ):
        raise ResumeRefused(
            "--mission differs from the mission the run was started with (hash mismatch)"
        )


def resume_point(
    run_path: str,
    inputs: RunInputs,
    mission: Mission,
    events: list[dict[str, Any]],
    completed: bool,
) -> ResumePoint:
    """The remaining mission after the run ``run_path`` (already hash-checked)."""
    if mission.has_commands():
        raise ResumeRefused(
            "the mission has commands (holds, jumps, returns, payload commands): where it "
            "stopped in them cannot be resumed by `run --resume`; fly it again from the start "
            "(`helixd serve` continues it from its step)"
        )
    if mission.frame is MissionFrameKind.START or inputs.frame is MissionFrameKind.START:
        raise ResumeRefused(
            "a start-frame mission cannot be resumed: its frame was the rover's pose at "
            "arming, which a new run cannot recover; fly surveys in local_ned or global"
        )
    if mission.frame is not inputs.frame:
        raise ResumeRefused(f"mission.yaml frame {mission.frame.value} is not the recorded one")
    n = len(mission.waypoints)
    if inputs.index_offset + n != inputs.waypoints_total:
        raise ResumeRefused(
            f"{INPUTS_FILE} counts {inputs.waypoints_total} waypoints from index "
            f"{inputs.index_offset}, mission.yaml has {n}: the run directory is inconsistent"
        )
    if completed:
        raise ResumeRefused("the run completed already: nothing to resume")
    k = first_not_reached(events, n)
    if k >= n:
        raise ResumeRefused("every waypoint of the run was reached already: nothing to resume")
    leg_start = mission.waypoints[k - 1] if k > 0 else inputs.leg_start
    remaining = mission.model_copy(update={"waypoints": tuple(mission.waypoints[k:])})
    first = inputs.index_offset + k
    done_own = sum(not w.via for w in mission.waypoints[:k])
    new = RunInputs(
        mission_sha256="",  # of the new run's mission.yaml, filled in by resumed_inputs()
        config_sha256=inputs.config_sha256,
        root_mission_sha256=inputs.root_mission_sha256,
        frame=inputs.frame,
        index_offset=first,
        waypoints_total=inputs.waypoints_total,
        leg_start=leg_start,
        operator_offset=inputs.operator_offset + done_own,
        operator_total=inputs.operator_total,
        resumed_from=ResumedFrom(
            path=run_path,
            mission_sha256=inputs.mission_sha256,
            config_sha256=inputs.config_sha256,
            first_waypoint=first,
        ),
    )
    return ResumePoint(mission=remaining, inputs=new, first_index=first)


def resumed_inputs(point: ResumePoint, mission_yaml: str) -> RunInputs:
    """The new run's inputs record, with the hash of the mission.yaml it writes."""
    return point.inputs.model_copy(update={"mission_sha256": sha256_text(mission_yaml)})


def with_leg_start(
    plan: Plan,
    mission: Mission,
    leg_start: WaypointSpec | None,
    control: ControlConfig,
    limits: MissionLimits,
    origin_latlon_deg: tuple[float, float] | None = None,
) -> Plan:
    """``plan`` with the first leg starting at ``leg_start`` (resolved in the same frame as
    the plan, through the same EKF origin); unchanged when there is none."""
    if leg_start is None:
        return plan
    one = mission.model_copy(update={"waypoints": (leg_start,)})
    wp = resolve_plan(one, control, limits, origin_latlon_deg).waypoints[0]
    return replace(plan, leg_start_xy_m=(wp.x_m, wp.y_m))


def event_whole(got: object, default: int) -> int:
    """An event's whole-number field (a step, an item) as recorded, else ``default`` (a
    garbled or missing field; a bool is no number here)."""
    return got if isinstance(got, int) and not isinstance(got, bool) else default


def last_step_started(events: list[dict[str, Any]]) -> int:
    """The last navigation step (1-based) a flight of a mission with commands started, from
    its ``mission_step`` ``step_started`` events (0: none; garbled fields are ignored)."""
    step = 0
    for ev in events:
        if not isinstance(ev, dict) or ev.get("event") != MISSION_STEP_EVENT:
            continue
        if ev.get("kind") == STEP_STARTED:
            step = event_whole(ev.get("step"), step)
    return step


def autopilot_step_held(events: list[dict[str, Any]]) -> int:
    """The step (1-based) the autopilot's own current item was on when a flight the autopilot's
    AUTO drove ended, followed along the walk (its ``autopilot_step`` and ``autopilot_item_set``
    events; 0: none recorded, as in a flight helixd drove in MANUAL)."""
    step = 0
    for ev in events:
        name = ev.get("event") if isinstance(ev, dict) else None
        if name == "autopilot_step":
            step = event_whole(ev.get("step"), step)
        elif name == "autopilot_item_set":
            step = event_whole(ev.get("autopilot_step"), step)
    return step


def with_walk(inputs: RunInputs, options: ExpandOptions) -> RunInputs:
    """``inputs`` with the walk ``options`` start (none when it starts at item 1 with nothing
    carried), so a continue of the flight can walk on from where it stopped."""
    walk = None
    if (
        options.first_item > 1
        or options.jumps_taken
        or options.speed_mps is not None
        or options.reverse
    ):
        walk = WalkStart(
            first_item=max(options.first_item, 1),
            jumps_taken=options.jumps_taken,
            speed_mps=options.speed_mps,
            reverse=options.reverse,
        )
    return inputs.model_copy(update={"walk": walk})


def walked_options(base: ExpandOptions, walk: WalkStart | None) -> ExpandOptions:
    """``base`` (the operator's choices) with the walk a run recorded."""
    if walk is None:
        return replace(base, first_item=1, jumps_taken=(), speed_mps=None, reverse=False)
    return replace(
        base,
        first_item=walk.first_item,
        jumps_taken=tuple(walk.jumps_taken),
        speed_mps=walk.speed_mps,
        reverse=walk.reverse,
    )


def continued_inputs(run_path: str, inputs: RunInputs, first_item: int) -> RunInputs:
    """The inputs record of a continue of the run ``run_path`` (its record ``inputs``) of a
    mission with commands: the same whole mission, walked from ``first_item`` (its walk is
    recorded when the flight starts)."""
    return inputs.model_copy(
        update={
            "walk": None,
            "resumed_from": ResumedFrom(
                path=run_path,
                mission_sha256=inputs.mission_sha256,
                config_sha256=inputs.config_sha256,
                first_waypoint=max(first_item - 1, 0),
            ),
        }
    )


__all__ = [
    "MISSION_STEP_EVENT",
    "RUN_RESUMED_EVENT",
    "STEP_STARTED",
    "ResumePoint",
    "ResumeRefused",
    "ResumedFrom",
    "RunInputs",
    "WalkStart",
    "autopilot_step_held",
    "check_inputs",
    "continued_inputs",
    "event_whole",
    "first_not_reached",
    "fresh_inputs",
    "last_step_started",
    "parse_inputs",
    "resume_point",
    "resumed_inputs",
    "sha256_text",
    "walked_options",
    "with_leg_start",
    "with_walk",
]
