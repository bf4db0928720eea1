"""``helixd serve`` in tests: the daemon as a subprocess with the test configuration, and the
simulator with a QGC-like ground station on a second link (tests.support.gcs)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import yaml

from helixd.sim.server import SimServer
from helixd.sim.snapshot import SimSnapshot
from tests.support.daemon import DaemonProc, spawn_daemon
from tests.support.gcs import QGC_SYSID
from tests.support.harness import BASE_CONFIG, MavClient, deep_merge, running_sim_links

SWITCH_CH = 7
LOW_US, HIGH_US = 1100, 1900
SPEEDUP = 5.0
MOVING_MPS = 0.1  # faster than this is driving
CONFIG: dict[str, Any] = {
    "mission": {"ground_station_mode": "roll"},
    "startup": {"start_switch_channel": SWITCH_CH},
    "serve": {"mission_poll_s": 1.0, "tick_s": 0.05, "state_rate_hz": 2.0},
}


def serve_proc(tmp_path: Path, url: str, extra: dict[str, Any] | None = None) -> DaemonProc:
    cfg = deep_merge(deep_merge(BASE_CONFIG, CONFIG), {"link": {"url": url}})
    cfg = deep_merge(cfg, extra or {})
    cfg_path = tmp_path / "helixd.yaml"
    cfg_path.write_text(yaml.safe_dump(cfg), encoding="utf-8")
    run_root = tmp_path / "runs"
    return spawn_daemon(
        ["serve", "--config", str(cfg_path), "--run-dir", str(run_root)],
        cwd=tmp_path,
        run_root=run_root,
    )


@contextmanager
def sim_with_ground_station(
    speedup: float = SPEEDUP, links: int = 2, **overrides: Any
) -> Iterator[tuple[SimServer, list[str], MavClient]]:
    """The simulator with ``links`` UDP links: helixd's URL first, the ground station (system
    255, connected) on the second, any others for the test; yields (server, urls, gcs).
    ``overrides``: more simulator settings (SimConfig keys)."""
    links_ = ["udpin:127.0.0.1:0"] * links
    with running_sim_links(links_, speedup=speedup, **overrides) as server:
        urls = [f"udpout:127.0.0.1:{p}" for p in server.local_ports]
        with MavClient(urls[1], sysid=QGC_SYSID) as gcs:
            yield server, urls, gcs


def moving(s: SimSnapshot) -> bool:
    """Armed and driving (from the simulator's side)."""
    return s.armed and s.speed_mps > MOVING_MPS
