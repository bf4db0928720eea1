"""What ``helixd check`` prints about a mission with commands: the flight as ArduPilot Rover
flies it, one line per navigation step (jumps expanded), the do/condition items under the step
they start with, and when each step ends by the estimate. Pure: text out, nothing printed.
"""

from __future__ import annotations

import math
import textwrap

from helixd.base.angles import wrap_pi
from helixd.base.plan import ActionKind, MotionMode, Plan

MAX_STEP_LINES = 200  # steps listed (first and last ones) before the rest is counted
DEFAULT_WIDTH = 88  # columns of the step table when the terminal's width is not known
WHAT_MAX = 62  # the "what" column at most this wide …
WHAT_MIN = 24  # … and at least this wide, however narrow the terminal
FIXED_COLUMNS = 26  # step, item, speed and end, with the spaces between the columns


def step_end_times_s(
    plan: Plan, yaw_rate_radps: float, start_xy_m: tuple[float, float]
) -> list[float]:
    """For each step of the plan's program, the estimated time (s) it completes: each leg at
    its step's speed, turns in place (ROLL/SCROLL) at ``yaw_rate_radps``, holds waited."""
    program = plan.program
    if program is None:
        return []
    speeds = plan.leg_speeds_mps()
    px, py = start_xy_m
    heading = 0.0 if plan.mode is MotionMode.ROLL else math.pi / 2
    t = 0.0
    out: list[float] = []
    for step in program.steps:
        if step.first_waypoint is not None and step.last_waypoint is not None:
            for i in range(step.first_waypoint, step.last_waypoint + 1):
                wp = plan.waypoints[i]
                t += math.hypot(wp.x_m - px, wp.y_m - py) / speeds[i]
                if plan.mode is not MotionMode.OMNI and yaw_rate_radps > 0:
                    leg = math.atan2(wp.y_m - py, wp.x_m - px)
                    t += abs(wrap_pi(leg - heading)) / yaw_rate_radps
                    heading = leg
                px, py = wp.x_m, wp.y_m
        t += step.hold_s
        out.append(t)
    return out


def _wrap(text: str, width: int) -> list[str]:
    """``text`` in lines of at most ``width`` characters, split between words, never cut
    (a word longer than the line gets a line of its own)."""
    return textwrap.wrap(text, width, break_long_words=False, break_on_hyphens=False) or [""]


def program_lines(
    plan: Plan,
    yaw_rate_radps: float,
    start_xy_m: tuple[float, float],
    width: int = DEFAULT_WIDTH,
) -> list[str]:
    """The flight as lines: ``step item command what speed end``, actions indented below;
    a text longer than its column wraps onto the next lines (``width``: the terminal's)."""
    program = plan.program
    if program is None:
        return []
    ends = step_end_times_s(plan, yaw_rate_radps, start_xy_m)
    what_w = max(WHAT_MIN, min(WHAT_MAX, width - FIXED_COLUMNS))
    text_w = max(WHAT_MIN, width - 14)  # an action's or a skipped item's line
    blank = f"{'':>5} {'':>4}  "
    lines = [
        f"flight  : {len(program.steps)} steps as ArduPilot Rover flies the items (jumps "
        "expanded); speed in m/s, end = estimated time the step completes",
        f"{'step':>5} {'item':>4}  {'what':<{what_w}} {'speed':>5} {'end':>7}",
    ]

    def below(item: str, mark: str, text: str) -> list[str]:
        parts = _wrap(text, text_w)
        head = f"{'':>5} {item:>4}  {mark} {parts[0]}"
        return [head, *(f"{blank}  {p}" for p in parts[1:])]

    count = len(program.steps)
    head = count if count <= MAX_STEP_LINES else MAX_STEP_LINES // 2
    for k, (step, end) in enumerate(zip(program.steps, ends, strict=True)):
        if head <= k < count - (MAX_STEP_LINES - head):
            if k == head:
                lines.append(f"  ... {count - MAX_STEP_LINES} steps not shown ...")
            continue
        for text in step.skipped:
            lines.extend(below("", "-", text))
        moves = step.first_waypoint is not None
        speed = f"{step.speed_mps:5.2f}" if moves else f"{'-':>5}"
        what, jump, rest = step.text.partition(" (after ")  # the jump note: kept whole
        parts = _wrap(what, what_w)
        if jump:
            note = f"(after {rest}"
            if len(parts[-1]) + 1 + len(note) <= what_w:
                parts[-1] += f" {note}"
            else:
                parts += _wrap(note, what_w)
        lines.append(
            f"{k + 1:>5} {step.item:>4}  {parts[0]:<{what_w}} {speed} {end:>6.0f}s".rstrip()
        )
        lines.extend(f"{blank}{p}" for p in parts[1:])
        for a in step.actions:
            lines.extend(below(str(a.item), "~" if a.kind is ActionKind.NOTE else "+", a.text))
    for a in program.final_actions:
        lines.extend(below(str(a.item), "+", f"{a.text} (at the end)"))
    if program.ending:
        lines.append(f"  ends: {program.ending}")
    return lines


__all__ = ["DEFAULT_WIDTH", "program_lines", "step_end_times_s"]
