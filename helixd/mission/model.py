"""Mission files (``config/missions/*.yaml``): what to fly, in which mode and frame.

Frames (see :mod:`helixd.base.frames`):

* ``start``: waypoints as ``x``/``y`` metres, x forward and y left of the pose at mission
  start; ``heading_deg`` counter-clockwise from the start heading.
* ``local_ned``: waypoints as ``north``/``east`` metres from the EKF origin; ``heading_deg`` is a
  compass heading (clockwise from North).
* ``global``: waypoints as ``lat``/``lon`` degrees; ``heading_deg`` compass, as above.

Mission-level safety overrides (a survey writes them): ``geofence_polygon`` (vertices in the
mission's own coordinates) replaces the config's keep-in polygon and radius,
``geofence_radius_m`` a radius, ``time_limit_s`` the time limit, ``gps_min_fix`` (``rtk_float``
or ``rtk_fixed``) raises ``safety.gps_min_fix_type`` for precision work, and ``ground`` the
ground it crosses (``control.slip.ground_*_fraction``) — see
:func:`helixd.mission.validate.apply_mission_limits`. Ground-station files (.plan, .waypoints)
are read into this model by :mod:`helixd.mission.formats`.

Commands: the ``waypoints`` list is ArduPilot's mission item list (as Mission Planner's
"waypoints" are): an entry without ``command`` is a NAV_WAYPOINT; with one it may be any
mission command, its parameters named as :mod:`helixd.mission.commands` lists them
(``{command: DO_CHANGE_SPEED, speed_mps: 0.3}``, ``{command: DO_SET_SERVO, channel: 9,
pwm_us: 1900}``, ``{command: DO_JUMP, item: 2, repeat: 1}``) or given as ``params: [p1, …]``.
A navigation entry without coordinates stays where the rover is when it starts (ArduPilot's
lat/lon 0, 0). ``z``, ``frame`` and ``autocontinue`` keep what a ground station wrote, so its
files convert both ways without loss. Entries are numbered from 1, as a ground station numbers
them (ArduPilot's item 0 is home); ``DO_JUMP``'s ``item`` counts the same way.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path
from typing import Any, Literal

from pydantic import Field, ValidationInfo, model_validator

from helixd.base.frames import latlon_to_ne
from helixd.base.media import Medium
from helixd.base.plan import MissionFrameKind, MotionMode
from helixd.base.polygon import polygon_problems
from helixd.config.mission import MissionLimits
from helixd.config.safety import GEOFENCE_RADIUS_MAX_M
from helixd.files.models import InputModel, entry_label, load_yaml_model
from helixd.files.yamlio import clip
from helixd.mav.constants import MAV_CMD_NAV_WAYPOINT
from helixd.mission.commands import (
    FLY_ROLES,
    MAX_PARAMS,
    CommandSpec,
    ParamSpec,
    command_name,
    command_number,
    command_spec,
)

DUPLICATE_EPSILON_M = 0.01  # consecutive points closer than this are the same point


_ALL_COORDS = ("x", "y", "north", "east", "lat", "lon")
_COORDS = {
    MissionFrameKind.START: ("x", "y"),
    MissionFrameKind.LOCAL_NED: ("north", "east"),
    MissionFrameKind.GLOBAL: ("lat", "lon"),
}


_NOT_PARAMS = frozenset(
    {"command", "params", "x", "y", "north", "east", "lat", "lon", "z", "frame", "autocontinue",
     "heading_deg", "tolerance_m", "via", "mode"}
)  # fmt: skip


# every entry's own keys, in the order an operator reads them (the place: one pair of them)
ENTRY_KEYS = (
    "x", "y", "north", "east", "lat", "lon", "z", "heading_deg", "tolerance_m", "via", "mode",
    "command", "params", "frame", "autocontinue",
)  # fmt: skip


def unknown_key_hint(key: str, spec: CommandSpec) -> str:
    """What an entry takes: its own keys and the command's named parameters, the nearest
    first when the key looks like a misspelling of one."""
    allowed = [p.name for p in spec.params if p is not None]
    near = difflib.get_close_matches(key, [*ENTRY_KEYS, *allowed], n=1)
    named = (
        f"{spec.name} also takes {', '.join(allowed)}"
        if allowed
        else f"{spec.name} has no named parameters: give params: [p1, p2, …]"
    )
    return (
        f"did you mean {near[0]}? " if near else ""
    ) + f"an entry takes {', '.join(ENTRY_KEYS)}; {named}"


def _named_params(data: dict[str, Any], spec: CommandSpec) -> dict[str, Any]:
    """An entry's named parameters (``hold_s``, ``channel``, …) → ``params`` [p1, …]; every
    value checked here, at the edge: a number (or null: unset), finite, in its range."""
    named = {k: v for k, v in data.items() if k not in _NOT_PARAMS}
    if not named:
        return data
    out = {k: v for k, v in data.items() if k in _NOT_PARAMS}
    if "params" in data:
        raise ValueError(
            f"give {spec.name}'s parameters by name or as params, not both "
            f"(got params and {', '.join(sorted(named))})"
        )
    values: list[float | None] = list(spec.defaults())
    for key, value in named.items():
        found = spec.param(key)
        if found is None:
            raise ValueError(f"{key}: unknown key ({unknown_key_hint(key, spec)})")
        index, pspec = found
        if value is None:
            values[index] = None
            continue
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{key}: expected a number, got {clip(value)}")
        v = float(value)
        if not (math.isfinite(v) and pspec.lo <= v <= pspec.hi):
            raise ValueError(f"{key}: {clip(value)} is outside {pspec.lo:g} .. {pspec.hi:g}")
        if pspec.whole and v != int(v):
            raise ValueError(f"{key}: {clip(value)} must be a whole number (ArduPilot keeps one)")
        values[index] = v
    out["params"] = values
    return out


def _whole(value: float | None, pspec: ParamSpec | None) -> float | int | None:
    """A parameter ArduPilot stores as an integer, written as one when it is whole."""
    if value is None or pspec is None or not pspec.whole:
        return value
    return int(value) if math.isfinite(value) and value == int(value) else value


def entry_yaml(wp: WaypointSpec) -> dict[str, Any]:
    """An entry as the YAML format writes it (loads back equal): the command by name (not
    for a NAV_WAYPOINT with a place), its parameters by name where every non-default one has
    a name (else ``params``), and only what differs from the defaults."""
    out: dict[str, Any] = {}
    if wp.command != MAV_CMD_NAV_WAYPOINT or not wp.given():
        out["command"] = wp.name if wp.name == command_name(wp.command) else wp.command
        if out["command"].startswith("command "):
            out["command"] = wp.command
    for key in ("x", "y", "north", "east", "lat", "lon", "heading_deg", "tolerance_m"):
        value = getattr(wp, key)
        if value is not None:
            out[key] = value
    if wp.params is not None:
        spec = wp.spec
        defaults = spec.defaults()
        named: dict[str, float | None] = {}
        by_name = True
        for i, value in enumerate(wp.params):
            default = defaults[i] if i < len(defaults) else 0.0
            if value == default or (value is None and default is None):
                continue
            pspec = spec.params[i] if i < len(spec.params) else None
            if pspec is None:
                by_name = False
                break
            named[pspec.name] = _whole(value, pspec)
        if by_name:
            out.update(named)
        else:
            out["params"] = [
                _whole(v, spec.params[i] if i < len(spec.params) else None)
                for i, v in enumerate(wp.params)
            ]
    if wp.z is not None:
        out["z"] = wp.z
    if wp.frame is not None:
        out["frame"] = wp.frame
    if not wp.autocontinue:
        out["autocontinue"] = False
    if wp.via:
        out["via"] = True
    if wp.mode is not None:
        out["mode"] = wp.mode.value
    return out


class WaypointSpec(InputModel):
    """One mission item: a place to go (NAV_WAYPOINT, the default) or a command."""

    command: int = Field(
        MAV_CMD_NAV_WAYPOINT,
        ge=0,
        le=65535,
        description="MAVLink command, by name (NAV_WAYPOINT, DO_SET_SERVO, …) or number",
    )
    x: float | None = Field(None, description="metres forward of the start pose (start frame)")
    y: float | None = Field(None, description="metres left of the start pose (start frame)")
    north: float | None = Field(None, description="metres north of the EKF origin (local_ned)")
    east: float | None = Field(None, description="metres east of the EKF origin (local_ned)")
    lat: float | None = Field(None, ge=-90.0, le=90.0, description="latitude, degrees (global)")
    lon: float | None = Field(None, ge=-180.0, le=180.0, description="longitude, degrees (global)")
    heading_deg: float | None = Field(
        None, ge=-360.0, le=360.0, description="optional final heading at this waypoint (deg)"
    )
    tolerance_m: float | None = Field(
        None, gt=0.05, le=20.0, description="per-waypoint arrival radius override (m)"
    )
    via: bool = Field(
        False,
        description="an intermediate point the planner inserted on the way to the next "
        "waypoint, not one of the operator's waypoints (not numbered or counted as one)",
    )
    mode: MotionMode | None = Field(
        None,
        description="the motion mode of the leg to this place, whatever the media map says "
        "(None: the medium's mode with a media map, else the mission's mode)",
    )
    params: tuple[float | None, ...] | None = Field(
        None,
        max_length=MAX_PARAMS,
        description="the command's param1.. as MAVLink numbers them (null: unset); None: the "
        "command's defaults. Written by name in YAML where the command has names",
    )
    z: float | None = Field(
        None, ge=-1e6, le=1e6, description="altitude (m) or param7; a rover ignores it"
    )
    frame: int | None = Field(
        None, ge=0, le=255, description="MAVLink frame a ground station gave it (kept)"
    )
    autocontinue: bool = Field(True, description="ground-station flag (kept; ArduPilot ignores)")

    @model_validator(mode="before")
    @classmethod
    def _by_name(cls, data: Any) -> Any:
        if not isinstance(data, dict):
            return data
        if "command" not in data:
            for key in data:
                if key not in _NOT_PARAMS:
                    break
            else:
                return data  # fast path: a waypoint without named parameters
        else:
            data = {**data, "command": command_number(data["command"])}
        spec = command_spec(int(data.get("command", MAV_CMD_NAV_WAYPOINT)))
        return _named_params(data, spec)

    @model_validator(mode="after")
    def _fits_command(self) -> WaypointSpec:
        if self.command == MAV_CMD_NAV_WAYPOINT and self.params is None:
            return self  # fast path
        spec = command_spec(self.command)
        if self.params is not None:
            size = 4 if spec.has_place else MAX_PARAMS
            if len(self.params) > size:
                raise ValueError(
                    f"params: {spec.name} has {size} parameters before its "
                    f"{'place' if spec.has_place else 'x/y'}; got {len(self.params)}"
                )
            bad = [v for v in self.params if v is not None and not math.isfinite(v)]
            if bad:
                raise ValueError("params: must be finite numbers or null")
        if not spec.has_place and self.given():
            raise ValueError(
                f"{sorted(self.given())}: {spec.name} has no place (give its x/y as params)"
            )
        if spec.role not in FLY_ROLES:
            if self.heading_deg is not None or self.tolerance_m is not None:
                raise ValueError(
                    f"heading_deg/tolerance_m: only for a place to go, not {spec.name}"
                )
            if self.mode is not None:
                raise ValueError(f"mode: only for a place to go, not {spec.name}")
        return self

    def given(self) -> set[str]:
        return {
            k for k in ("x", "y", "north", "east", "lat", "lon") if getattr(self, k) is not None
        }

    @property
    def spec(self) -> CommandSpec:
        return command_spec(self.command)

    @property
    def name(self) -> str:
        return command_name(self.command)

    def param(self, index: int) -> float:
        """param1.. (0-based ``index``): the value, the command's default, NaN when unset."""
        values = self.params if self.params is not None else self.spec.defaults()
        if index >= len(values):
            return 0.0
        v = values[index]
        return math.nan if v is None else v

    def is_plain(self) -> bool:
        """A NAV_WAYPOINT with a place and nothing else to do (no hold)."""
        if self.command != MAV_CMD_NAV_WAYPOINT:
            return False
        d = self.__dict__  # plain attribute reads: called once per waypoint of big missions
        placed = (d["x"] is not None or d["north"] is not None or d["lat"] is not None) and (
            d["y"] is not None or d["east"] is not None or d["lon"] is not None
        )
        return placed and (self.params is None or not self.param(0) > 0.0)


class GroundSpec(InputModel):
    """The ground a mission crosses: the fraction of the no-slip (eq. 1) motion it delivers,
    per body axis. Replaces ``control.slip.ground_*_fraction`` for the run: the slip estimate
    starts from it and the time estimate counts it."""

    roll_fraction: float = Field(
        1.0, gt=0.0, le=1.0, description="delivered along the roll axis (1)"
    )
    scroll_fraction: float = Field(
        1.0, gt=0.0, le=1.0, description="delivered along the scroll axis (1)"
    )
    yaw_fraction: float = Field(1.0, gt=0.0, le=1.0, description="delivered yaw rate (1)")


class Mission(InputModel):
    name: str = Field(min_length=1, max_length=80, pattern=r"^[A-Za-z0-9_.\- ]+$")
    mode: MotionMode
    frame: MissionFrameKind = MissionFrameKind.START
    waypoints: tuple[WaypointSpec, ...] = Field(
        description="the mission items in order: places to go, and commands between them; at "
        "least one place"
    )
    tolerance_m: float | None = Field(
        None, gt=0.05, le=20.0, description="arrival radius for every waypoint (m)"
    )
    speed_mps: float | None = Field(None, gt=0.0, le=3.0, description="speed cap override (m/s)")
    # Mission-level safety overrides (a survey carries its own fence and time budget):
    geofence_polygon: tuple[tuple[float, float], ...] = Field(
        (),
        max_length=1000,
        description="keep-in polygon in the mission's own coordinates (x/y, north/east or "
        "lat/lon pairs); replaces safety.geofence_polygon_ne_m and safety.geofence_radius_m",
    )
    geofence_radius_m: float | None = Field(
        None,
        gt=0.0,
        le=GEOFENCE_RADIUS_MAX_M,
        description="with geofence_polygon: also a radius around the start point (None = the "
        "polygon alone); without: replaces safety.geofence_radius_m (None = the config's)",
    )
    time_limit_s: float | None = Field(
        None, gt=0.0, le=86_400.0, description="replaces safety.mission_time_limit_s (s)"
    )
    gps_min_fix: Literal["rtk_float", "rtk_fixed"] | None = Field(
        None,
        description="a precision mission's GPS minimum: raises safety.gps_min_fix_type to RTK "
        "float (5) or RTK fixed (6); never lowers it",
    )
    ground: GroundSpec | None = Field(
        None,
        description="the ground it crosses (roll_fraction, scroll_fraction, yaw_fraction); "
        "replaces control.slip.ground_*_fraction",
    )
    keep_out_polygons: tuple[tuple[tuple[float, float], ...], ...] = Field(
        (),
        max_length=1000,
        description="areas the rover must not enter (islands, exclusion zones), each a polygon "
        "in the mission's own coordinates (north/east or lat/lon pairs; not in the start "
        "frame): legs are planned around them, a waypoint inside one is refused",
    )
    media_map: Path | None = Field(
        None,
        description="media map (GeoJSON/KML) of where it goes, relative to the mission file; "
        "replaces media.media_map of the config: each stretch is flown in its medium's mode",
    )
    media_modes: dict[Medium, MotionMode] | None = Field(
        None,
        description="the mode per medium for this mission (hard, grass, sand, mud, water); "
        "replaces those entries of media.modes",
    )
    home: tuple[float, float] | None = Field(
        None,
        description="where the mission was planned to start (the ground station's home, in "
        "the mission's own coordinates): NAV_RETURN_TO_LAUNCH goes there in `check`; a run "
        "returns to the autopilot's own home (HOME_POSITION)",
    )
    home_alt_m: float | None = Field(
        None,
        ge=-1e6,
        le=1e6,
        description="the home's altitude (m) from the ground station, kept so a conversion "
        "back writes it; a rover ignores it",
    )

    @model_validator(mode="after")
    def _check_points(self, info: ValidationInfo) -> Mission:
        if not self.waypoints:
            raise ValueError("waypoints: the list is empty; a mission needs at least one waypoint")
        wanted = _COORDS[self.frame]
        ka, kb = wanted
        o1, o2, o3, o4 = (k for k in _ALL_COORDS if k not in wanted)
        for i, wp in enumerate(self.waypoints):
            d = wp.__dict__  # plain attribute reads: this loop runs once per waypoint
            if (
                d[ka] is not None
                and d[kb] is not None
                and d[o1] is None
                and d[o2] is None
                and d[o3] is None
                and d[o4] is None
            ):
                continue
            got = wp.given()
            if not got and wp.command != MAV_CMD_NAV_WAYPOINT:
                continue  # a command without a place, or a navigation item that stays put
            if not got and (wp.params is not None or "command" in wp.model_fields_set):
                continue  # a NAV_WAYPOINT that stays where it starts (e.g. a hold)
            if got != set(wanted):
                raise ValueError(
                    f"{entry_label(i)}: frame '{self.frame.value}' needs exactly "
                    f"{wanted[0]} and {wanted[1]}, got {sorted(got) or 'no coordinates'}"
                )
        if not self.places():
            raise ValueError(
                "waypoints: no entry has a place to go (a navigation item without coordinates "
                "stays where the rover is): nothing to fly"
            )
        is_global = self.frame is MissionFrameKind.GLOBAL
        hypot = math.hypot
        wps = self.waypoints
        key_a, key_b = _COORDS[self.frame]
        for i in range(1, len(wps)):
            prev, here = wps[i - 1], wps[i]
            if not (prev.is_plain() and here.is_plain()):
                continue  # a hold, a command between: ArduPilot's "reached at once" is fine
            a0, a1 = getattr(prev, key_a), getattr(prev, key_b)
            b0, b1 = getattr(here, key_a), getattr(here, key_b)
            if is_global:
                dn, de = latlon_to_ne(b0, b1, a0, a1)
                gap = hypot(dn, de)
            else:
                gap = hypot(b0 - a0, b1 - a1)
            if gap < DUPLICATE_EPSILON_M:
                raise ValueError(
                    f"{entry_label(i)}: same point as waypoint {i} "
                    f"({b0}, {b1}); consecutive waypoints must differ by >= "
                    f"{DUPLICATE_EPSILON_M} m"
                )
        if self.home is not None and is_global:
            lat, lon = self.home
            if not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
                raise ValueError(f"home: ({lat}, {lon}) is not a latitude/longitude pair")
        if self.home_alt_m is not None and self.home is None:
            raise ValueError("home_alt_m: given without a home")
        fence_problems = self.fence_problems()
        if fence_problems:
            raise ValueError("\n".join(f"geofence_polygon: {p}" for p in fence_problems))
        keep_out_problems = self.keep_out_problems()
        if keep_out_problems:
            raise ValueError("\n".join(keep_out_problems))
        limits = (info.context or {}).get("limits") if info.context else None
        if isinstance(limits, MissionLimits) and self.frame is not MissionFrameKind.GLOBAL:
            for i, wp in enumerate(wps):
                if getattr(wp, key_a) is None or getattr(wp, key_b) is None:
                    continue
                a, b = float(getattr(wp, key_a)), float(getattr(wp, key_b))
                rng = math.hypot(a, b)
                if rng > limits.max_range_m:
                    raise ValueError(
                        f"{entry_label(i)}: ({a}, {b}) is {rng:.1f} m from the origin; "
                        f"allowed at most mission.max_range_m = {limits.max_range_m} m"
                    )
        return self

    def keep_out_problems(self) -> list[str]:
        """Why ``keep_out_polygons`` cannot be used (empty when absent or usable)."""
        if not self.keep_out_polygons:
            return []
        if self.frame is MissionFrameKind.START:
            return [
                "keep_out_polygons: a start-frame mission moves with the rover; keep-out areas "
                "need a local_ned or global mission"
            ]
        out: list[str] = []
        for i, poly in enumerate(self.keep_out_polygons):
            if len(poly) > 1000:
                out.append(f"keep_out_polygons.{i}: {len(poly)} vertices; allowed at most 1000")
                continue
            out.extend(f"keep_out_polygons.{i}: {p}" for p in self._ring_problems(poly))
        return out[:5]

    def keep_outs_ne(
        self, origin_latlon_deg: tuple[float, float] | None = None
    ) -> list[tuple[tuple[float, float], ...]]:
        """``keep_out_polygons`` as (north_m, east_m) polygons: as written (``local_ned``), or
        around ``origin_latlon_deg`` (``global``; default: waypoint 0)."""
        if self.frame is not MissionFrameKind.GLOBAL:
            return [tuple(p) for p in self.keep_out_polygons]
        origin = origin_latlon_deg or self.points()[0]
        return [
            tuple(latlon_to_ne(a, b, *origin) for a, b in poly) for poly in self.keep_out_polygons
        ]

    def fence_problems(self) -> list[str]:
        """Why ``geofence_polygon`` cannot fence anything (empty when absent or usable)."""
        return self._ring_problems(self.geofence_polygon)

    def _ring_problems(self, poly: tuple[tuple[float, float], ...]) -> list[str]:
        """Why ``poly`` (mission coordinates) is no usable polygon (empty: none or usable)."""
        if not poly:
            return []
        if self.frame is MissionFrameKind.GLOBAL:
            bad = [
                f"vertex {i} ({a}, {b}) is not a latitude/longitude pair (-90..90, -180..180)"
                for i, (a, b) in enumerate(poly)
                if not (-90.0 <= a <= 90.0 and -180.0 <= b <= 180.0)
            ]
            if bad:
                return bad[:3]
            lat0, lon0 = poly[0]
            plane = [latlon_to_ne(a, b, lat0, lon0) for a, b in poly]
        else:
            plane = list(poly)
        return polygon_problems(plane)

    def places(self) -> list[WaypointSpec]:
        """The entries that are places to go (NAV_WAYPOINT, loiters) with coordinates."""
        a = _COORDS[self.frame][0]
        return [
            w
            for w in self.waypoints
            if getattr(w, a) is not None
            and (w.command == MAV_CMD_NAV_WAYPOINT or w.spec.role in FLY_ROLES)
        ]

    def points(self) -> list[tuple[float, float]]:
        """The places' raw coordinate pairs in the file's own frame: (x, y), (north, east) or
        (lat, lon), in item order (jumps, returns and commands are the program's business)."""
        a, b = _COORDS[self.frame]
        return [(float(getattr(w, a)), float(getattr(w, b))) for w in self.places()]

    def position(self, wp: WaypointSpec) -> tuple[float, float] | None:
        """An entry's coordinate pair in the file's own frame, None when it has none."""
        a, b = _COORDS[self.frame]
        va, vb = getattr(wp, a), getattr(wp, b)
        return None if va is None or vb is None else (float(va), float(vb))

    def has_commands(self) -> bool:
        """Anything beyond plain waypoints: a command, a hold, a place-less entry."""
        return not all(w.is_plain() for w in self.waypoints)


def coordinate_keys(frame: MissionFrameKind) -> tuple[str, str]:
    """The two coordinate keys of a frame: ("x", "y"), ("north", "east") or ("lat", "lon")."""
    return _COORDS[frame]


def load_mission(path: Path | str, limits: MissionLimits | None = None) -> Mission:
    """Load and validate a mission file; raises ConfigFileError with one line per problem."""
    return load_yaml_model(path, Mission, context={"limits": limits or MissionLimits()})


__all__ = [
    "GroundSpec",
    "Mission",
    "WaypointSpec",
    "coordinate_keys",
    "entry_yaml",
    "load_mission",
]
