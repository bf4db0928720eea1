"""What ``helixd check`` prints about a mission with commands: the flight as ArduPilot Rover
flies it, one line per navigation step (jumps expanded), the do/condition items under the step
they start with, and when each step ends by the estimate. Pure: text out, nothing printed.
"""

from __future__ import annotations

import math

from helixd.base.angles import wrap_pi
from helixd.base.plan import ActionKind, MotionMode, Plan

MAX_STEP_LINES = 200  # steps listed (first and last ones) before the rest is counted


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


def program_lines(plan: Plan, yaw_rate_radps: float, start_xy_m: tuple[float, float]) -> list[str]:
    """The flight as lines: ``step item command what speed end``, actions indented below."""
    program = plan.program
    if program is None:
        return []
    ends = step_end_times_s(plan, yaw_rate_radps, start_xy_m)
    lines = [
        f"flight  : {len(program.steps)} steps as ArduPilot Rover flies the items (jumps "
        "expanded); speed in m/s, end = estimated time the step completes",
        f"{'step':>5} {'item':>4}  {'what':<62} {'speed':>5} {'end':>7}",
    ]
    count = len(program.steps)
    head = count if count <= MAX_STEP_LINES else MAX_STEP_LINES // 2
    for k, (step, end) in enumerate(zip(program.steps, ends, strict=True)):
        if head <= k < count - (MAX_STEP_LINES - head):
            if k == head:
                lines.append(f"  ... {count - MAX_STEP_LINES} steps not shown ...")
            continue
        lines.extend(f"{'':>5} {'':>4}  - {text}" for text in step.skipped)
        moves = step.first_waypoint is not None
        speed = f"{step.speed_mps:5.2f}" if moves else f"{'-':>5}"
        lines.append(f"{k + 1:>5} {step.item:>4}  {step.text[:62]:<62} {speed} {end:>6.0f}s")
        for a in step.actions:
            mark = "~" if a.kind is ActionKind.NOTE else "+"
            lines.append(f"{'':>5} {a.item:>4}  {mark} {a.text[:80]}")
    for a in program.final_actions:
        lines.append(f"{'':>5} {a.item:>4}  + {a.text[:80]} (at the end)")
    if program.ending:
        lines.append(f"  ends: {program.ending}")
    return lines


__all__ = ["program_lines", "step_end_times_s"]
