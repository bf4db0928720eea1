"""What each medium delivers in each motion mode, identified from a flight's record. Pure.

The slip estimate (:mod:`helixd.control.slip`) follows the ground under the rover with a
memory of seconds, per mode; this module answers the question a crew asks after a survey:
*per medium and per mode*, what fraction of the no-slip (eq. 1) motion did the ground
deliver, how sure is that, and what did each metre cost. Its input is what ``flight.csv``
holds on any rover (the pose, the four scroll commands sent, the motion mode) and a media
map; nothing of the simulator.

Per row i of the record (autopilot time t_i):

* the no-slip body velocity the scrolls were commanded, u_i = J · ω_i with ω_i = f_i · ω_max
  (eq. 1, f the four signed scroll fractions sent, the feed-forward included), low-passed by
  the scrolls' response lag τ (``lag_s``): ū_i = ū_{i−1} + (u_i − ū_{i−1}) (1 − e^{−Δt/τ});
* the measured body velocity y_i: the pose's central difference over ± ``half_window_s``,
  rotated into the body frame (x forward, y left; the yaw rate counter-clockwise);
* the medium: the map's medium under all four scroll centres (±l_x, ±l_y); a row whose scrolls
  stand in different media teaches nothing (it is a blend).

Per medium m, mode k and axis a (roll = v_x, scroll = v_y, yaw = ω_z), the delivered fraction
is the least-squares fit through the origin of y = κ · ū over the rows that teach, each
weighted by its Δt:

    κ = Σ ū·y Δt / Σ ū² Δt

A row teaches axis a when |ū_a| is at least ``min_speed_mps`` (``min_yaw_rate_radps``) and
the command is steady (|u_a − ū_a| ≤ ``steady_tolerance`` · |ū_a|): turning in place teaches
no translation, and while the command changes the response lag, not the ground, shows. The
uncertainty is the fit's standard error with the residuals counted once per
``correlation_s`` (the pose's errors are correlated over about a second, not independent at
50 Hz):

    σ_κ² = (Σ y² Δt − κ Σ ū·y Δt) / Σ Δt · correlation_s / Σ ū² Δt

The power per m/s is the energy per metre, E / d: E = Σ P_i Δt with P_i = ``power_w`` ·
Σ_j |f_ij| (each scroll's power proportional to its rpm, the thesis's "wheel power"; the
record holds no current), d = Σ |v_i| Δt, over every row in the medium and mode.

A profile (:class:`CellSums` per medium and mode) merges runs by adding their sums, the older
ones scaled by ``fade`` first (:func:`merge_profiles`): weighted by the time each axis
taught, old data fading run by run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from helixd.base.media import MediaMapNe, Medium
from helixd.base.plan import MotionMode
from helixd.control.kinematics import forward_matrix, rpm_to_radps
from helixd.control.params import VehicleParams

FloatArray = npt.NDArray[np.float64]
AXES = ("roll", "scroll", "yaw")
# the axis a mode drives along (OMNI drives both translation axes)
DRIVEN: Mapping[MotionMode, tuple[str, ...]] = {
    MotionMode.ROLL: ("roll",),
    MotionMode.SCROLL: ("scroll",),
    MotionMode.OMNI: ("roll", "scroll"),
}
# scroll centres in units of (l_x, l_y), scrolls 1..4 (docs/physics.md, "Media maps")
SCROLL_CORNERS = ((1.0, -1.0), (-1.0, -1.0), (-1.0, 1.0), (1.0, 1.0))
MAX_RUNS = 200  # run names a cell keeps (the newest)
# What each medium delivers (roll, scroll, yaw) before the rover has learnt it: the sourced
# table (docs/physics.md, "The ground table"; the simulator's default table holds the same
# numbers, tests/control/test_ground_fit.py checks it). The time estimate counts it where the
# profile knows too little (helixd.prepare.ground_learning.with_learned_ground).
SOURCED_FRACTIONS: Mapping[Medium, tuple[float, float, float]] = {
    Medium.HARD: (0.95, 0.12, 0.85),
    Medium.GRASS: (0.9, 0.25, 0.75),
    Medium.SAND: (0.6, 0.12, 0.12),
    Medium.MUD: (0.3, 0.85, 0.55),
    Medium.WATER: (0.05, 0.62, 0.4),
}


@dataclass(frozen=True, slots=True)
class GroundFitParams:
    """How a record is read (defaults: the slip estimate's thresholds, docs/physics.md)."""

    lag_s: float = 0.3
    half_window_s: float = 0.25
    min_speed_mps: float = 0.15
    min_yaw_rate_radps: float = 0.2
    steady_tolerance: float = 0.2
    max_gap_s: float = 0.5
    correlation_s: float = 1.0
    power_w: float = 100.0  # one scroll at its max rpm (the energy's unit; not measured)


@dataclass(frozen=True, slots=True)
class AxisSums:
    """The fit's sums for one axis: Σ ū² Δt, Σ ū·y Δt, Σ y² Δt, Σ Δt and the rows."""

    s_uu: float = 0.0
    s_uy: float = 0.0
    s_yy: float = 0.0
    seconds: float = 0.0
    samples: int = 0

    def plus(self, other: AxisSums) -> AxisSums:
        return AxisSums(
            self.s_uu + other.s_uu,
            self.s_uy + other.s_uy,
            self.s_yy + other.s_yy,
            self.seconds + other.seconds,
            self.samples + other.samples,
        )

    def scaled(self, factor: float) -> AxisSums:
        """Old evidence faded by ``factor`` (the sample count is kept as it was)."""
        return AxisSums(
            self.s_uu * factor,
            self.s_uy * factor,
            self.s_yy * factor,
            self.seconds * factor,
            self.samples,
        )

    @property
    def fraction(self) -> float | None:
        """κ (None: nothing taught)."""
        if not (self.s_uu > 0.0 and self.seconds > 0.0):
            return None
        return self.s_uy / self.s_uu

    def sigma(self, correlation_s: float) -> float | None:
        """The standard error of κ (module docstring)."""
        k = self.fraction
        if k is None:
            return None
        residual = max(0.0, self.s_yy - k * self.s_uy)
        return math.sqrt(residual / self.seconds * correlation_s / self.s_uu)


@dataclass(frozen=True, slots=True)
class CellSums:
    """One medium in one mode: each axis's fit, the metres travelled, the energy spent and the
    runs it came from."""

    roll: AxisSums = AxisSums()
    scroll: AxisSums = AxisSums()
    yaw: AxisSums = AxisSums()
    metres: float = 0.0
    energy_j: float = 0.0
    runs: tuple[str, ...] = ()

    def axis(self, name: str) -> AxisSums:
        got: AxisSums = getattr(self, name)
        return got

    def plus(self, other: CellSums) -> CellSums:
        runs = self.runs + tuple(r for r in other.runs if r not in self.runs)
        runs = runs[-MAX_RUNS:]  # the newest: a profile of years of runs stays small
        return CellSums(
            self.roll.plus(other.roll),
            self.scroll.plus(other.scroll),
            self.yaw.plus(other.yaw),
            self.metres + other.metres,
            self.energy_j + other.energy_j,
            runs,
        )

    def scaled(self, factor: float) -> CellSums:
        return CellSums(
            self.roll.scaled(factor),
            self.scroll.scaled(factor),
            self.yaw.scaled(factor),
            self.metres * factor,
            self.energy_j * factor,
            self.runs,
        )

    @property
    def power_w_per_mps(self) -> float | None:
        """Energy per metre (J/m = W per m/s); None before a metre was travelled."""
        return self.energy_j / self.metres if self.metres > 0.0 else None


Cell = tuple[Medium, MotionMode]
Profile = Mapping[Cell, CellSums]


@dataclass(frozen=True, slots=True)
class Record:
    """The columns of a flight record the fit reads (one entry per control step)."""

    t_s: Sequence[float]  # autopilot time
    north_m: Sequence[float]
    east_m: Sequence[float]
    yaw_ned_rad: Sequence[float]  # clockwise from North
    scrolls: Sequence[Sequence[float]]  # per row the four signed fractions sent
    modes: Sequence[str]  # the motion mode flown ("" or unknown: not learnt from)


def _arrays(rec: Record) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    t = np.asarray(rec.t_s, dtype=np.float64)
    n = np.asarray(rec.north_m, dtype=np.float64)
    e = np.asarray(rec.east_m, dtype=np.float64)
    yaw = np.asarray(rec.yaw_ned_rad, dtype=np.float64)
    f = np.asarray(rec.scrolls, dtype=np.float64).reshape(-1, 4)
    if not len(t) == len(n) == len(e) == len(yaw) == len(f) == len(rec.modes):
        raise ValueError("a record's columns differ in length")
    return t, n, e, yaw, f


def _lagged(u: FloatArray, t: FloatArray, params: GroundFitParams) -> FloatArray:
    """The command low-passed by the scrolls' lag, restarted after a gap."""
    out = np.empty_like(u)
    for i in range(len(u)):
        dt = t[i] - t[i - 1] if i else math.inf
        if not (0.0 < dt <= params.max_gap_s) or not np.all(np.isfinite(out[i - 1])):
            out[i] = u[i]
            continue
        alpha = 1.0 if params.lag_s <= 0.0 else 1.0 - math.exp(-dt / params.lag_s)
        out[i] = out[i - 1] + (u[i] - out[i - 1]) * alpha
    return out


def _measured(
    t: FloatArray, n: FloatArray, e: FloatArray, yaw: FloatArray, half_s: float
) -> FloatArray:
    """Body velocity (v_x, v_y, ω_z CCW) by central differences over ± ``half_s``."""
    lo = np.searchsorted(t, t - half_s, side="left")
    hi = np.searchsorted(t, t + half_s, side="right") - 1
    lo = np.clip(lo, 0, len(t) - 1)
    hi = np.clip(hi, 0, len(t) - 1)
    span = t[hi] - t[lo]
    unwrapped = np.unwrap(yaw) if len(yaw) else yaw
    with np.errstate(divide="ignore", invalid="ignore"):
        vn = np.where(span > 0.0, (n[hi] - n[lo]) / span, np.nan)
        ve = np.where(span > 0.0, (e[hi] - e[lo]) / span, np.nan)
        wz = np.where(span > 0.0, -(unwrapped[hi] - unwrapped[lo]) / span, np.nan)
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([vn * c + ve * s, vn * s - ve * c, wz], axis=1)


def _media(
    n: FloatArray, e: FloatArray, yaw: FloatArray, media: MediaMapNe, vehicle: VehicleParams
) -> list[Medium | None]:
    """Per row the medium under all four scrolls, None where they differ."""
    out: list[Medium | None] = []
    for north, east, psi in zip(n, e, yaw, strict=True):
        if not (math.isfinite(north) and math.isfinite(east) and math.isfinite(psi)):
            out.append(None)
            continue
        c, s = math.cos(psi), math.sin(psi)
        seen = set()
        for fx, fy in SCROLL_CORNERS:
            x, y = fx * vehicle.lx_m, fy * vehicle.ly_m
            seen.add(media.medium_at(north + x * c + y * s, east + x * s - y * c))
        out.append(seen.pop() if len(seen) == 1 else None)
    return out


def identify(
    rec: Record,
    media: MediaMapNe,
    vehicle: VehicleParams,
    params: GroundFitParams = GroundFitParams(),
    run: str = "",
) -> dict[Cell, CellSums]:
    """Per medium and mode flown, the fit's sums from one record (module docstring)."""
    t, n, e, yaw, f = _arrays(rec)
    if len(t) < 2:
        return {}
    omega = np.nan_to_num(f, nan=0.0) * rpm_to_radps(vehicle.max_rpm)
    u = omega @ forward_matrix(vehicle.scroll_radius_m, vehicle.lx_m, vehicle.ly_m).T
    lag = _lagged(u, t, params)
    y = _measured(t, n, e, yaw, params.half_window_s)
    media_rows = _media(n, e, yaw, media, vehicle)
    dts = np.diff(t, prepend=t[0])
    least = (params.min_speed_mps, params.min_speed_mps, params.min_yaw_rate_radps)
    sums: dict[Cell, dict[str, object]] = {}
    for i in range(1, len(t)):
        dt = float(dts[i])
        medium = media_rows[i]
        if medium is None or not (0.0 < dt <= params.max_gap_s):
            continue
        try:
            mode = MotionMode(rec.modes[i])
        except ValueError:
            continue
        if not (np.all(np.isfinite(y[i])) and np.all(np.isfinite(lag[i]))):
            continue
        cell = sums.setdefault((medium, mode), {"metres": 0.0, "energy_j": 0.0})
        speed = math.hypot(float(y[i, 0]), float(y[i, 1]))
        cell["metres"] = float(cell["metres"]) + speed * dt  # type: ignore[arg-type]
        power = params.power_w * float(np.sum(np.abs(np.nan_to_num(f[i], nan=0.0))))
        cell["energy_j"] = float(cell["energy_j"]) + power * dt  # type: ignore[arg-type]
        for a, name in enumerate(AXES):
            ub, un, ym = float(lag[i, a]), float(u[i, a]), float(y[i, a])
            if abs(ub) < least[a] or abs(un - ub) > params.steady_tolerance * abs(ub):
                continue
            got = cell.get(name, AxisSums())
            assert isinstance(got, AxisSums)
            cell[name] = got.plus(AxisSums(ub * ub * dt, ub * ym * dt, ym * ym * dt, dt, 1))
    runs = (run,) if run else ()
    out: dict[Cell, CellSums] = {}
    for key, cell in sums.items():
        axes = {name: cell.get(name, AxisSums()) for name in AXES}
        out[key] = CellSums(
            roll=axes["roll"],  # type: ignore[arg-type]
            scroll=axes["scroll"],  # type: ignore[arg-type]
            yaw=axes["yaw"],  # type: ignore[arg-type]
            metres=float(cell["metres"]),  # type: ignore[arg-type]
            energy_j=float(cell["energy_j"]),  # type: ignore[arg-type]
            runs=runs,
        )
    return out


def merge_profiles(old: Profile, new: Profile, fade: float) -> dict[Cell, CellSums]:
    """``old`` faded by ``fade`` (0..1: how much of it counts after one more run), plus
    ``new``: the fits weighted by the time each taught (module docstring)."""
    if not 0.0 <= fade <= 1.0:
        raise ValueError(f"fade must be within 0 .. 1, got {fade}")
    out = {key: cell.scaled(fade) for key, cell in old.items()}
    for key, cell in new.items():
        out[key] = out[key].plus(cell) if key in out else cell
    return out


@dataclass(frozen=True, slots=True)
class Learned:
    """What a profile says of one medium in one mode, read for planning: each axis's fraction
    (None: too little taught) and its uncertainty, the metres behind it, the energy per
    metre; ``pinned``: axes the crew set by hand."""

    fractions: Mapping[str, float | None]
    sigmas: Mapping[str, float | None]
    samples: Mapping[str, int]
    metres: float
    power_w_per_mps: float | None
    runs: tuple[str, ...]
    pinned: tuple[str, ...] = ()


def learned(
    cell: CellSums,
    min_seconds: float,
    pins: Mapping[str, float] | None = None,
    correlation_s: float = GroundFitParams().correlation_s,
) -> Learned:
    """``cell`` read for planning: an axis taught for less than ``min_seconds`` has no
    fraction; a pinned axis has the crew's value (uncertainty 0)."""
    fr: dict[str, float | None] = {}
    sd: dict[str, float | None] = {}
    for name in AXES:
        ax = cell.axis(name)
        ok = ax.seconds >= min_seconds
        fr[name] = ax.fraction if ok else None
        sd[name] = ax.sigma(correlation_s) if ok else None
    pins = dict(pins or {})
    for name, value in pins.items():
        fr[name], sd[name] = value, 0.0
    return Learned(
        fr,
        sd,
        {name: cell.axis(name).samples for name in AXES},
        cell.metres,
        cell.power_w_per_mps,
        cell.runs,
        tuple(sorted(pins)),
    )


def axis_fraction(profile: Mapping[Cell, Learned], medium: Medium, axis: str) -> float | None:
    """What ``medium`` delivers along ``axis`` by the profile, from the mode(s) that drive it
    (roll: ROLL, else OMNI; scroll: SCROLL, else OMNI; yaw: the mode with the most samples)."""
    if axis == "yaw":
        cells = [c for (m, _), c in profile.items() if m is medium and c.fractions["yaw"]]
        best = max(cells, key=lambda c: c.samples["yaw"], default=None)
        return None if best is None else best.fractions["yaw"]
    for mode in (MotionMode.ROLL if axis == "roll" else MotionMode.SCROLL, MotionMode.OMNI):
        cell = profile.get((medium, mode))
        if cell is not None and cell.fractions[axis] is not None:
            return cell.fractions[axis]
    return None


def with_run(profile: Mapping[Cell, CellSums], run: str) -> dict[Cell, CellSums]:
    """Every cell of ``profile`` marked as coming from ``run``."""
    return {k: replace(c, runs=(run,)) for k, c in profile.items()}


__all__ = [
    "AXES",
    "DRIVEN",
    "SOURCED_FRACTIONS",
    "AxisSums",
    "CellSums",
    "GroundFitParams",
    "Learned",
    "Record",
    "axis_fraction",
    "identify",
    "learned",
    "merge_profiles",
    "with_run",
]
