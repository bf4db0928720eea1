#!/usr/bin/env python3
"""Benchmark the built-in simulator.

1. Core cost: one 50 Hz scheduler loop (autopilot + physics + estimator + telemetry build),
   no sockets, thesis noise, 40 Hz pose streams granted on one link.
2. On the wire: a pymavlink GCS asks for helixd's rates; simulated/wall time ratio, messages
   per second received and CPU (simulator thread + client) at several speed-ups.

Usage: python tools/bench_sim.py [--seconds 3]
"""

from __future__ import annotations

import os
import resource
import time

import numpy as np
import typer

os.environ.setdefault("MAVLINK20", "1")

from pymavlink import mavutil

from helixd.sim import stream_rates as st
from helixd.sim.core import SimCore
from helixd.sim.server import start_embedded
from helixd.sim.sim_config import SimConfig

POSE_INTERVAL_MS = 25
TELEMETRY_INTERVAL_MS = 100


def cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def bench_core(sim_seconds: float) -> float:
    """Mean µs per simulated loop."""
    core = SimCore(SimConfig(noise="thesis", seed=1), 1, np.random.default_rng(1))
    schedule = core.links[0].streams
    for msg_id in (st.MSG_LOCAL_POSITION_NED, st.MSG_ATTITUDE):
        schedule.set_interval(msg_id, POSE_INTERVAL_MS, 0.0)
    for msg_id in (st.MSG_SERVO_OUTPUT_RAW, st.MSG_RC_CHANNELS, st.MSG_EKF_STATUS_REPORT):
        schedule.set_interval(msg_id, TELEMETRY_INTERVAL_MS, 0.0)
    loops = round(sim_seconds / core.dt_s())
    start = time.perf_counter()
    for _ in range(loops):
        core.tick()
        core.drain_outbox()
        core.drain_events()
    return (time.perf_counter() - start) / loops * 1e6


def bench_wire(speedup: float, wall_seconds: float) -> tuple[float, float, float]:
    server, url = start_embedded(SimConfig(noise="thesis", seed=1, speedup=speedup))
    conn = mavutil.mavlink_connection(url, source_system=255, source_component=190)
    try:
        conn.mav.heartbeat_send(6, 8, 0, 0, 0)
        conn.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=30)
        for msg_id, interval_ms in (
            (st.MSG_LOCAL_POSITION_NED, POSE_INTERVAL_MS),
            (st.MSG_ATTITUDE, POSE_INTERVAL_MS),
            (st.MSG_SERVO_OUTPUT_RAW, TELEMETRY_INTERVAL_MS),
            (st.MSG_RC_CHANNELS, TELEMETRY_INTERVAL_MS),
            (st.MSG_EKF_STATUS_REPORT, TELEMETRY_INTERVAL_MS),
        ):
            conn.mav.command_long_send(1, 1, 511, 0, msg_id, interval_ms * 1000, 0, 0, 0, 0, 0)
        sim0, wall0, cpu0 = server.snapshot().sim_time_s, time.monotonic(), cpu_s()
        received = 0
        while time.monotonic() - wall0 < wall_seconds:
            if conn.recv_match(blocking=True, timeout=0.1) is not None:
                received += 1
        wall = time.monotonic() - wall0
        ratio = (server.snapshot().sim_time_s - sim0) / wall
        return ratio, received / wall, 100.0 * (cpu_s() - cpu0) / wall
    finally:
        conn.close()
        server.stop()


def main(seconds: float = typer.Option(3.0, help="wall seconds per wire measurement")) -> None:
    typer.echo(f"core: {bench_core(60.0):.0f} µs per 50 Hz loop (60 simulated s, thesis noise)")
    for speedup in (1.0, 10.0, 30.0):
        ratio, rate, cpu = bench_wire(speedup, seconds)
        typer.echo(
            f"wire speedup {speedup:>4.0f}: sim/wall {ratio:5.2f}  {rate:6.0f} msgs/s  "
            f"CPU {cpu:4.0f}% of one core (simulator + client)"
        )


if __name__ == "__main__":
    typer.run(main)
