"""The inbound handler depends on the core only through its narrow port (no import loop)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

import helixd.sim.inbound as inbound
from helixd.sim.core import SimCore
from helixd.sim.sim_config import SimConfig


def imported_modules(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


def test_inbound_does_not_import_the_core() -> None:
    names = imported_modules(Path(inbound.__file__))
    assert not {n for n in names if n.startswith("helixd.sim.core")}, names


def test_the_core_provides_every_member_of_the_port() -> None:
    members = [*inbound.InboundPort.__annotations__] + [  # its attributes, then its methods
        name
        for name, value in vars(inbound.InboundPort).items()
        if not name.startswith("_") and callable(value)
    ]
    assert {"ap", "params", "now_s", "view_now", "send", "record", "streams"} <= set(members)
    core = SimCore(SimConfig(), 1, np.random.default_rng(0))
    missing = [name for name in members if not hasattr(core, name)]
    assert not missing, missing
    assert core.inbound.core is core
