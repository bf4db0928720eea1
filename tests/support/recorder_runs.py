"""A realistic flight-recorder run directory for the recorder, plot and replay tests.

``synth_run`` flies a point mass round the 10 m square with the thesis's turn-then-drive logic
and records it through the real RunRecorder, SummaryBuilder and events tee.
"""

from __future__ import annotations

import io
import math
from datetime import UTC, datetime
from pathlib import Path

import structlog

from helixd.base.angles import shortest_angular_distance, wrap_pi
from helixd.base.geometry import BodyVelocity
from helixd.base.plan import MotionMode
from helixd.config.load import config_to_yaml
from helixd.config.root import HelixdConfig
from helixd.control.kinematics import body_to_fractions
from helixd.recorder import logging_setup
from helixd.recorder.rows import FlightRow
from helixd.recorder.rundir import RunRecorder
from helixd.recorder.summary import SummaryBuilder

NOW = datetime(2026, 11, 21, 3, 15, 0, tzinfo=UTC)
SQUARE_YAML = """\
name: square
mode: roll
frame: start
waypoints:
- {x: 10.0, y: 0.0}
- {x: 10.0, y: 10.0}
- {x: 0.0, y: 10.0}
- {x: 0.0, y: 0.0}
"""
SQUARE = [(10.0, 0.0), (10.0, 10.0), (0.0, 10.0), (0.0, 0.0)]


class FakeClock:
    def __init__(self, start_s: float = 1000.0) -> None:
        self.t = start_s

    def __call__(self) -> float:
        return self.t

    def advance(self, dt_s: float) -> None:
        self.t += dt_s


def synth_run(
    root: Path,
    *,
    fault_at_s: float | None = None,
    fault_cause: str = "stall",
    pause_s: tuple[float, float] | None = None,
    rate_hz: float = 20.0,
    cfg: HelixdConfig | None = None,
    speedup: float = 1.0,
) -> tuple[Path, FakeClock]:
    """Fly a point mass round the 10 m square (ROLL: turn in place, then drive) and record it
    through RunRecorder + SummaryBuilder + the events tee. ``fault_at_s``: stop there with a
    ``fallback`` event (cause ``fault_cause``) as the supervisor would; ``pause_s``: held
    for the crew (``mode_gate`` events) from its start to its end (s). ``speedup``: the autopilot
    clock (``t_boot_s``) runs this much faster than the wall clock, as in a sped-up simulator
    (the point mass still moves on the wall clock)."""
    cfg = cfg or HelixdConfig()
    clock = FakeClock(5000.0)
    logging_setup.configure_logging(tty=False, stream=io.StringIO(), clock=clock)
    log = structlog.get_logger("synth")
    rec = RunRecorder.create(
        root, "square", config_to_yaml(cfg), SQUARE_YAML, cfg.recorder, NOW, clock=clock
    )
    builder = SummaryBuilder("square", "roll", len(SQUARE), SQUARE[-1])
    dt = 1.0 / rate_hz
    x = y = yaw = 0.0
    t0 = clock()
    target = 0
    fault: str | None = None
    paused = "before"
    tol = cfg.control.waypoint_tolerance_m
    prev_xy = (x, y)
    while target < len(SQUARE) and clock() - t0 < 300.0:
        t_rel = clock() - t0
        if fault_at_s is not None and t_rel >= fault_at_s:
            fault = fault_cause
            log.warning("fallback", cause=fault, detail="measured speed 0.00 m/s for 4.0 s")
            break
        if pause_s is not None and t_rel >= pause_s[0] and paused == "before":
            paused = "held"
            log.info("mode_gate", gate="hold", mode="HOLD")
        if pause_s is not None and t_rel >= pause_s[1] and paused == "held":
            paused = "after"
            log.info("mode_gate", gate="drive", mode="AUTO")
        tx, ty = SQUARE[target]
        dist = math.hypot(tx - x, ty - y)
        if dist < tol:
            builder.arrival(target, 100.0 + speedup * t_rel, dist)
            log.info("waypoint_reached", index=target, error_m=round(dist, 3))
            target += 1
            continue
        leg_start = SQUARE[target - 1] if target else (0.0, 0.0)
        lx, ly = tx - leg_start[0], ty - leg_start[1]
        leg_len = math.hypot(lx, ly) or 1.0
        xt = (lx * (y - leg_start[1]) - ly * (x - leg_start[0])) / leg_len
        herr = shortest_angular_distance(yaw, math.atan2(ty - y, tx - x))
        wz = max(-1.0, min(1.0, 8.0 * herr))
        vx = 0.0 if abs(herr) > 0.2 else min(0.6, 1.2 * dist)
        frac = body_to_fractions(BodyVelocity(vx, 0.0, wz), cfg.vehicle, MotionMode.ROLL)
        speed = math.hypot(x - prev_xy[0], y - prev_xy[1]) / dt
        row = FlightRow(
            t_boot_s=100.0 + speedup * t_rel,
            t_mono_s=clock(),
            north_m=x,
            east_m=-y,
            yaw_ned_rad=wrap_pi(-yaw),
            x_m=x,
            y_m=y,
            yaw_rad=yaw,
            target_index=target,
            target_x_m=tx,
            target_y_m=ty,
            distance_error_m=dist,
            heading_error_rad=herr,
            cross_track_m=xt,
            dist_p=1.2 * dist,
            dist_i=0.0,
            dist_d=0.0,
            yaw_p=8.0 * herr,
            yaw_i=0.0,
            yaw_d=0.0,
            vx_cmd_mps=vx,
            vy_cmd_mps=0.0,
            wz_cmd_radps=wz,
            speed_meas_mps=speed,
            scroll1=float(frac[0]),
            scroll2=float(frac[1]),
            scroll3=float(frac[2]),
            scroll4=float(frac[3]),
            pwm1_us=int(1500 + 500 * frac[0]),
            pwm2_us=int(1500 + 500 * frac[1]),
            pwm3_us=int(1500 + 500 * frac[2]),
            pwm4_us=int(1500 + 500 * frac[3]),
            mode="MANUAL",
            armed=True,
            nav_state="align" if vx == 0.0 else "track",
            link_ok=True,
            pose_fresh=True,
        )
        rec.record(row)
        builder.add(row)
        prev_xy = (x, y)
        yaw = wrap_pi(yaw + wz * dt)
        x += vx * math.cos(yaw) * dt
        y += vx * math.sin(yaw) * dt
        clock.advance(dt)
    completed = target == len(SQUARE)
    rec.finish(builder.build(completed, fault, 0 if completed else 4))
    assert rec.run_dir is not None and not rec.degraded
    return rec.run_dir, clock
