"""The rover learns its ground: after a run with a media map, what each medium delivered in
each mode is identified from the run's ``flight.csv`` (:mod:`helixd.control.ground_fit`),
recorded in its ``summary.json`` (``ground``) and merged into the ground profile
(:mod:`helixd.recorder.ground_profile`); ``media.modes: learned`` plans the next flight's
modes with it (:func:`helixd.planning.media_modes.learned_modes`). ``run`` and ``serve`` both
learn, through the runner (:mod:`helixd.runtime.daemon`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import structlog

from helixd.base.media import MediaMap, MediaMapNe, Medium
from helixd.base.plan import MotionMode, Plan
from helixd.config.root import HelixdConfig
from helixd.control.ground_cap import full_speed_mps, leg_cap_mps
from helixd.control.ground_fit import (
    AXES,
    SOURCED_FRACTIONS,
    Cell,
    CellSums,
    GroundFitParams,
    Learned,
    axis_fraction,
    learned,
    merge_profiles,
)
from helixd.files.models import ConfigFileError
from helixd.planning.media_modes import config_modes, delivered, learned_modes
from helixd.recorder.ground_profile import (
    PROFILE_NAME,
    GroundProfile,
    identify_run,
    read_profile,
    write_profile,
)

log = structlog.get_logger(__name__)


def profile_path(cfg: HelixdConfig, run_root: Path | None = None) -> Path:
    """The ground profile's file: ``ground.profile_file``, else under the run root
    (``run_root``: the one runs go to, ``--run-dir``; None: ``recorder.run_root``)."""
    root = cfg.recorder.run_root if run_root is None else run_root
    return cfg.ground.profile_file or root / PROFILE_NAME


def fit_params(cfg: HelixdConfig) -> GroundFitParams:
    """The fit reads a record with the slip estimate's own thresholds and lag."""
    slip = cfg.control.slip
    return GroundFitParams(
        lag_s=slip.command_lag_s,
        min_speed_mps=slip.min_speed_mps,
        min_yaw_rate_radps=slip.min_yaw_rate_radps,
        steady_tolerance=slip.steady_tolerance,
        max_gap_s=slip.max_gap_s,
    )


def learned_view(cfg: HelixdConfig, profile: GroundProfile) -> dict[Cell, Learned]:
    """Every cell of ``profile`` read for planning (too little taught: no fraction; the crew's
    pins win)."""
    keys = set(profile.cells) | {(m, k) for m, k, _ in profile.pins}
    return {
        key: learned(
            profile.cells.get(key, CellSums()), cfg.ground.min_taught_s, profile.pins_of(key)
        )
        for key in sorted(keys)
    }


def modes_from_profile(cfg: HelixdConfig, view: Mapping[Cell, Learned]) -> dict[Medium, MotionMode]:
    """``media.modes: learned``: per medium the mode ``view`` makes best, the defaults where
    it knows too little."""
    slip = cfg.control.slip

    def energy(medium: Medium, mode: MotionMode) -> float | None:
        cell = view.get((medium, mode))
        return None if cell is None else cell.power_w_per_mps

    return learned_modes(
        config_modes(cfg.media),
        lambda medium, axis: axis_fraction(view, medium, axis),
        energy,
        slip.max_gain,
        slip.stuck_fraction,
        cfg.ground.objective,
    )


def learned_policy_modes(
    cfg: HelixdConfig, run_root: Path | None = None
) -> dict[Medium, MotionMode]:
    """The policy's modes when ``media.modes`` is ``learned`` (from the profile file); a
    profile that cannot be read is refused (ConfigFileError, one line per problem)."""
    path = profile_path(cfg, run_root)
    return modes_from_profile(cfg, learned_view(cfg, read_profile(path)))


STEP_M = 0.1  # the leg's ground is sampled this often along it


@dataclass(frozen=True)
class OverMedia:
    """Where a plan lies over the media: the map placed around the EKF origin, the mission
    frame → (north, east) conversion, and where the first leg starts (mission frame, m)."""

    placed: MediaMapNe
    to_ne: Callable[[float, float], tuple[float, float]]
    start_xy_m: tuple[float, float]


def with_learned_ground(
    plan: Plan,
    over: OverMedia,
    view: Mapping[Cell, Learned],
    cfg: HelixdConfig,
) -> Plan:
    """``plan`` with each leg's ground as the profile knows it (``PlanWaypoint.ground``), for
    the time estimate. Along the leg, every :data:`STEP_M`, the rover's front and rear scroll
    pairs stand half its length ahead and behind (l_y in SCROLL, l_x in ROLL) and each pair
    delivers its medium's fraction, so the rover the mean of the two (the simulator's blend,
    docs/physics.md "Media maps"); per axis the leg's fraction is the one that, through the
    slip feed-forward, delivers the harmonic mean of what the steps deliver (time adds up as
    length / delivered). Where the profile knows too little: the ground the operator declared
    (``control.slip.ground_*_fraction``, if any is below 1), else the medium's sourced default
    (:data:`helixd.control.ground_fit.SOURCED_FRACTIONS`, the simulator's default table)."""
    slip = cfg.control.slip
    gain = slip.max_gain if slip.enabled else 1.0
    declared = {
        "roll": slip.ground_roll_fraction,
        "scroll": slip.ground_scroll_fraction,
        "yaw": slip.ground_yaw_fraction,
    }
    operator_declared = any(f < 1.0 for f in declared.values())
    known: dict[tuple[Medium, str], float] = {}

    def fraction(medium: Medium, axis: str) -> float:
        key = (medium, axis)
        if key not in known:
            default = (
                declared[axis] if operator_declared else SOURCED_FRACTIONS[medium][AXES.index(axis)]
            )
            known[key] = axis_fraction(view, medium, axis) or default
        return known[key]

    legs = []
    for j, wp in enumerate(plan.waypoints):
        pairs = _leg_pairs(plan, j, over, cfg)
        steps = len(pairs)
        fractions = []
        for axis in AXES:
            inverse = 0.0
            for ahead, behind in pairs:
                mean = (fraction(ahead, axis) + fraction(behind, axis)) / 2.0
                inverse += 1.0 / delivered(mean, gain, slip.stuck_fraction) / steps
            both = 1.0 / inverse
            # the fraction the estimate's feed-forward turns into ``both`` again
            if both >= 1.0 - 1e-9:  # all of the command (the steps' sum rounds)
                raw = 1.0
            elif both / gain >= slip.stuck_fraction:
                raw = both / gain
            else:
                raw = min(both, slip.stuck_fraction)
            fractions.append(raw)
        legs.append(replace(wp, ground=(fractions[0], fractions[1], fractions[2])))
    return replace(plan, waypoints=tuple(legs))


def _leg_pairs(
    plan: Plan, j: int, over: OverMedia, cfg: HelixdConfig
) -> list[tuple[Medium, Medium]]:
    """Along leg ``j``, every :data:`STEP_M`, the media under the rover's front and rear
    scroll pairs (half its length ahead and behind: l_y in SCROLL, l_x in ROLL)."""
    placed, to_ne = over.placed, over.to_ne
    (ax, ay) = over.start_xy_m if j == 0 else (plan.waypoints[j - 1].x_m, plan.waypoints[j - 1].y_m)
    bx, by = plan.waypoints[j].x_m, plan.waypoints[j].y_m
    length = math.hypot(bx - ax, by - ay)
    ux, uy = ((bx - ax) / length, (by - ay) / length) if length > 0.0 else (0.0, 0.0)
    half = cfg.vehicle.lx_m if plan.mode_at(j) is MotionMode.ROLL else cfg.vehicle.ly_m
    steps = max(1, math.ceil(length / STEP_M))
    pairs = []
    for k in range(steps):
        s_m = (k + 0.5) / steps * length
        ahead = placed.medium_at(*to_ne(ax + ux * (s_m + half), ay + uy * (s_m + half)))
        behind = placed.medium_at(*to_ne(ax + ux * (s_m - half), ay + uy * (s_m - half)))
        pairs.append((ahead, behind))
    return pairs


def with_speed_caps(
    plan: Plan,
    over: OverMedia,
    view: Mapping[Cell, Learned],
    cfg: HelixdConfig,
) -> Plan:
    """``plan`` with each leg's speed cap (``PlanWaypoint.speed_cap_mps``): the lowest over
    the media under its scrolls of what the profile knows they take in the leg's mode
    (:func:`helixd.control.ground_cap.leg_cap_mps`); no cap where it knows too little."""
    full = full_speed_mps(cfg.vehicle)
    margin = cfg.ground.speed_cap_margin
    legs = []
    for j, wp in enumerate(plan.waypoints):
        mode = plan.mode_at(j)
        media = {m for pair in _leg_pairs(plan, j, over, cfg) for m in pair}

        def fraction_of(medium: Medium, axis: str, mode: MotionMode = mode) -> float | None:
            cell = view.get((medium, mode))
            return None if cell is None else cell.fractions.get(axis)

        cap = leg_cap_mps(sorted(media), mode, fraction_of, full, margin, cfg.control.slip)
        legs.append(replace(wp, speed_cap_mps=cap))
    return replace(plan, waypoints=tuple(legs))


def slip_priors(
    plan: Plan,
    over: OverMedia,
    view: Mapping[Cell, Learned],
    cfg: HelixdConfig,
) -> tuple[tuple[MotionMode, tuple[float, float, float]], ...]:
    """Per motion mode, the (roll, scroll, yaw) fractions of the medium where the rover first
    flies in it (the start of that mode's first leg), as the profile knows them, the declared
    ground where it knows too little: where the slip estimate starts (``Plan.slip_priors``)."""
    slip = cfg.control.slip
    declared = (slip.ground_roll_fraction, slip.ground_scroll_fraction, slip.ground_yaw_fraction)
    points = [over.start_xy_m, *((w.x_m, w.y_m) for w in plan.waypoints)]
    out: dict[MotionMode, tuple[float, float, float]] = {}
    for j in range(len(plan.waypoints)):
        mode = plan.mode_at(j)
        if mode in out:
            continue
        medium = over.placed.medium_at(*over.to_ne(*points[j]))
        got = [axis_fraction(view, medium, axis) for axis in AXES]
        out[mode] = (
            got[0] or declared[0],
            got[1] or declared[1],
            got[2] or declared[2],
        )
    return tuple(out.items())


def learned_plan(
    cfg: HelixdConfig,
    plan: Plan,
    placed: MediaMapNe,
    to_ne: Callable[[float, float], tuple[float, float]],
    start_xy_m: tuple[float, float],
) -> Plan:
    """``media.modes: learned``: ``plan`` with its legs' learnt ground for the estimate, their
    speed caps and the slip estimate's learnt priors (the profile read again); any other
    policy: with its legs' ground for the estimate from the defaults alone (the sourced table
    per medium, or the declared ground: :func:`with_learned_ground`), the flight as it was."""
    over = OverMedia(placed, to_ne, start_xy_m)
    if not isinstance(cfg.media.modes, str):
        return with_learned_ground(plan, over, {}, cfg)
    view = learned_view(cfg, read_profile(profile_path(cfg)))
    legs = with_speed_caps(with_learned_ground(plan, over, view, cfg), over, view, cfg)
    return replace(legs, slip_priors=slip_priors(plan, over, view, cfg))


def ground_section(cfg: HelixdConfig, cells: Mapping[Cell, CellSums]) -> dict[str, Any]:
    """summary.json's ``ground``: per ``medium/mode`` the fractions, their uncertainty, the
    samples and metres behind them and the energy per metre, from this run alone."""
    out: dict[str, Any] = {}
    for (medium, mode), cell in sorted(cells.items()):
        view = learned(cell, cfg.ground.min_taught_s)
        out[f"{medium.value}/{mode.value}"] = {
            "samples": dict(view.samples),
            "metres": round(view.metres, 2),
            "fractions": {a: _r(view.fractions[a]) for a in AXES},
            "sigmas": {a: _r(view.sigmas[a]) for a in AXES},
            "power_w_per_mps": _r(view.power_w_per_mps, 1),
        }
    return out


def _r(value: float | None, digits: int = 4) -> float | None:
    return None if value is None else round(value, digits)


def learn_from_run(
    cfg: HelixdConfig, media: MediaMap | None, run_dir: Path | None, run_root: Path | None = None
) -> bool:
    """After a run: identify what its ground delivered, add ``ground`` to its summary.json and
    merge it into the profile (``ground.learn``; only with a media map). Never raises: a
    problem is a ``ground_not_learned`` warning, the run's outcome stands."""
    if not cfg.ground.learn or media is None or run_dir is None:
        return False
    try:
        cells = identify_run(run_dir, media, cfg.vehicle, fit_params(cfg))
        if not cells:
            return False
        _add_to_summary(run_dir / "summary.json", ground_section(cfg, cells))
        path = profile_path(cfg, run_root)
        profile = read_profile(path)
        profile.cells = merge_profiles(profile.cells, cells, cfg.ground.fade)
        write_profile(path, profile)
    except (OSError, ValueError, ConfigFileError) as exc:
        log.warning("ground_not_learned", run_dir=str(run_dir), problem=str(exc))
        return False
    log.info(
        "ground_learned",
        run_dir=str(run_dir),
        profile=str(path),
        cells=sorted(f"{m.value}/{k.value}" for m, k in cells),
    )
    return True


def _add_to_summary(path: Path, section: dict[str, Any]) -> None:
    """``section`` as summary.json's ``ground``, the file rewritten atomically."""
    data = json.loads(path.read_text(encoding="utf-8"))
    data["ground"] = section
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp, path)


__all__ = [
    "OverMedia",
    "fit_params",
    "ground_section",
    "learn_from_run",
    "learned_plan",
    "learned_policy_modes",
    "learned_view",
    "modes_from_profile",
    "profile_path",
    "slip_priors",
    "with_learned_ground",
    "with_speed_caps",
]
