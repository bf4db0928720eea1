"""Mission files in every format helixd reads: its own YAML, QGroundControl ``.plan`` and
Mission Planner / QGC WPL 110 ``.waypoints`` — detected by suffix, converted to one
:class:`~helixd.mission.model.Mission`. Writing is the reverse (``helixd mission convert``).

Ground-station files carry no motion mode: it comes from ``--mode`` or the config's
``mission.ground_station_mode``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

import yaml
from pydantic import ValidationError

from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.config.mission import MissionLimits
from helixd.files.models import ConfigFileError, as_items, entry_label, format_validation_error
from helixd.files.yamlio import YamlFileError, read_text_capped
from helixd.mission.formats.items import (
    Converted,
    FenceNe,
    FencePolygon,
    FormatError,
    GcsMission,
    check_latlon,
    fence_ne,
    items_to_mission,
    keep_in_of,
    keep_out_problems,
    mission_name,
    mission_to_items,
)
from helixd.mission.formats.qgc_plan import parse_plan_text, plan_to_text
from helixd.mission.formats.wpl import parse_wpl_fence_text, parse_wpl_text, wpl_to_text
from helixd.mission.model import Mission, entry_yaml, load_mission


class MissionFormat(StrEnum):
    YAML = "yaml"
    PLAN = "plan"
    WAYPOINTS = "waypoints"


SUFFIXES = {
    ".yaml": MissionFormat.YAML,
    ".yml": MissionFormat.YAML,
    ".plan": MissionFormat.PLAN,
    ".mission": MissionFormat.PLAN,  # QGroundControl's older mission file (read only)
    ".waypoints": MissionFormat.WAYPOINTS,
    ".txt": MissionFormat.WAYPOINTS,  # Mission Planner's "save WP file" also offers .txt
}


def detect_format(path: Path) -> MissionFormat:
    """The format a file name asks for (writing, and ``convert``'s output)."""
    fmt = SUFFIXES.get(path.suffix.lower())
    if fmt is None or path.suffix.lower() == ".mission":
        raise FormatError(
            [
                f"{path}: unknown mission file type {path.suffix or '(no suffix)'!r}; allowed: "
                ".yaml/.yml (helixd), .plan (QGroundControl), .waypoints/.txt (QGC WPL 110)"
            ]
        )
    return fmt


def sniff_format(path: Path) -> MissionFormat:
    """The format of a file to read: by suffix; a ``.txt`` is WPL only if it starts with the
    ``QGC WPL`` header; any other suffix (or none) is helixd YAML, as it always was."""
    fmt = SUFFIXES.get(path.suffix.lower(), MissionFormat.YAML)
    if path.suffix.lower() == ".txt":
        try:
            with path.open("rb") as fh:
                head = fh.read(16).removeprefix(b"\xef\xbb\xbf")
        except OSError:
            return MissionFormat.YAML  # the YAML loader names the problem
        if not head.startswith(b"QGC WPL"):
            return MissionFormat.YAML
    return fmt


def _old_text_kind(path: Path) -> str | None:
    """A ``.txt`` that is neither WPL nor YAML but MAVProxy's older formats: "rally" (lines
    ``RALLY lat lon …``) or "fence" (lines ``lat lon``: the return point, then a polygon)."""
    if path.suffix.lower() != ".txt":
        return None
    try:
        with path.open("rb") as fh:
            head = fh.read(4096).removeprefix(b"\xef\xbb\xbf").decode("utf-8", "replace")
    except OSError:
        return None
    lines = [ln.split() for ln in head.splitlines() if ln.strip() and not ln.startswith("#")]
    if not lines:
        return None
    if lines[0][0].upper() == "RALLY":
        return "rally"
    try:
        if all(len(ln) == 2 and all(math.isfinite(float(v)) for v in ln) for ln in lines[:20]):
            return "fence"
    except ValueError:
        return None
    return None


def parse_point_fence_text(text: str, source: Path | str) -> GcsMission:
    """MAVProxy's older polygon fence (``fence load`` of a lat/lon list, the one ArduPilot's
    autotest still carries): the first point is the return point, the rest one inclusion
    polygon (its closing repeat of the first vertex dropped)."""
    src = str(source)
    pts: list[tuple[float, float]] = []
    problems: list[str] = []
    for n, line in enumerate(text.splitlines(), start=1):
        cols = line.split()
        if not cols or line.startswith("#"):
            continue
        try:
            if len(cols) != 2:
                raise ValueError
            lat, lon = float(cols[0]), float(cols[1])
        except ValueError:
            problems.append(f"{src}: line {n}: expected 'latitude longitude'")
            continue
        bad = check_latlon(f"{src}: line {n}", lat, lon)
        if bad:
            problems.extend(bad)
            continue
        pts.append((lat, lon))
    if problems:
        raise FormatError(problems[:20])
    polygon = pts[1:]
    if len(polygon) > 1 and polygon[0] == polygon[-1]:
        polygon = polygon[:-1]
    if len(polygon) < 3:
        raise FormatError([f"{src}: a return point and at least 3 polygon vertices are needed"])
    return GcsMission(
        items=(),
        polygons=(FencePolygon(tuple(polygon), inclusion=True),),
        notes=(f"{src}: line 1: fence return point {pts[0]} not kept",),
    )


def read_gcs(path: Path) -> GcsMission:
    """A .plan or .waypoints file's items and fences (no conversion)."""
    fmt = sniff_format(path)
    try:
        text = read_text_capped(path).removeprefix("\ufeff")  # Windows tools write a BOM
    except YamlFileError as exc:
        raise FormatError([exc.message.replace("YAML file", "mission file")]) from None
    if fmt is MissionFormat.PLAN:
        return parse_plan_text(text, path)
    if fmt is MissionFormat.WAYPOINTS:
        return parse_wpl_text(text, path)
    raise FormatError([f"{path}: a helixd YAML mission has no ground-station items"])


@dataclass(frozen=True, slots=True)
class LoadedMission:
    mission: Mission
    format: MissionFormat
    notes: tuple[str, ...] = ()
    gcs: GcsMission | None = None


def load_mission_file(
    path: Path,
    limits: MissionLimits | None = None,
    *,
    mode: MotionMode | None = None,
    default_mode: MotionMode | None = None,
    route_keep_outs: bool = False,
) -> LoadedMission:
    """Any supported file → a validated mission. Raises :class:`ConfigFileError` (one line per
    problem, each naming the file) like :func:`load_mission`.

    ``mode`` (the ``--mode`` flag) overrides any file's mode (a YAML mission's own ``mode:``
    too, with a note saying so; ``check`` and ``run`` take :func:`forced_mode` instead);
    ``default_mode`` (the config's ``mission.ground_station_mode``) is used for
    ground-station files only, which carry none.
    ``route_keep_outs``: legs through a .plan's exclusion zones are planned around
    (helixd.planning), not refused (see :func:`items_to_mission`)."""
    fmt = sniff_format(path)
    old = _old_text_kind(path) if fmt is MissionFormat.YAML else None
    if old == "fence":
        raise ConfigFileError(
            path,
            [
                f"{path}: a fence file (MAVProxy's lat/lon list: return point, then a polygon), "
                f"not a mission: give it with --fence {path}"
            ],
        )
    if old == "rally":
        raise ConfigFileError(
            path,
            [
                f"{path}: rally points (RALLY lines), not a mission: helixd flies missions; its "
                "NAV_RETURN_TO_LAUNCH goes to the autopilot's home, not to rally points"
            ],
        )
    if fmt is MissionFormat.YAML:
        msn = load_mission(path, limits)
        if mode is not None and mode is not msn.mode:
            note = (
                f"{path}: --mode {mode.value} wins over the mission's own mode: "
                f"{msn.mode.value}; it is flown in {mode.value}"
            )
            return LoadedMission(msn.model_copy(update={"mode": mode}), fmt, (note,))
        return LoadedMission(msn, fmt)
    mode = mode or default_mode
    if mode is None:
        raise ConfigFileError(
            path,
            [
                f"{path}: a {fmt.value} file carries no motion mode: give --mode roll|scroll|omni "
                "or set mission.ground_station_mode in the config"
            ],
        )
    try:
        gcs = read_gcs(path)
        conv: Converted = items_to_mission(
            gcs,
            name=mission_name(path.stem),
            mode=mode,
            source=str(path),
            route_keep_outs=route_keep_outs,
            here_completes=True,  # a file whose only item is "here": done at once, as Rover
        )
    except FormatError as exc:
        raise ConfigFileError(path, exc.problems) from None
    msn = conv.mission
    if limits is not None:  # the YAML loader's context checks (range) run on the result too
        try:
            msn = Mission.model_validate(msn.model_dump(), context={"limits": limits})
        except ValidationError as exc:
            raise ConfigFileError(path, format_validation_error(path, exc, Mission)) from None
    return LoadedMission(msn, fmt, conv.notes, gcs)


def forced_mode(
    msn: Mission, mode: MotionMode, config_media_map: bool = False
) -> tuple[Mission, str]:
    """A YAML mission ``check`` or ``run`` flies wholly in ``mode`` (``--mode``): its mode,
    every waypoint's and no media plan (its ``media_map``/``media_modes`` dropped; the caller
    drops the config's ``media.media_map`` when ``config_media_map``). The note says what the
    flag replaced, once ("" when nothing)."""
    pinned = [w for w in msn.waypoints if w.mode is not None and w.mode is not mode]
    replaced = [f"mode ({msn.mode.value})"] if msn.mode is not mode else []
    replaced += [f"waypoints' own modes ({len(pinned)})"] if pinned else []
    if msn.media_map is not None or config_media_map:
        replaced.append("media map (the mode follows no medium)")
    forced = msn.model_copy(
        update={
            "mode": mode,
            "waypoints": tuple(
                w.model_copy(update={"mode": None}) if w.mode is not None else w
                for w in msn.waypoints
            ),
            "media_map": None,
            "media_modes": None,
        }
    )
    if not replaced:
        return forced, ""
    return forced, (
        f"--mode {mode.value} wins over the mission's {' and '.join(replaced)}: every leg is "
        f"flown in {mode.value}"
    )


def mission_to_yaml(mission: Mission) -> str:
    """The mission as helixd YAML (loads back equal)."""
    data = mission.model_dump(mode="json", exclude_none=True, exclude_defaults=False)
    data["waypoints"] = [entry_yaml(wp) for wp in mission.waypoints]
    for key in ("geofence_polygon",):
        if not data.get(key):
            data.pop(key, None)
        else:
            data[key] = [list(v) for v in data[key]]
    if not data.get("keep_out_polygons"):
        data.pop("keep_out_polygons", None)
    else:
        data["keep_out_polygons"] = [[list(v) for v in p] for p in data["keep_out_polygons"]]
    if "home" in data:
        data["home"] = list(data["home"])
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=None)


def rebased_media_map(mission: Mission, src: Path, dst: Path) -> Mission:
    """``mission`` (read from ``src``) to be written to ``dst``: a relative ``media_map`` —
    relative to the mission file's folder — made relative to ``dst``'s folder, so the copy
    names the same map."""
    if mission.media_map is None or mission.media_map.is_absolute():
        return mission
    target = (src.parent / mission.media_map).resolve()
    moved = Path(os.path.relpath(target, dst.parent.resolve()))
    return mission.model_copy(update={"media_map": moved})


def lost_in(mission: Mission, fmt: MissionFormat, *, had_mode: bool = True) -> list[str]:
    """What of ``mission`` the format cannot hold (said when converting); ``had_mode``: the
    mode came from a helixd mission (a ground-station source has none to lose)."""
    if fmt is MissionFormat.YAML:
        return []
    lost = ["mode"] if had_mode else []
    lost += ["tolerance_m"] if mission.tolerance_m is not None else []
    lost += ["speed_mps"] if mission.speed_mps is not None else []
    lost += ["geofence_radius_m"] if mission.geofence_radius_m is not None else []
    lost += ["ground"] if mission.ground is not None else []
    if fmt is MissionFormat.WAYPOINTS:  # a .plan keeps them in its "helixd" key
        lost += ["time_limit_s"] if mission.time_limit_s is not None else []
        lost += ["media_map"] if mission.media_map is not None else []
    if any(w.heading_deg is not None or w.tolerance_m is not None for w in mission.waypoints):
        lost.append("per-waypoint heading_deg/tolerance_m")
    if any(w.mode is not None for w in mission.waypoints):
        lost.append("per-waypoint mode")
    lost += ["media_modes"] if mission.media_modes is not None else []
    if fmt is MissionFormat.WAYPOINTS:
        lost += ["geofence_polygon"] if mission.geofence_polygon else []
        lost += ["keep_out_polygons"] if mission.keep_out_polygons else []
    return lost


def write_mission_file(
    mission: Mission, path: Path, home: tuple[float, float, float] | None = None
) -> MissionFormat:
    """Write ``mission`` in the format ``path``'s suffix names (atomic replace); ``home``
    (lat, lon, alt) for a ground-station file: the source file's, else waypoint 1's place."""
    fmt = detect_format(path)
    if fmt is MissionFormat.YAML:
        text = mission_to_yaml(mission)
    elif fmt is MissionFormat.PLAN:
        text = plan_to_text(mission_to_items(mission, home), mission.speed_mps)
    else:
        text = wpl_to_text(mission_to_items(mission, home))
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    tmp.replace(path)
    return fmt


def source_home(gcs: GcsMission | None) -> tuple[float, float, float] | None:
    """A ground-station file's home (lat, lon, alt; alt 0 when it had none), to keep when the
    mission is written to another one; None when it had no home (or is not such a file)."""
    if gcs is None or gcs.home_latlon_deg is None:
        return None
    alt = gcs.home_alt_m if gcs.home_alt_m is not None and math.isfinite(gcs.home_alt_m) else 0.0
    return gcs.home_latlon_deg[0], gcs.home_latlon_deg[1], alt


def has_keep_outs(path: Path) -> bool:
    """Whether a mission file is a .plan with exclusion polygons or circles in its geofence."""
    if sniff_format(path) is not MissionFormat.PLAN:
        return False
    return fence_has_keep_outs(read_gcs(path))


def fence_has_keep_outs(fence: GcsMission | None) -> bool:
    """Whether a fence has exclusion polygons or circles (keep-outs to plan around)."""
    if fence is None:
        return False
    return any(not p.inclusion for p in fence.polygons) or any(
        not c.inclusion for c in fence.circles
    )


def plan_fence_ne(path: Path, origin_latlon_deg: tuple[float, float]) -> FenceNe:
    """The geofence of a .plan (or .waypoints: none) as plain north/east polygons and circles
    around the EKF origin — keep-out obstacles for a planner, keep-in boundaries."""
    return fence_ne(read_gcs(path), origin_latlon_deg)


def read_fence(path: Path) -> GcsMission:
    """A fence where operators keep one: a ``.plan``'s geoFence (its mission items are not
    read as a mission) or a Mission Planner fence file (QGC WPL 110 rows of commands
    5000-5004). FormatError naming the file."""
    fmt = sniff_format(path)
    try:
        text = read_text_capped(path).removeprefix("\ufeff")
    except YamlFileError as exc:
        raise FormatError([exc.message.replace("YAML file", "fence file")]) from None
    if fmt is MissionFormat.PLAN:
        gcs = parse_plan_text(text, path)
        fence = GcsMission(items=(), polygons=gcs.polygons, circles=gcs.circles)
    elif fmt is MissionFormat.WAYPOINTS:
        fence = parse_wpl_fence_text(text, path)
    elif _old_text_kind(path) == "fence":
        fence = parse_point_fence_text(text, path)
    else:
        raise FormatError(
            [
                f"{path}: a fence is a .plan (its geoFence), a Mission Planner fence file "
                "(.waypoints/.txt, QGC WPL 110 with commands 5000-5004) or MAVProxy's lat/lon "
                "list (.txt)"
            ]
        )
    if not fence.polygons and not fence.circles:
        raise FormatError([f"{path}: holds no fence polygon or circle"])
    return fence


def with_fence(
    loaded: LoadedMission, fence: GcsMission, source: str, *, route_keep_outs: bool = False
) -> LoadedMission:
    """The mission with a fence file's shapes: its one inclusion polygon (or circle) becomes
    the mission's keep-in fence (replacing the mission's own, said in a note), its exclusion
    zones are refused around the waypoints (and the legs, unless planned around) and kept for
    the planner. Only a global (lat/lon) mission can be fenced by lat/lon shapes."""
    msn = loaded.mission
    if msn.frame is not MissionFrameKind.GLOBAL:
        raise FormatError(
            [
                f"--fence {source}: the fence is latitude/longitude; mission {msn.name!r} is in "
                f"the '{msn.frame.value}' frame (use safety.geofence_polygon_ne_m / "
                "planning.keep_out_* for north/east shapes, or a global mission)"
            ]
        )
    notes = list(loaded.notes)
    keep_in, why_none = keep_in_of(fence)
    if why_none:
        notes.append(
            f"--fence {source}: {why_none}: none used as the keep-in fence (helixd keeps one)"
        )
    points = msn.points()
    labels = [as_items(entry_label(msn.waypoints.index(wp))) for wp in msn.places()]
    problems = keep_out_problems(fence, points, labels, legs=not route_keep_outs)
    if problems:
        raise FormatError([f"--fence {source}: {p}" for p in problems[:20]])
    if keep_in:
        if msn.geofence_polygon:
            notes.append(f"--fence {source}: its inclusion polygon replaces the mission's own")
        try:
            msn = Mission.model_validate(
                {**msn.model_dump(), "geofence_polygon": [list(v) for v in keep_in]}
            )
        except ValidationError as exc:
            raise FormatError(format_validation_error(source, exc, Mission)) from None
    own = loaded.gcs
    merged = GcsMission(
        items=own.items if own is not None else (),
        home_latlon_deg=own.home_latlon_deg if own is not None else None,
        polygons=(*(own.polygons if own is not None else ()), *fence.polygons),
        circles=(*(own.circles if own is not None else ()), *fence.circles),
        survey_polygons=own.survey_polygons if own is not None else (),
    )
    return LoadedMission(msn, loaded.format, tuple(notes), merged)


__all__ = [
    "LoadedMission",
    "MissionFormat",
    "detect_format",
    "fence_has_keep_outs",
    "forced_mode",
    "has_keep_outs",
    "load_mission_file",
    "lost_in",
    "mission_to_yaml",
    "plan_fence_ne",
    "read_fence",
    "read_gcs",
    "rebased_media_map",
    "sniff_format",
    "source_home",
    "with_fence",
    "write_mission_file",
]
