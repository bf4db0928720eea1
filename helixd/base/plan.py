"""Plain plan and mode types: what the control core flies, free of the mission file format.

:mod:`helixd.mission` loads and validates mission files (pydantic, YAML) and resolves them into
a :class:`Plan`; the navigator only ever sees this module's types.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum


class MotionMode(StrEnum):
    ROLL = "roll"  # hard ground: v_y = 0, drive along +x
    SCROLL = "scroll"  # water, mud, snow: v_x = 0, drive along +y
    OMNI = "omni"  # viscous media: ω_z = 0, heading held


class MissionFrameKind(StrEnum):
    START = "start"
    LOCAL_NED = "local_ned"
    GLOBAL = "global"


@dataclass(frozen=True, slots=True)
class PlanWaypoint:
    """One target in the mission frame (x/y metres, yaw CCW from +x)."""

    x_m: float
    y_m: float
    tolerance_m: float
    final_yaw_rad: float | None = None
    via: bool = False  # inserted by the planner on the way to the next waypoint


@dataclass(frozen=True, slots=True)
class Plan:
    name: str
    mode: MotionMode
    frame: MissionFrameKind
    waypoints: tuple[PlanWaypoint, ...]
    speed_mps: float
    # Start of the first leg (mission frame, m). None: the rover's pose at the first step, as
    # for a fresh mission. A resumed mission sets the waypoint before its first one, so line
    # guidance re-enters the interrupted leg instead of cutting across to the waypoint.
    leg_start_xy_m: tuple[float, float] | None = None

    def path_length_m(self, start_xy_m: tuple[float, float] = (0.0, 0.0)) -> float:
        """Length of the polyline start → wp1 → … → wpN (m)."""
        total = 0.0
        px, py = start_xy_m
        for wp in self.waypoints:
            total += math.hypot(wp.x_m - px, wp.y_m - py)
            px, py = wp.x_m, wp.y_m
        return total

    def numbers(self) -> tuple[int, ...]:
        """Per waypoint, see :func:`operator_numbers`."""
        return operator_numbers([w.via for w in self.waypoints])

    @property
    def operator_count(self) -> int:
        """The operator's waypoints (via points not counted)."""
        return sum(not w.via for w in self.waypoints)


def operator_numbers(vias: Sequence[bool], first: int = 1) -> tuple[int, ...]:
    """The operator's numbering, 1-based as a ground station shows mission items: each
    waypoint's own number; a via point (inserted by the planner) gets the number of the
    waypoint its leg leads to. ``first``: the number of the first operator waypoint here
    (a resumed run starts further on)."""
    out: list[int] = []
    k = first
    for via in vias:
        out.append(k)
        if not via:
            k += 1
    return tuple(out)


@dataclass(frozen=True, slots=True)
class Numbering:
    """How the operator numbers a run's waypoints: 1-based over the whole mission (a resumed
    run continues the count), via points not counted (see :func:`operator_numbers`)."""

    numbers: tuple[int, ...]  # per plan index
    vias: tuple[bool, ...]  # per plan index
    total: int  # the operator's waypoints in the whole mission

    @staticmethod
    def of(vias: Sequence[bool], first: int = 1, total: int | None = None) -> Numbering:
        """``first``: the number of this run's first operator waypoint; ``total`` (default:
        the last one's number) of the whole mission."""
        own = sum(not v for v in vias)
        return Numbering(
            operator_numbers(vias, first), tuple(vias), first - 1 + own if total is None else total
        )

    @property
    def operator_count(self) -> int:
        """The operator's waypoints in this run."""
        return sum(not v for v in self.vias)

    def number(self, index: int) -> int:
        """The number of plan index ``index`` (a via point: of the waypoint it leads to)."""
        return self.numbers[min(max(index, 0), len(self.numbers) - 1)] if self.numbers else 0

    def via(self, index: int) -> bool:
        return bool(self.vias) and self.vias[min(max(index, 0), len(self.vias) - 1)]

    def label(self, index: int) -> str:
        """``"3/5"``, or ``"via → 3/5"`` for a via point on the leg to waypoint 3."""
        return waypoint_label(self.number(index), self.via(index), self.total)


def waypoint_label(number: int, via: bool, total: int | None = None) -> str:
    """``"3"`` (or ``"3/5"`` with ``total``) for the operator's waypoint 3; ``"via → 3"`` (or
    ``"via → 3/5"``) for a via point on the leg to it."""
    text = str(number) if total is None else f"{number}/{total}"
    return f"via → {text}" if via else text


__all__ = [
    "MissionFrameKind",
    "MotionMode",
    "Numbering",
    "Plan",
    "PlanWaypoint",
    "operator_numbers",
    "waypoint_label",
]
