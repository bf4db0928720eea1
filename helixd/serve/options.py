"""What ``helixd serve`` was started with (the CLI builds it; the service's parts read it)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from helixd.base.plan import MotionMode
from helixd.config.root import HelixdConfig
from helixd.mission.expand import ExpandOptions
from helixd.planning.mapfile import OccupancyMap

# an operator can continue a NAV_LOITER_UNLIM here (DO_PAUSE_CONTINUE 1)
SERVE_OPTIONS = ExpandOptions(operator_continue=True)
STATE_FILE_NAME = "serve-state.json"


@dataclass
class ServeOptions:
    cfg: HelixdConfig
    config_path: Path | None  # hashed into each run's inputs (what a continue checks)
    run_root: Path
    mode: MotionMode | None = None  # --mode; else mission.ground_station_mode
    occupancy: OccupancyMap | None = None
    options: ExpandOptions = SERVE_OPTIONS
    mission_file: Path | None = None  # fly this file instead of the autopilot's mission

    @property
    def state_file(self) -> Path:
        return self.cfg.serve.state_file or self.run_root / STATE_FILE_NAME


__all__ = ["SERVE_OPTIONS", "STATE_FILE_NAME", "ServeOptions"]
