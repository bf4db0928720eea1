"""The Helix plant on a UDP port for ArduPilot SITL ``--model JSON`` (the I/O shell of
:mod:`helixd.plant.json_physics`).

SITL sends each frame's servo outputs to ``127.0.0.1:9002`` (+10 per ``-I`` instance) and
waits, lockstep, for the answer on the same socket: the plant answers every datagram to the
address it came from. It runs until ``stop`` is set (or the process is interrupted). With
``truth_csv`` it also writes the plant's true pose, ten rows per simulated second: the
ground truth that SITL's EKF estimates, for measuring a flight on what really happened.
"""

from __future__ import annotations

import csv
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

import structlog

from helixd.plant.json_physics import FrameError, JsonPlant, decode_servo_frame
from helixd.plant.plant_config import PlantConfig

log = structlog.get_logger(__name__)

RECV_TIMEOUT_S = 0.2  # how often a quiet loop looks at ``stop``
MAX_DATAGRAM_BYTES = 256  # a servo packet is 40 or 72 bytes
TRUTH_PERIOD_S = 0.1  # simulated seconds between truth rows
PROGRESS_PERIOD_S = 10.0  # simulated seconds between rate reports
TRUTH_COLUMNS = ("t_s", "north_m", "east_m", "yaw_ned_rad", "speed_mps", "s1", "s2", "s3", "s4")


@dataclass(frozen=True, slots=True)
class PlantStats:
    frames: int
    bad_datagrams: int
    restarts: int
    sim_time_s: float
    wall_time_s: float

    @property
    def rate_hz(self) -> float:
        """Frames per wall second: the lockstep rate reached (SITL's own frame rate is the cap)."""
        return self.frames / self.wall_time_s if self.wall_time_s > 0 else 0.0


class _TruthWriter:
    def __init__(self, stream: TextIO) -> None:
        self._writer = csv.writer(stream)
        self._writer.writerow(TRUTH_COLUMNS)
        self._stream = stream
        self._next_s = 0.0

    def maybe_write(self, plant: JsonPlant) -> None:
        if plant.time_s + 1e-9 < self._next_s:
            return
        s = plant.state
        self._writer.writerow(
            [
                f"{plant.time_s:.4f}",
                f"{s.north_m:.4f}",
                f"{s.east_m:.4f}",
                f"{s.yaw_ned_rad:.5f}",
                f"{s.speed_mps:.4f}",
                *(f"{f:.4f}" for f in plant.scroll_fractions),
            ]
        )
        self._stream.flush()
        self._next_s = plant.time_s + TRUTH_PERIOD_S

    def restart(self) -> None:
        self._next_s = 0.0


def open_socket(host: str, port: int) -> socket.socket:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.settimeout(RECV_TIMEOUT_S)
    return sock


def serve_plant(
    cfg: PlantConfig,
    sock: socket.socket,
    stop: threading.Event,
    truth_csv: Path | None = None,
) -> PlantStats:
    """Answer SITL's frames on ``sock`` until ``stop`` is set; the socket is closed after."""
    plant = JsonPlant(cfg)
    bad = 0
    peer: tuple[str, int] | None = None
    started = time.monotonic()
    next_progress_s = PROGRESS_PERIOD_S
    last_progress = (started, 0)
    truth_file = truth_csv.open("w", encoding="utf-8", newline="") if truth_csv else None
    truth = _TruthWriter(truth_file) if truth_file is not None else None
    try:
        while not stop.is_set():
            try:
                data, addr = sock.recvfrom(MAX_DATAGRAM_BYTES)
            except TimeoutError:
                continue
            try:
                frame = decode_servo_frame(data)
            except FrameError as exc:
                bad += 1
                if bad == 1 or bad % 1000 == 0:
                    log.warning(
                        "plant_bad_datagram",
                        sender=f"{addr[0]}:{addr[1]}",
                        problem=str(exc),
                        count=bad,
                    )
                continue
            if addr != peer:
                peer = addr
                log.info(
                    "plant_connected",
                    sitl=f"{addr[0]}:{addr[1]}",
                    frame_rate_hz=frame.frame_rate_hz,
                )
            restarts = plant.restarts
            report = plant.step(frame)
            if plant.restarts != restarts:
                log.warning("plant_restarted", reason="SITL's frame count went back: it restarted")
                next_progress_s = PROGRESS_PERIOD_S
                if truth is not None:
                    truth.restart()
            sock.sendto(report.to_json_bytes(), addr)
            if truth is not None:
                truth.maybe_write(plant)
            if plant.time_s >= next_progress_s:
                now = time.monotonic()
                wall = now - last_progress[0]
                frames = plant.frames - last_progress[1]
                log.info(
                    "plant_progress",
                    sim_time_s=round(plant.time_s, 1),
                    frame_rate_hz=frame.frame_rate_hz,
                    wall_rate_hz=round(frames / wall, 1) if wall > 0 else None,
                    north_m=round(plant.state.north_m, 2),
                    east_m=round(plant.state.east_m, 2),
                )
                last_progress = (now, plant.frames)
                next_progress_s += PROGRESS_PERIOD_S
    finally:
        sock.close()
        if truth_file is not None:
            truth_file.close()
    return PlantStats(plant.frames, bad, plant.restarts, plant.time_s, time.monotonic() - started)
