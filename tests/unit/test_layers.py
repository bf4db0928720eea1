"""The layers hold: checked through ``sys.modules`` in a fresh interpreter, not by reading code.

* the base layer (:mod:`helixd.base`) is standard library only;
* the control core loads only the base (and numpy): no pydantic, YAML, asyncio or sockets, and
  nothing of the mission loader, the config or the I/O shell;
* the simulator is an independent oracle: it loads nothing of the controller, the link or the
  daemon (its physics has its own eq. 1, :mod:`helixd.sim.forward`).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from helixd.config import ControlConfig, ScrollCalibration, SlipConfig, VehicleConfig
from helixd.control import params

REPO = Path(__file__).resolve().parents[2]

BASE_MODULES = (
    "helixd.base.geometry",
    "helixd.base.angles",
    "helixd.base.frames",
    "helixd.base.plan",
)
CONTROL_MODULES = (
    "helixd.control.navigator",
    "helixd.control.guidance",
    "helixd.control.line",
    "helixd.control.pid",
    "helixd.control.kinematics",
    "helixd.control.slip",
    "helixd.control.params",
)
HEAVY = ("pydantic", "yaml", "asyncio", "socket")


def loaded_after_import(*modules: str) -> set[str]:
    """The names in ``sys.modules`` after importing ``modules`` in a fresh interpreter."""
    code = (
        "import importlib, json, sys\n"
        f"for name in {list(modules)!r}:\n"
        "    importlib.import_module(name)\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, cwd=REPO, capture_output=True, text=True, check=True
    )
    return set(json.loads(out.stdout))


def helixd_modules(loaded: set[str]) -> set[str]:
    return {m for m in loaded if m == "helixd" or m.startswith("helixd.")}


def test_base_layer_is_standard_library_only() -> None:
    loaded = loaded_after_import(*BASE_MODULES)
    assert not {m for m in loaded if m.split(".")[0] in (*HEAVY, "numpy")}
    assert helixd_modules(loaded) <= {"helixd", "helixd.base", *BASE_MODULES}


@pytest.mark.parametrize("module", CONTROL_MODULES)
def test_control_loads_only_the_base(module: str) -> None:
    loaded = loaded_after_import(module)
    assert not {m for m in loaded if m.split(".")[0] in HEAVY}, module
    others = {
        m
        for m in helixd_modules(loaded)
        if m != "helixd" and not m.startswith(("helixd.base", "helixd.control"))
    }
    assert not others, f"{module} loads {sorted(others)}"


def test_navigator_loads_neither_pydantic_yaml_asyncio_nor_socket() -> None:
    loaded = loaded_after_import("helixd.control.navigator")
    for name in HEAVY:
        assert name not in loaded


def test_simulator_loads_nothing_of_the_controller_link_or_daemon() -> None:
    loaded = loaded_after_import("helixd.sim", "helixd.sim.command")
    assert "helixd.sim.server" in loaded  # the import really reached the simulator
    forbidden = (
        "helixd.control",
        "helixd.link",
        "helixd.runtime.daemon",
        "helixd.runtime.flight",
        "helixd.link.vehicle",
    )
    bad = {m for m in helixd_modules(loaded) if m.startswith(forbidden)}
    assert not bad, f"helixd.sim loads {sorted(bad)}"


def _members(protocol: type) -> list[str]:
    return [name for name, value in vars(protocol).items() if isinstance(value, property)]


@pytest.mark.parametrize(
    ("protocol", "model"),
    [
        (params.VehicleParams, VehicleConfig()),
        (params.ScrollCalibrationParams, ScrollCalibration()),
        (params.PidGainsParams, ControlConfig().yaw_pid),
        (params.SlipParams, SlipConfig()),
        (params.NavigatorParams, ControlConfig()),
    ],
)
def test_config_models_provide_what_control_reads(protocol: type, model: object) -> None:
    members = _members(protocol)
    assert members  # the Protocol is not empty
    missing = [name for name in members if not hasattr(model, name)]
    assert not missing, f"{type(model).__name__} lacks {missing}"


def test_mission_loader_loads_nothing_of_the_controller() -> None:
    loaded = loaded_after_import("helixd.mission", "helixd.mission.validate")
    assert "helixd.mission.plan" in loaded
    bad = {m for m in helixd_modules(loaded) if m.startswith("helixd.control")}
    assert not bad, f"helixd.mission loads {sorted(bad)}"
