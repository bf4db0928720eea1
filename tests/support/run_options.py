"""The in-process daemon run the integration tests start: the shipped square mission with
:func:`helixd.runtime.daemon.run_mission`'s options (one place, so test modules do not repeat
the setup)."""

from __future__ import annotations

from pathlib import Path

from helixd.config.root import HelixdConfig
from helixd.mission.model import load_mission
from helixd.runtime.daemon import RunOptions
from tests.support.harness import MISSIONS

SQUARE = MISSIONS / "square.yaml"


def sim_run_config(url: str) -> HelixdConfig:
    """The daemon's config against a simulator at ``url``: defaults, a quick arm retry."""
    return HelixdConfig.model_validate(
        {"link": {"url": url}, "startup": {"arm_retry_interval_s": 0.5}}
    )


def square_run(cfg: HelixdConfig, url: str, run_root: Path) -> RunOptions:
    """Options to fly the shipped square on ``url`` with ``cfg``, recording under ``run_root``,
    without a terminal."""
    return RunOptions(
        cfg=cfg,
        mission=load_mission(SQUARE),
        mission_yaml=SQUARE.read_text(),
        connect_url=url,
        run_root=run_root,
        tty=False,
    )
