"""helixd.serve.options: what the service was started with."""

from __future__ import annotations

from pathlib import Path

from helixd.config.root import HelixdConfig
from helixd.serve.options import SERVE_OPTIONS, STATE_FILE_NAME, ServeOptions


def test_the_state_file_is_under_the_run_root_unless_the_config_names_one(
    tmp_path: Path,
) -> None:
    opts = ServeOptions(HelixdConfig(), None, tmp_path / "runs")
    assert opts.state_file == tmp_path / "runs" / STATE_FILE_NAME
    own = HelixdConfig.model_validate({"serve": {"state_file": str(tmp_path / "s.json")}})
    assert ServeOptions(own, None, tmp_path / "runs").state_file == tmp_path / "s.json"


def test_a_served_flight_lets_an_operator_continue_a_hold() -> None:
    """serve's walk: an operator's DO_PAUSE_CONTINUE 1 ends a NAV_LOITER_UNLIM hold, so its
    default options allow it; the rest is the mission's own walk."""
    opts = ServeOptions(HelixdConfig(), None, Path("runs"))
    assert opts.options is SERVE_OPTIONS and SERVE_OPTIONS.operator_continue
    assert (opts.mode, opts.mission_file, opts.occupancy) == (None, None, None)
