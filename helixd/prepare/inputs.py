"""What a run flies, loaded and checked before anything connects: the config and the mission
together (every problem at once, as ``check`` and ``run`` both need), the text the run
directory records and hashes, and the inputs of ``run --resume RUN_DIR``.

No printing and no exits: a refusal is :class:`InputsRefused` (one line per problem and the
exit code); what the operator should read but which does not stop the run comes back as notes.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

from helixd.base.exitcodes import ExitCode
from helixd.base.plan import MissionFrameKind, MotionMode, Plan
from helixd.base.problems import Problems
from helixd.base.run_files import MISSION_FILE
from helixd.config.load import config_to_yaml, load_config
from helixd.config.root import HelixdConfig
from helixd.files.models import ConfigFileError, as_items
from helixd.files.yamlio import clip_line
from helixd.mission.expand import DEFAULT_OPTIONS, ExpandOptions
from helixd.mission.formats import (
    MissionFormat,
    forced_mode,
    load_mission_file,
    mission_to_yaml,
    read_fence,
    sniff_format,
    with_fence,
)
from helixd.mission.formats.items import FormatError, GcsMission
from helixd.mission.judge import MissionChecked, mission_vs_config
from helixd.mission.locate import MissionNotFound, locate_mission
from helixd.mission.model import Mission
from helixd.mission.resume import (
    ResumeRefused,
    RunInputs,
    check_inputs,
    parse_inputs,
    resume_point,
    resumed_inputs,
    sha256_text,
)
from helixd.recorder.resume_dir import read_run_dir


class InputsRefused(Problems):
    """The inputs cannot be flown; ``problems`` holds one line each, ``code`` the exit code,
    ``notes`` what the operator should read with them (skipped items, …)."""

    def __init__(
        self, problems: list[str], code: ExitCode = ExitCode.USAGE, notes: tuple[str, ...] = ()
    ) -> None:
        super().__init__(problems)
        self.code = code
        self.notes = notes


@dataclass(frozen=True)
class LoadedInputs:
    """The config (with the mission's own limits applied), the mission, the file actually used
    and the plan as :func:`plan_for_check` resolves it; ``notes`` are warnings to show."""

    cfg: HelixdConfig
    mission: Mission
    path: Path
    plan: Plan
    provisional: bool  # a global plan shown relative to waypoint 0 (EKF origin not known)
    notes: tuple[str, ...] = field(default=())
    # the lat/lon fence the flight is planned and fenced by: a .plan's own geofence and the
    # --fence file's shapes (None: none)
    fence: GcsMission | None = None
    options: ExpandOptions = DEFAULT_OPTIONS


def load_inputs(
    config: Path | None,
    mission: Path,
    mode: MotionMode | None = None,
    skip_unsupported: bool = False,
    *,
    fence: Path | None = None,
    strict: bool = False,
) -> LoadedInputs:
    """Load config and mission together so the operator sees every problem at once.

    Runs the shared mission-vs-config validation (what can be checked without the vehicle),
    so ``check`` and ``run`` refuse the same files. ``fence``: a fence file (``--fence``);
    ``strict`` refuses what ArduPilot Rover skips, ``skip_unsupported`` passes over what
    helixd cannot fly (both for missions with commands)."""
    options = ExpandOptions(strict=strict, skip_unsupported=skip_unsupported)
    problems: list[str] = []
    notes: list[str] = []
    cfg: HelixdConfig | None = None
    try:
        cfg = load_config(config)
    except ConfigFileError as exc:
        problems.extend(exc.problems)
    limits = cfg.mission if cfg is not None else HelixdConfig().mission
    msn = None
    fence_gcs: GcsMission | None = None
    path = mission
    try:
        found = locate_mission(mission)
        path = found.path
        if found.searched:
            notes.append(f"mission {mission}: using {path}")
        gs_mode = cfg.mission.ground_station_mode if cfg is not None else None
        # --mode wins over a YAML mission's whole media plan (forced_mode), not only its mode
        forced = mode if sniff_format(path) is MissionFormat.YAML else None
        loaded = load_mission_file(
            path,
            limits,
            mode=None if forced is not None else mode,
            default_mode=MotionMode(gs_mode) if gs_mode else None,
            # planning routes the legs around a .plan's exclusion zones instead of refusing
            route_keep_outs=cfg is not None and cfg.planning.enabled,
        )
        if forced is not None:
            config_map = cfg is not None and cfg.media.media_map is not None
            whole, note = forced_mode(loaded.mission, forced, config_map)
            said = (f"{path}: {note}",) if note else ()
            loaded = replace(loaded, mission=whole, notes=(*loaded.notes, *said))
            if cfg is not None:  # the config's media map is off as well
                cfg = cfg.model_copy(
                    update={"media": cfg.media.model_copy(update={"media_map": None})}
                )
        if fence is not None:
            loaded = with_fence(
                loaded,
                read_fence(fence),
                str(fence),
                route_keep_outs=cfg is not None and cfg.planning.enabled,
            )
        msn = loaded.mission
        fence_gcs = loaded.gcs
        notes.extend(f"warning: {clip_line(line)}" for line in loaded.notes)
    except MissionNotFound as exc:
        problems.append(str(exc))
    except ConfigFileError as exc:
        problems.extend(exc.problems)
    except FormatError as exc:  # the --fence file
        problems.extend(exc.problems)
    checked: MissionChecked | None = None
    if cfg is not None and msn is not None:
        checked = mission_vs_config(cfg, msn, str(path), problems, options, notes)
    if problems or cfg is None or msn is None or checked is None:
        if sniff_format(path) is not MissionFormat.YAML:  # QGC's item numbers, not the YAML's
            problems = [as_items(p) for p in problems]
        raise InputsRefused(problems, ExitCode.USAGE)
    # the mission's own fence/time limit (a survey's) replace the config's for this run
    plan, provisional, cfg = checked
    return LoadedInputs(cfg, msn, path, plan, provisional, tuple(notes), fence_gcs, options)


def recorded_mission_yaml(mission_path: Path, msn: Mission, mode: MotionMode | None) -> str:
    """What the run directory keeps as mission.yaml (and hashes): the YAML file as written,
    else the flown mission as helixd YAML."""
    try:
        if sniff_format(mission_path) is MissionFormat.YAML and mode is None:
            return mission_path.read_text(encoding="utf-8")
        return mission_to_yaml(msn)
    except (OSError, UnicodeDecodeError) as exc:
        raise InputsRefused([f"{mission_path}: cannot read file: {exc}"]) from None


def config_sha256(config: Path | None) -> str:
    """Hash of the loaded config (canonical YAML dump: a value change is a change, a comment
    is not), before any command-line override such as --connect."""
    try:
        return sha256_text(config_to_yaml(load_config(config)))
    except ConfigFileError as exc:
        raise InputsRefused(exc.problems) from None


@dataclass(frozen=True)
class ResumeInputs:
    """Config, remaining mission, its YAML and the new run's inputs record for
    ``--resume RUN_DIR``; ``notes`` are lines to show the operator."""

    cfg: HelixdConfig
    mission: Mission
    mission_yaml: str
    inputs: RunInputs
    notes: tuple[str, ...]
    # where the interrupted run left the rover (north_m, east_m, yaw_ned_rad), if recorded
    last_pose_ned: tuple[float, float, float] | None = None


def resume_inputs(
    config: Path | None, run_dir: Path, explicit_mission: Path | None
) -> ResumeInputs:
    """The inputs of ``run --resume RUN_DIR``; every refusal is one line and exit 2."""
    try:
        contents = read_run_dir(run_dir)
        recorded = parse_inputs(contents.inputs_text)
        explicit_sha = None
        if explicit_mission is not None:
            given = load_inputs(config, explicit_mission)
            explicit_sha = sha256_text(recorded_mission_yaml(given.path, given.mission, None))
        check_inputs(recorded, contents.mission_yaml, config_sha256(config), explicit_sha)
        old = load_inputs(config, run_dir / MISSION_FILE)
        point = resume_point(
            str(run_dir.resolve()), recorded, old.mission, contents.events, contents.completed
        )
    except ResumeRefused as exc:
        raise InputsRefused([f"--resume {run_dir}: {exc}"]) from None
    mission_yaml = mission_to_yaml(point.mission)
    numbering = point.inputs.numbering([w.via for w in point.mission.waypoints])
    left = numbering.operator_count
    notes = [
        f"resume  : {run_dir}: from waypoint {numbering.label(0)} ({left} remaining"
        + (f", {len(numbering.vias) - left} via points)" if left < len(numbering.vias) else ")")
    ]
    if point.mission.frame is MissionFrameKind.LOCAL_NED:
        notes.append(
            "warning: local_ned waypoints are relative to the EKF origin; if the autopilot "
            "set a new origin since (reboot, GPS), they lie elsewhere (global is safe)"
        )
    return ResumeInputs(
        old.cfg,
        point.mission,
        mission_yaml,
        resumed_inputs(point, mission_yaml),
        tuple(notes),
        contents.last_pose_ned,
    )
