"""One builder for a flight: a source (a mission file, the autopilot's mission, a resume) and
the config → the checked flight, or the refusal.

``helixd check``, ``helixd run`` and ``helixd serve`` all call :func:`prepare_flight`, so what
it refuses all three refuse, with the same lines, before anything connects or moves. What it
judges: the config and the mission together (every problem at once), the mission against the
config (:func:`helixd.mission.judge.mission_vs_config`: ranges, fence, keep-outs, servo
outputs, the time limit; a global mission's places against the home it carries, which stands
for the EKF origin until connected), the route planned around the map, keep-outs and fence
(:func:`helixd.prepare.planned.planned_flight`). What needs the rover's pose and the EKF origin
is judged again in preflight (:mod:`helixd.runtime.setup`); ``check`` lists it as left for
preflight.

No printing and no exits: a refusal is :class:`helixd.prepare.inputs.InputsRefused` (one line
per problem, the exit code ``run`` gives it: 2 for a file or a resume, 3 for the autopilot's
mission failing its checks, and the notes to show with it); notes are lines to show.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

from pydantic import ValidationError

from helixd.base.exitcodes import ExitCode
from helixd.base.media import MediaMap
from helixd.base.plan import MissionFrameKind, MotionMode, operator_numbers
from helixd.base.run_files import MISSION_FILE
from helixd.config.root import HelixdConfig
from helixd.files.models import as_items, format_validation_error
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions, carried_at_step
from helixd.mission.formats import MissionFormat, mission_to_yaml, sniff_format
from helixd.mission.formats.items import GcsMission
from helixd.mission.judge import mission_vs_config
from helixd.mission.model import Mission
from helixd.mission.resolve import PlanError
from helixd.mission.resume import (
    WAYPOINT_REACHED_EVENT,
    ResumeRefused,
    autopilot_step_held,
    check_inputs,
    continued_inputs,
    last_step_started,
    parse_inputs,
    resume_point,
    resumed_inputs,
    sha256_text,
    walked_options,
)
from helixd.mission.validate import resolved_for_check
from helixd.mission.walk import jumps_when_current, restart_at_step, walk_at_step
from helixd.planning.mapfile import OccupancyMap
from helixd.prepare.autopilot_mission import MISSION_NAME, FromAutopilot
from helixd.prepare.inputs import (
    InputsRefused,
    config_sha256,
    load_inputs,
    recorded_mission_yaml,
    resume_inputs,
)
from helixd.prepare.media import MediaRefused, mode_policy, read_media, with_absolute_media
from helixd.prepare.planned import Flight, load_occupancy, planned_flight
from helixd.recorder.resume_dir import read_run_dir

__all__ = [
    "AutoWalk",
    "AutopilotMission",
    "AutopilotPlace",
    "FlightSource",
    "MissionFile",
    "Prepared",
    "Resume",
    "continue_commands",
    "from_autopilot_item",
    "prepare_flight",
]


@dataclass(frozen=True)
class MissionFile:
    """A mission file (YAML, .plan, .waypoints, …) as ``--mission`` names it."""

    path: Path
    mode: MotionMode | None = None  # --mode
    fence: Path | None = None  # --fence
    options: ExpandOptions = DEFAULT_OPTIONS  # --strict / --skip-unsupported


@dataclass(frozen=True)
class AutopilotMission:
    """The autopilot's mission, downloaded and converted (its home is the autopilot's)."""

    got: FromAutopilot
    cfg: HelixdConfig  # the config it was converted with
    options: ExpandOptions = DEFAULT_OPTIONS


@dataclass(frozen=True)
class Resume:
    """The rest of an interrupted run (``--resume RUN_DIR``, a continue in ``serve``)."""

    run_dir: Path
    explicit_mission: Path | None = None  # --mission given with --resume: must be the same


@dataclass(frozen=True)
class AutopilotPlace:
    """The place the autopilot's GUIDED, RTL or SMART_RTL drives to (POSITION_TARGET_GLOBAL_INT):
    a one-leg flight from where the rover is, checked as the autopilot's mission is (fence,
    keep-outs, limits, the route planned around the map)."""

    lat_deg: float
    lon_deg: float
    mode: str  # the autopilot's mode, the flight's name
    cfg: HelixdConfig
    motion: MotionMode  # mission.ground_station_mode (or serve --mode)
    fence: GcsMission | None = None  # the autopilot's fence, for planning


FlightSource = MissionFile | AutopilotMission | Resume | AutopilotPlace


def place_as_mission(place: AutopilotPlace) -> AutopilotMission:
    """The place as a mission of one global waypoint. Raises :class:`InputsRefused`."""
    source = f"the autopilot's {place.mode} place"
    data = {
        "name": place.mode,
        "mode": place.motion.value,
        "frame": MissionFrameKind.GLOBAL.value,
        "waypoints": [{"lat": place.lat_deg, "lon": place.lon_deg}],
    }
    try:
        msn = Mission.model_validate(data, context={"limits": place.cfg.mission})
    except ValidationError as exc:
        raise InputsRefused(format_validation_error(source, exc, Mission)) from None
    return AutopilotMission(FromAutopilot(msn, source, 1, 0, place.fence), place.cfg)


@dataclass(frozen=True)
class Prepared:
    """A checked flight: the config with the mission's own limits in place, the mission as
    loaded (before planning), the file it came from, the flight (planned), the notes to show,
    the lat/lon fence and the map (for the simulator's world) and, for a resume, where the
    interrupted run left the rover (north_m, east_m, yaw_ned_rad)."""

    cfg: HelixdConfig
    mission: Mission
    path: Path
    flight: Flight
    notes: tuple[str, ...] = ()
    fence: GcsMission | None = None
    occupancy: OccupancyMap | None = None
    last_pose_ned: tuple[float, float, float] | None = None
    media: MediaMap | None = None  # the media map the mode follows (None: one mode)


def prepare_flight(
    source: FlightSource,
    config: Path | None,
    occupancy: OccupancyMap | Path | None = None,
) -> Prepared:
    """The checked flight of ``source`` with the config file ``config`` (hashed into the run's
    inputs record; an :class:`AutopilotMission` brings the config it was converted with);
    ``occupancy``: the map (already loaded, or its file); a resume flies the recorded mission
    as it was planned. Raises :class:`InputsRefused`."""
    if isinstance(source, AutopilotPlace):
        source = place_as_mission(source)
    if isinstance(source, Resume):
        resumed = resume_inputs(config, source.run_dir, source.explicit_mission)
        flight = Flight(resumed.mission, resumed.mission_yaml, None, resumed.inputs)
        path = source.run_dir / MISSION_FILE
        return Prepared(
            resumed.cfg,
            resumed.mission,
            path,
            flight,
            resumed.notes,
            last_pose_ned=resumed.last_pose_ned,
        )
    if isinstance(source, AutopilotMission):
        got = source.got
        msn = got.mission
        problems: list[str] = []
        notes: list[str] = []
        checked = mission_vs_config(source.cfg, msn, got.source, problems, source.options, notes)
        if problems or checked is None:
            items = [as_items(p) for p in problems]  # the autopilot's mission: its items
            raise InputsRefused(items, ExitCode.PREFLIGHT, tuple(notes))
        cfg = checked.cfg  # its own limits in force
        path = Path(MISSION_NAME)
        text = mission_to_yaml(msn)  # the run directory records what was downloaded
        fence, options, shown = got.fence, source.options, tuple(notes)
    else:
        loaded = load_inputs(
            config,
            source.path,
            source.mode,
            source.options.skip_unsupported,
            fence=source.fence,
            strict=source.options.strict,
        )
        cfg, path = loaded.cfg, loaded.path
        msn = with_absolute_media(loaded.mission, path)
        text = recorded_mission_yaml(path, msn, source.mode)
        fence, options, shown = loaded.fence, source.options, loaded.notes
    try:
        media = read_media(cfg, msn)
        if media is not None:
            mode_policy(cfg, msn)  # media.modes learned: the ground profile read and checked
    except MediaRefused as exc:
        raise InputsRefused(exc.problems, ExitCode.USAGE, shown) from None
    try:
        occ = load_occupancy(cfg, occupancy) if isinstance(occupancy, Path) else occupancy
        flight = planned_flight(cfg, msn, text, path, occ, config_sha256(config), fence, options)
    except InputsRefused as exc:  # the notes about the mission still stand
        raise InputsRefused(exc.problems, exc.code, shown) from None
    gcs = isinstance(source, AutopilotMission) or sniff_format(path) is not MissionFormat.YAML
    flight = replace(flight, item_numbers=gcs)
    return Prepared(cfg, msn, path, flight, shown, fence, occ, media=media)


@dataclass(frozen=True)
class AutoWalk:
    """Where an AUTO flight of a mission with commands was let go while the autopilot stayed
    armed: the walk it flew (its first item and jump counters) and the step it was on
    (1-based). The autopilot keeps its jump counters until it is disarmed outside AUTO."""

    options: ExpandOptions
    step: int
    # ``step`` is the step the autopilot's own item was on (followed along the walk), not
    # helixd's: the counters are the ones held there, which AP_Mission's resume and
    # set_current_cmd (the crew's *set current waypoint*) keep
    exact: bool = False


def from_autopilot_item(
    flight: Flight,
    seq: int,
    cfg: HelixdConfig,
    held: AutoWalk | None = None,
    from_here: bool = False,
) -> Flight:
    """The checked flight from the autopilot's current item ``seq`` (MISSION_CURRENT, where
    its AUTO runs the mission from); the whole flight for item 0 (none current) or the first.
    A mission of waypoints: the waypoints before it left out, the first leg starting at the one
    before (line guidance re-enters that leg, as a resume does) — or, ``from_here`` (the crew
    set the item mid-leg), where the rover is, as ArduPilot's ``AR_WPNav::set_desired_location``
    starts an interrupted leg from the stopping point: a skipped item is not driven past. A
    mission with commands: the
    whole mission walked from item ``seq`` as ArduPilot runs it from there
    (:attr:`ExpandOptions.first_item`, see :mod:`helixd.mission.expand`), with the jump
    counters the autopilot holds after ``held`` (none: zero), checked again with ``cfg``.
    Raises :class:`InputsRefused`."""
    msn = flight.mission
    numbers = operator_numbers([w.via for w in msn.waypoints])
    k = next((i for i, n in enumerate(numbers) if n >= seq), None)
    if k is None:
        raise InputsRefused(
            [f"the autopilot's current item {seq} is past the mission's last waypoint"]
        )
    if seq <= 0:
        return flight
    if msn.has_commands():
        jumps: tuple[tuple[int, int], ...] = ()
        if held is not None and held.exact:
            at = walk_at_step(msn.waypoints, held.options, max(held.step, 1))
            jumps = () if at is None else at[1]
        elif held is not None:
            jumps = jumps_when_current(msn.waypoints, held.options, max(held.step, 1), k + 1)
        if k == 0 and not jumps:
            return flight
        return _commands_from_item(flight, seq, k + 1, jumps, cfg)
    if k == 0:
        return flight
    reached = [{"event": WAYPOINT_REACHED_EVENT, "index": k - 1}]
    try:
        point = resume_point(f"autopilot item {seq}", flight.inputs, msn, reached, False)
    except ResumeRefused as exc:
        raise InputsRefused(
            [f"cannot start at the autopilot's item {seq}: {exc}; set the current item to 1"]
        ) from None
    if from_here:  # no leg to re-enter: the first leg starts at the rover's pose
        point = replace(point, inputs=point.inputs.model_copy(update={"leg_start": None}))
    text = mission_to_yaml(point.mission)
    return Flight(point.mission, text, None, resumed_inputs(point, text), options=flight.options)


def _commands_from_item(
    flight: Flight, seq: int, entry: int, jumps: tuple[tuple[int, int], ...], cfg: HelixdConfig
) -> Flight:
    """A mission with commands from its entry ``entry`` (1-based; the autopilot's item
    ``seq``) with the jump counters ``jumps``: the same mission and record, its walk starting
    there; what that walk cannot fly is refused as a whole mission's would be."""
    options = replace(flight.options, first_item=entry, jumps_taken=jumps)
    try:
        resolved, _ = resolved_for_check(flight.mission, cfg, options)
    except PlanError as exc:
        raise InputsRefused([f"cannot start at the autopilot's item {seq}: {exc}"]) from None
    if resolved.problems:
        said = [f"cannot start at the autopilot's item {seq}: {p}" for p in resolved.problems]
        raise InputsRefused(said)
    return replace(flight, options=options)


def continue_commands(flight: Flight, run_dir: Path, cfg: HelixdConfig) -> Flight:
    """The continue of an interrupted flight of ``flight``'s mission with commands, recorded in
    ``run_dir`` (``helixd serve``: the start switch, DO_PAUSE_CONTINUE 1 or MISSION_START 0 to
    helixd after a pause or a fault). ``flight`` is the checked mission, which must be the one
    that run flew (same mission.yaml) with the same config.

    What a field engineer gets: the flight goes on with the navigation step it stopped at
    (the last ``step_started`` in its events.jsonl; a flight the autopilot's AUTO drove: the
    step its own current item was on, ``autopilot_step``), at its place in ArduPilot's walk through
    the mission, with the jump counters held there (a DO_JUMP half done is not run from zero;
    :func:`helixd.mission.walk.restart_at_step` on the interrupted flight's own walk, from
    its recorded :class:`helixd.mission.resume.WalkStart`). That step is flown again whole:

    * the do items started with it (a DO_CHANGE_SPEED, DO_SET_SERVO, DO_SET_HOME just before
      its navigation item) start again: the walk starts at the first of them, as
      AP_Mission's ``set_current_cmd`` on a do item starts it and the navigation item after
      it; a payload command of that step is therefore sent a second time;
    * the cruise speed and direction in effect when the step started (a DO_CHANGE_SPEED or
      DO_SET_REVERSE of an earlier step) carry on, set again as the continue starts
      (:attr:`ExpandOptions.speed_mps`, :attr:`ExpandOptions.reverse`); ArduPilot's own AUTO
      re-entry would drop back to WP_SPEED, helixd does not;
    * its first leg runs straight from where the rover stands to the step's waypoint (not
      back onto the interrupted leg's line, as a continue of plain waypoints does); a hold,
      a NAV_LOITER_TIME or a NAV_DELAY interrupted mid-wait waits its whole time again, a
      CONDITION_DELAY its whole delay; a NAV_LOITER_TURNS flies all its turns again.

    A flight paused before its first step started flies its own walk again. The walk is
    checked again with ``cfg``. Raises :class:`InputsRefused`."""
    said = f"continue {run_dir}"
    try:
        contents = read_run_dir(run_dir)
        recorded = parse_inputs(contents.inputs_text)
        check_inputs(recorded, contents.mission_yaml, flight.inputs.config_sha256)
    except ResumeRefused as exc:
        raise InputsRefused([f"{said}: {exc}"]) from None
    if sha256_text(contents.mission_yaml) != sha256_text(flight.mission_yaml):
        raise InputsRefused([f"{said}: the interrupted flight flew another mission"])
    if contents.completed:
        raise InputsRefused([f"{said}: the run completed already: nothing to continue"])
    flown = walked_options(flight.options, recorded.walk)
    # a flight the autopilot's AUTO drove: where its own item was (the crew's set current to
    # the next item, or its arrival ahead of helixd's), as a re-entry of AUTO goes on
    # (serve/flights.py held_walk); a flight helixd drove: its own last step
    step = autopilot_step_held(contents.events) or last_step_started(contents.events)
    options = flown
    if step >= 1:
        at = restart_at_step(flight.mission.waypoints, flown, step)
        if at is None:
            raise InputsRefused([f"{said}: its step {step} is past the mission's end"])
        try:
            resolved, _ = resolved_for_check(flight.mission, cfg, flown)
        except PlanError as exc:
            raise InputsRefused([f"{said}: {exc}"]) from None
        program = resolved.plan.program
        speed, reverse = (None, False) if program is None else carried_at_step(program, step, flown)
        first_item, jumps = at
        options = replace(
            flown, first_item=first_item, jumps_taken=jumps, speed_mps=speed, reverse=reverse
        )
    try:
        resolved, _ = resolved_for_check(flight.mission, cfg, options)
    except PlanError as exc:
        raise InputsRefused([f"{said}: {exc}"]) from None
    if resolved.problems:
        raise InputsRefused([f"{said}: {p}" for p in resolved.problems])
    inputs = continued_inputs(str(run_dir.resolve()), recorded, options.first_item)
    return replace(flight, options=options, inputs=inputs)
