"""``helixd ground``'s back end: the ground profile (or a profile identified from given runs
alone) as rows for a table, the mode the policy picks per medium, the crew's pins and reset,
and a figure beside the table."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from helixd.base.media import MediaMap, Medium
from helixd.base.plan import MotionMode
from helixd.base.problems import Problems
from helixd.config.root import HelixdConfig
from helixd.control.ground_fit import (
    AXES,
    DRIVEN,
    Cell,
    CellSums,
    Learned,
    axis_fraction,
    merge_profiles,
)
from helixd.planning.media_modes import MODE_AXIS, config_modes
from helixd.prepare.ground_learning import fit_params, learned_view, modes_from_profile
from helixd.recorder.ground_profile import GroundProfile, identify_run

PIN = re.compile(r"^(?P<medium>[a-z]+)/(?P<mode>[a-z]+)/(?P<axis>[a-z]+)=(?P<value>\S+)$")


class GroundCommandError(Problems, ValueError):
    """A command-line value helixd ground cannot use; ``problems``: one line each."""


@dataclass(frozen=True)
class GroundRow:
    """One medium in one mode, as the table shows it."""

    medium: Medium
    mode: MotionMode
    view: Learned


@dataclass(frozen=True)
class GroundReport:
    rows: tuple[GroundRow, ...]
    picks: Mapping[Medium, MotionMode]  # the mode media.modes learned picks now
    defaults: Mapping[Medium, MotionMode]
    source: str  # where it came from (the profile file, or the runs)
    decided: frozenset[Medium]  # media the profile knows both ROLL and SCROLL of


def report(cfg: HelixdConfig, profile: GroundProfile, source: str) -> GroundReport:
    view = learned_view(cfg, profile)
    rows = tuple(GroundRow(m, k, v) for (m, k), v in view.items())
    if cfg.ground.objective == "energy":
        decided = {
            m
            for m in Medium
            if all(
                (c := view.get((m, k))) is not None and c.power_w_per_mps is not None
                for k in MODE_AXIS
            )
        }
    else:
        decided = {
            m
            for m in Medium
            if all(axis_fraction(view, m, a) is not None for a in MODE_AXIS.values())
        }
    picks = modes_from_profile(cfg, view)
    return GroundReport(rows, picks, config_modes(cfg.media), source, frozenset(decided))


def from_runs(cfg: HelixdConfig, runs: Sequence[Path], media: MediaMap) -> GroundProfile:
    """A profile from the given runs alone, each weighing as much as the others (no fading):
    the same fit as after each flight, on flight.csv and the media map."""
    cells: dict[Cell, CellSums] = {}
    problems: list[str] = []
    for run in runs:
        try:
            cells = merge_profiles(
                cells, identify_run(run, media, cfg.vehicle, fit_params(cfg)), 1.0
            )
        except ValueError as exc:
            problems.append(str(exc))
    if problems:
        raise GroundCommandError(problems)
    return GroundProfile(cells)


def parse_pin(text: str) -> tuple[tuple[Medium, MotionMode, str], float]:
    """``MEDIUM/MODE/AXIS=FRACTION`` (``mud/scroll/scroll=0.7``)."""
    m = PIN.match(text.strip())
    problem = f"--pin {text!r}: expected MEDIUM/MODE/AXIS=FRACTION, e.g. mud/scroll/scroll=0.7"
    if m is None:
        raise GroundCommandError([problem])
    try:
        medium, mode = Medium(m["medium"]), MotionMode(m["mode"])
        value = float(m["value"])
    except ValueError:
        raise GroundCommandError([problem]) from None
    if m["axis"] not in AXES:
        raise GroundCommandError([f"--pin {text!r}: axis must be one of {', '.join(AXES)}"])
    if not 0.0 < value <= 1.2:
        raise GroundCommandError([f"--pin {text!r}: fraction must be within 0 (excluded) .. 1.2"])
    return (medium, mode, m["axis"]), value


def driven_samples(row: GroundRow) -> int:
    """The samples behind the axis the mode drives (ROLL: roll; SCROLL: scroll)."""
    return sum(row.view.samples[a] for a in DRIVEN[row.mode])


def fraction_text(view: Learned, axis: str) -> str:
    f, s = view.fractions[axis], view.sigmas[axis]
    if f is None:
        return "-"
    pin = " (pinned)" if axis in view.pinned else ""
    return f"{f:.3f} ± {s:.3f}{pin}" if s is not None else f"{f:.3f}{pin}"


__all__ = [
    "GroundCommandError",
    "GroundReport",
    "GroundRow",
    "driven_samples",
    "fraction_text",
    "from_runs",
    "parse_pin",
    "report",
]
