"""The mode follows the medium: a plan split into stretches, each flown in the mode that works
on its ground. Pure: a plan, a media map and a policy in; a plan with a mode per waypoint out.

* **Policy** (:class:`ModePolicy`, built by :meth:`ModePolicy.from_config`, the one source):
  the mode per medium (``media.modes`` in the config, whose defaults are the defaults, or the
  ground profile's learned modes; a mission's ``media_modes`` replaces entries), and the
  margin on the firm side of a boundary. Every medium has its mode: none is guessed.
* **Stretches**: the path (start → waypoint 1 → …) is cut where the medium changes
  (:func:`helixd.base.media.media_along`), each piece gets its medium's mode, neighbours in one
  mode are one stretch. A leg whose waypoint pins a mode (a YAML waypoint's ``mode:``) is one
  piece in that mode whatever it crosses. A stretch shorter than the policy's
  ``min_stretch_m`` (and than ``2 × margin``) is not worth two turns: it joins its
  neighbour, and the pair keeps the mode that moves in both (SCROLL or OMNI, never ROLL:
  rolling is what fails in water and mud).
* **Transitions**: where the mode changes between ROLL and SCROLL the driving axis turns by
  90°, which the rover does in place, stopped. It stops on the firm side — ``margin`` before the
  boundary when it leaves ROLL, ``margin`` past it when it takes ROLL back — so it turns with
  all four scrolls on the ground that ROLL works on. A via point (``via``, ``stop``) is
  inserted there, unless a waypoint is within :data:`SNAP_M`: that waypoint becomes the stop.

A mission with commands keeps its program: the steps' waypoint ranges are renumbered around the
inserted via points.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

from helixd.base.media import MediaMapNe, Medium, media_along
from helixd.base.plan import MotionMode, NavStep, Plan, PlanWaypoint
from helixd.config.media import MediaConfig, MediaModesConfig

XY = tuple[float, float]
MediaLengths = tuple[tuple[Medium, float], ...]  # (medium, metres) in path order
ToNe = Callable[[float, float], XY]  # mission-frame (x, y) → (north_m, east_m)

SNAP_M = 0.05  # a transition this close to a waypoint happens at the waypoint
MIN_STRETCH_M = 0.5  # no stretch shorter than this (nor than 2 × margin) keeps its own mode


def config_modes(media: MediaConfig) -> dict[Medium, MotionMode]:
    """The fixed policy's mode per medium: ``media.modes``, or its defaults when that is
    ``learned`` (what the ground profile knows too little of keeps these)."""
    fixed = MediaModesConfig() if isinstance(media.modes, str) else media.modes
    return {Medium(k): MotionMode(v) for k, v in fixed.model_dump().items()}


@dataclass(frozen=True, slots=True)
class ModePolicy:
    """The motion mode per medium (every medium has one), and where a change of mode
    happens."""

    modes: Mapping[Medium, MotionMode]
    margin_m: float = 1.0
    min_stretch_m: float = 5.0  # shorter stretches join a neighbour (at least 2 × margin)

    def __post_init__(self) -> None:
        missing = [m.value for m in Medium if m not in self.modes]
        if missing:
            raise ValueError(f"no mode for {', '.join(missing)}")

    @classmethod
    def from_config(
        cls,
        media: MediaConfig,
        mission_modes: Mapping[Medium, MotionMode] | None = None,
        learned: Mapping[Medium, MotionMode] | None = None,
    ) -> ModePolicy:
        """The policy a flight follows: ``learned`` (``media.modes: learned``, the ground
        profile's picks, read by the caller) or the config's ``media.modes``, a mission's
        ``media_modes`` over them; the margin and shortest stretch from ``media``."""
        modes = dict(config_modes(media) if learned is None else learned)
        modes.update(mission_modes or {})
        return cls(modes, media.transition_margin_m, media.min_stretch_m)

    def mode_for(self, medium: Medium) -> MotionMode:
        return self.modes[medium]

    @property
    def firm_mode(self) -> MotionMode:
        """The mode on firm ground (hard): what the ground check judges and comes back to."""
        return self.modes[Medium.HARD]

    @property
    def soft_mode(self) -> MotionMode:
        """The mode on soft ground (mud): what the ground check takes where the map is wrong."""
        return self.modes[Medium.MUD]


@dataclass(frozen=True, slots=True)
class Stretch:
    """A part of the path in one mode: from ``start_m`` to ``end_m`` along it (after the
    transitions moved to the firm side), with the length in each medium it crosses."""

    mode: MotionMode
    start_m: float
    end_m: float
    media_m: tuple[tuple[Medium, float], ...]  # (medium, metres) in path order, merged
    pinned: bool = False  # a waypoint's own mode

    @property
    def length_m(self) -> float:
        return self.end_m - self.start_m

    @property
    def main_medium(self) -> Medium:
        """The medium it runs through longest."""
        total: dict[Medium, float] = {}
        for medium, length in self.media_m:
            total[medium] = total.get(medium, 0.0) + length
        return max(total, key=lambda m: total[m])


@dataclass(frozen=True, slots=True)
class Transition:
    """A change of mode at plan waypoint ``index`` (a stop), ``at_m`` along the path."""

    index: int
    at_m: float
    xy_m: XY
    before: MotionMode
    after: MotionMode
    medium: Medium  # the ground it turns on

    @property
    def turn_rad(self) -> float:
        """The turn in place it needs: 90° between ROLL and SCROLL, none to or from OMNI
        (OMNI drives in any direction at a held heading)."""
        if MotionMode.OMNI in (self.before, self.after):
            return 0.0
        return math.pi / 2


@dataclass(frozen=True, slots=True)
class MediaPlan:
    plan: Plan  # a mode on every waypoint, via stops where the mode changes
    stretches: tuple[Stretch, ...]
    transitions: tuple[Transition, ...]


@dataclass
class _Piece:
    start_m: float
    end_m: float
    mode: MotionMode
    media_m: list[tuple[Medium, float]]
    pinned: bool


def _pieces(
    points: Sequence[XY],
    pinned: Sequence[MotionMode | None],
    media: MediaMapNe,
    policy: ModePolicy,
    to_ne: ToNe,
) -> tuple[list[_Piece], list[float]]:
    """Per leg, its runs of one medium as pieces along the path; and each point's distance."""
    pieces: list[_Piece] = []
    at = [0.0]
    for i in range(1, len(points)):
        a, b = points[i - 1], points[i]
        length = math.hypot(b[0] - a[0], b[1] - a[1])
        s0 = at[-1]
        at.append(s0 + length)
        if length <= 0.0:
            continue
        runs = media_along(media, to_ne(*a), to_ne(*b))
        own = pinned[i - 1]
        for run in runs:
            lo, hi = s0 + run.start_fraction * length, s0 + run.end_fraction * length
            mode = own if own is not None else policy.mode_for(run.medium)
            pieces.append(_Piece(lo, hi, mode, [(run.medium, hi - lo)], own is not None))
    return pieces, at


def _join(pieces: list[_Piece]) -> list[_Piece]:
    """Neighbours in one mode (and equally pinned) become one."""
    out: list[_Piece] = []
    for p in pieces:
        last = out[-1] if out else None
        if last is not None and last.mode is p.mode and last.pinned == p.pinned:
            last.end_m = p.end_m
            for medium, length in p.media_m:
                if last.media_m and last.media_m[-1][0] is medium:
                    last.media_m[-1] = (medium, last.media_m[-1][1] + length)
                else:
                    last.media_m.append((medium, length))
        else:
            out.append(_Piece(p.start_m, p.end_m, p.mode, list(p.media_m), p.pinned))
    return out


def _moving_mode(a: _Piece, b: _Piece) -> MotionMode:
    """The mode two joined stretches keep: a pinned one's, else the one that is not ROLL,
    else the longer one's."""
    if a.pinned != b.pinned:
        return a.mode if a.pinned else b.mode
    if a.mode is MotionMode.ROLL:
        return b.mode
    if b.mode is MotionMode.ROLL:
        return a.mode
    return a.mode if a.end_m - a.start_m >= b.end_m - b.start_m else b.mode


def _absorb_short(stretches: list[_Piece], min_m: float) -> list[_Piece]:
    """Join every stretch shorter than ``min_m`` (not pinned) to a neighbour, shortest first."""
    out = list(stretches)
    while len(out) > 1:
        short = [i for i, s in enumerate(out) if not s.pinned and s.end_m - s.start_m < min_m]
        if not short:
            break
        i = min(short, key=lambda k: out[k].end_m - out[k].start_m)
        j = i - 1 if i == len(out) - 1 else i + 1
        if 0 < i < len(out) - 1 and out[i - 1].mode is not MotionMode.ROLL:
            j = i - 1  # join the neighbour that keeps moving (not ROLL) by preference
        lo, hi = min(i, j), max(i, j)
        mode = _moving_mode(out[lo], out[hi])
        pinned = out[lo].pinned or out[hi].pinned
        merged = _Piece(
            out[lo].start_m, out[hi].end_m, mode, out[lo].media_m + out[hi].media_m, pinned
        )
        out[lo : hi + 1] = [merged]
        out = _join(out)
    return out


def _transition_m(left: _Piece, right: _Piece, margin_m: float) -> float:
    """Where the change between ``left`` and ``right`` happens: on ROLL's side, by the margin."""
    boundary = left.end_m
    if left.mode is right.mode:  # a pinned leg beside the same mode: no stop, no turn
        return boundary
    if left.mode is MotionMode.ROLL:
        return max(left.start_m, boundary - margin_m)
    if right.mode is MotionMode.ROLL:
        return min(right.end_m, boundary + margin_m)
    return boundary


def _media_between(pieces: Sequence[_Piece], lo_m: float, hi_m: float) -> MediaLengths:
    """The media the path crosses from ``lo_m`` to ``hi_m`` (a stretch after its ends moved
    to the firm side), in path order, neighbours in one medium merged."""
    out: list[tuple[Medium, float]] = []
    for p in pieces:
        length = min(p.end_m, hi_m) - max(p.start_m, lo_m)
        if length <= 0.0:
            continue
        medium = p.media_m[0][0]
        if out and out[-1][0] is medium:
            out[-1] = (medium, out[-1][1] + length)
        else:
            out.append((medium, length))
    if not out and pieces:  # a stretch of no length: the medium where it stands
        here = min(pieces, key=lambda p: max(p.start_m - lo_m, lo_m - p.end_m, 0.0))
        out.append((here.media_m[0][0], 0.0))
    return tuple(out)


def _point_at(points: Sequence[XY], at: Sequence[float], s_m: float) -> XY:
    for i in range(1, len(points)):
        if s_m <= at[i] or i == len(points) - 1:
            length = at[i] - at[i - 1]
            f = 0.0 if length <= 0.0 else min(max((s_m - at[i - 1]) / length, 0.0), 1.0)
            a, b = points[i - 1], points[i]
            return (a[0] + (b[0] - a[0]) * f, a[1] + (b[1] - a[1]) * f)
    return points[-1]


def follow_media(
    plan: Plan,
    media: MediaMapNe,
    policy: ModePolicy,
    start_xy_m: XY,
    to_ne: ToNe,
) -> MediaPlan:
    """``plan`` with each leg in the mode of its medium (see the module's docstring).
    ``start_xy_m``: where the first leg starts (mission frame); ``to_ne``: mission-frame
    point → the media map's north/east."""
    wps = plan.waypoints
    if not wps:
        return MediaPlan(plan, (), ())
    points = [start_xy_m, *((w.x_m, w.y_m) for w in wps)]
    pieces, at = _pieces(points, [w.mode for w in wps], media, policy, to_ne)
    if not pieces:  # every leg has no length: the plan's mode where the rover stands
        medium = media.medium_at(*to_ne(*start_xy_m))
        pieces = [_Piece(0.0, 0.0, wps[0].mode or policy.mode_for(medium), [(medium, 0.0)], False)]
    shortest_m = max(MIN_STRETCH_M, policy.min_stretch_m, 2.0 * policy.margin_m)
    stretches = _absorb_short(_join(pieces), shortest_m)
    # each change of mode, moved to the firm side and snapped onto a close waypoint
    changes: list[float] = []
    for left, right in itertools.pairwise(stretches):
        s = _transition_m(left, right, policy.margin_m)
        near = min(range(len(at)), key=lambda k: abs(at[k] - s))
        changes.append(at[near] if abs(at[near] - s) <= SNAP_M else s)
    bounds = [0.0, *changes, at[-1]]
    done = [
        Stretch(st.mode, lo, hi, _media_between(pieces, lo, hi), st.pinned)
        for st, lo, hi in zip(stretches, bounds[:-1], bounds[1:], strict=True)
    ]

    def mode_at(s_m: float) -> MotionMode:
        for k, c in enumerate(changes):
            if s_m < c:
                return done[k].mode
        return done[-1].mode

    new: list[PlanWaypoint] = []
    new_index: list[int] = []  # per original waypoint
    for i, wp in enumerate(wps):
        lo, hi = at[i], at[i + 1]
        cuts = [c for c in changes if lo + SNAP_M < c < hi - SNAP_M]
        prev = lo
        for c in cuts:
            x, y = _point_at(points, at, c)
            mode = mode_at((prev + c) / 2)
            stop = PlanWaypoint(x, y, wp.tolerance_m, via=True, stop=True, mode=mode)
            new.append(replace(stop, media_stop=True))
            prev = c
        new.append(replace(wp, mode=mode_at((prev + hi) / 2) if hi > prev else mode_at(prev)))
        new_index.append(len(new) - 1)
    for k in range(len(new) - 1):  # a change of mode at a waypoint: stop there
        if new[k].mode is not new[k + 1].mode and not new[k].stop:
            new[k] = replace(new[k], stop=True)
    new = _with_unfit_spans(new, start_xy_m, plan.mode, media, policy, to_ne)
    program = plan.program
    if program is not None:
        program = replace(program, steps=tuple(_renumbered(s, new_index) for s in program.steps))
    out = replace(plan, waypoints=tuple(new), program=program)
    transitions: list[Transition] = []
    for k in range(len(new) - 1):
        before, after = out.mode_at(k), out.mode_at(k + 1)
        if before is not after:
            w = new[k]
            medium = media.medium_at(*to_ne(w.x_m, w.y_m))
            s_here = next((c for c in changes if _close(points, at, c, w)), math.nan)
            transitions.append(Transition(k, s_here, (w.x_m, w.y_m), before, after, medium))
    return MediaPlan(out, tuple(done), tuple(transitions))


def _with_unfit_spans(
    wps: Sequence[PlanWaypoint],
    start_xy_m: XY,
    plan_mode: MotionMode,
    media: MediaMapNe,
    policy: ModePolicy,
    to_ne: ToNe,
) -> list[PlanWaypoint]:
    """Each waypoint with the spans of its leg (as distance still to go, m) where the map's
    medium is one the policy flies in another mode than the leg's (a pinned leg's water)."""
    out: list[PlanWaypoint] = []
    prev = start_xy_m
    for w in wps:
        here = (w.x_m, w.y_m)
        length = math.hypot(here[0] - prev[0], here[1] - prev[1])
        mode = w.mode or plan_mode
        spans: list[tuple[float, float]] = []
        for r in reversed(media_along(media, to_ne(*prev), to_ne(*here))):
            if policy.mode_for(r.medium) is mode or r.length_m <= SNAP_M:
                continue
            near, far = length * (1.0 - r.end_fraction), length * (1.0 - r.start_fraction)
            if spans and near - spans[-1][1] <= SNAP_M:  # mud, then water: one span
                near = spans.pop()[0]
            spans.append((near, far))
        out.append(replace(w, unfit_to_go_m=tuple(spans)) if spans and length > 0.0 else w)
        prev = here
    return out


def _close(points: Sequence[XY], at: Sequence[float], s_m: float, w: PlanWaypoint) -> bool:
    x, y = _point_at(points, at, s_m)
    return math.hypot(x - w.x_m, y - w.y_m) <= SNAP_M + 1e-9


def _renumbered(step: NavStep, new_index: Sequence[int]) -> NavStep:
    """A step's waypoint range after via points were inserted: from just after the previous
    original waypoint (the vias on its first leg are its own) to its last waypoint."""
    first, last = step.first_waypoint, step.last_waypoint
    if first is None or last is None:
        return step
    new_first = new_index[first - 1] + 1 if first > 0 else 0
    return replace(step, first_waypoint=new_first, last_waypoint=new_index[last])


def pinned_misfits(
    got: MediaPlan, policy: ModePolicy
) -> tuple[tuple[int, Stretch, MediaLengths], ...]:
    """The stretches a waypoint pins to a mode over media the policy flies in another mode
    (a ROLL leg across the pond): (stretch index from 0, the stretch, those media's lengths)."""
    out: list[tuple[int, Stretch, MediaLengths]] = []
    for k, st in enumerate(got.stretches):
        if not st.pinned:
            continue
        total: dict[Medium, float] = {}
        for medium, length in st.media_m:
            if policy.mode_for(medium) is not st.mode and length > SNAP_M:
                total[medium] = total.get(medium, 0.0) + length
        if total:
            out.append((k, st, tuple(total.items())))
    return tuple(out)


def medium_under_mode_m(got: MediaPlan, medium: Medium, mode: MotionMode) -> float:
    """How far the plan flies ``mode`` over ``medium`` (metres)."""
    return sum(
        length for st in got.stretches if st.mode is mode for m, length in st.media_m if m is medium
    )


# the translation axis each single-axis mode drives along (ground_fit's axis names)
MODE_AXIS: Mapping[MotionMode, str] = {MotionMode.ROLL: "roll", MotionMode.SCROLL: "scroll"}


def delivered(fraction: float, max_gain: float, stuck_fraction: float) -> float:
    """What an axis whose ground delivers ``fraction`` gives of the navigator's command with
    the slip feed-forward: min(1, fraction · max_gain), none amplified below
    ``stuck_fraction`` (helixd.control.slip.feed_forward_gain)."""
    if not fraction >= stuck_fraction:
        return fraction
    return min(1.0, fraction * max_gain)


def learned_modes(
    defaults: Mapping[Medium, MotionMode],
    axis_fraction: Callable[[Medium, str], float | None],
    energy_per_m: Callable[[Medium, MotionMode], float | None],
    max_gain: float,
    stuck_fraction: float,
    objective: str = "time",
) -> dict[Medium, MotionMode]:
    """The mode per medium a ground profile makes best: of ROLL and SCROLL, the one whose
    driving axis delivers most of the command (``objective`` ``time``; ties go to the larger
    fraction: fewer rpm for the same speed) or spends the least energy per metre
    (``energy``). A medium where either mode is not known (``None``) keeps its default."""
    out = dict(defaults)
    for medium in Medium:
        known: dict[MotionMode, float] = {}
        for mode, axis in MODE_AXIS.items():
            if objective == "energy":
                value = energy_per_m(medium, mode)
                if value is not None and value > 0.0:
                    known[mode] = -value
            else:
                f = axis_fraction(medium, axis)
                if f is not None and f > 0.0:
                    known[mode] = delivered(f, max_gain, stuck_fraction) + 1e-6 * f
        if len(known) == len(MODE_AXIS):
            out[medium] = max(known, key=lambda m: known[m])
    return out


__all__ = [
    "MIN_STRETCH_M",
    "MODE_AXIS",
    "SNAP_M",
    "MediaLengths",
    "MediaPlan",
    "ModePolicy",
    "Stretch",
    "Transition",
    "config_modes",
    "delivered",
    "follow_media",
    "learned_modes",
    "medium_under_mode_m",
    "pinned_misfits",
]
