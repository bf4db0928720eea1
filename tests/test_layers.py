"""The layers hold, checked two ways.

Statically, over every module of ``helixd/`` (top-level, function-local and TYPE_CHECKING
imports alike): each package imports only itself and the rows below it in :data:`LAYERS`; the
simulator imports only :data:`SIM_MAY_IMPORT`, the plant under it only :data:`PLANT_MAY_IMPORT`,
and only the CLI imports either (and the simulator the plant); there is no import loop between
modules; no re-export shim module is left. One import path per name: every
``from helixd.X import Name`` in helixd/, tests/ and tools/ names the module that defines
``Name`` (or ``Name`` is a submodule of ``helixd.X``), and no package ``__init__.py`` imports a
helixd module (``helixd.mission.formats``, which defines code of its own, excepted).

Through ``sys.modules`` in a fresh interpreter:

* the base layer (:mod:`helixd.base`) is standard library only;
* the control core loads only the base (and numpy): no pydantic, YAML, asyncio or sockets, and
  nothing of the mission loader, the config or the I/O shell;
* the simulator is an independent oracle: it loads nothing of the controller, the link or the
  daemon (its physics has its own eq. 1, :mod:`helixd.plant.forward`); the plant loads nothing
  of them nor of the simulator.
"""

from __future__ import annotations

import ast
import itertools
import json
import os
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pytest

from helixd.config.control import ControlConfig, SlipConfig
from helixd.config.vehicle import ScrollCalibration, VehicleConfig
from helixd.control import params
from tests.support.paths import REPO_ROOT

REPO = REPO_ROOT
PACKAGE = REPO / "helixd"

# Rows from the bottom: a package may import itself and any package of a lower row.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("base",),  # stdlib only: geometry, angles, frames, plan types, exit codes, polygons
    ("control", "files", "mav"),  # pure core; hostile-input readers; MAVLink constants, URLs
    ("config",),  # helixd.yaml sections
    ("mission",),  # models, formats, validation, survey, resume, geodesy
    ("planning",),
    ("link",),  # transport, codec, plugins, vehicle state
    ("recorder", "actuators", "safety"),
    ("prepare", "report"),  # a flight built and checked before anything is sent; reporting
    ("runtime",),  # flying: daemon phases, flight loop, host, signals
    ("serve", "commands"),  # the all-day service; the one-shot commands' back ends
    ("cli",),  # typer app: parse, call, print
)
SIM_MAY_IMPORT = frozenset({"base", "files", "mav", "config", "plant", "sim"})
PLANT_MAY_IMPORT = frozenset({"base", "files", "mav", "config", "plant"})
ONLY_CLI_IMPORTS_SIM = frozenset({"cli", "sim"})
APART = frozenset({"plant", "sim"})  # beside the rows: the simulator and its plant
RANK = {pkg: row for row, pkgs in enumerate(LAYERS) for pkg in pkgs}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _resolve(name: str) -> str | None:
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def imports_of(module: str, path: Path | None = None) -> set[str]:
    """Every helixd module ``module`` (at ``path``) imports, wherever the statement stands."""
    path = MODULES[module] if path is None else path
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        targets: list[str] = []
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join([*up, base] if base else up)
            subs = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in MODULES]
            targets = subs if len(subs) == len(node.names) else [*subs, base]
        for target in targets:
            if target == "helixd" or target.startswith("helixd."):
                resolved = _resolve(target)
                if resolved is not None and resolved != module:
                    found.add(resolved)
    return found


def _room(module: str) -> str:
    """The package (or top-level module) a module lives in: helixd.link.wire.codec → link."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def violation(module: str, target: str) -> str | None:
    """Why ``module`` may not import ``target`` (None: it may)."""
    here, there = _room(module), _room(target)
    if there in ("", here) or here == "__main__":
        return None  # the helixd package itself (its version), or the same package
    if there in APART and here not in ONLY_CLI_IMPORTS_SIM:
        return f"{module} imports {target}: only the CLI imports the simulator and the plant"
    if here == "plant":
        ok = there in PLANT_MAY_IMPORT
        return None if ok else f"{module} imports {target}: the plant stands apart"
    if here == "sim":
        ok = there in SIM_MAY_IMPORT
        return None if ok else f"{module} imports {target}: the simulator stands apart"
    if there in APART:
        return None  # the CLI starts the simulator or the plant
    if RANK[there] >= RANK[here]:
        return f"{module} imports {target}: {there} is not below {here}"
    return None


def layer_violations() -> list[str]:
    found = (violation(m, t) for m in MODULES for t in sorted(imports_of(m)))
    return [why for why in found if why is not None]


def test_every_package_has_a_row() -> None:
    rooms = {_room(m) for m in MODULES} - {"", "__main__", *APART}
    assert rooms == set(RANK), f"not in LAYERS: {sorted(rooms - set(RANK))}"


def test_packages_import_only_lower_rows() -> None:
    assert layer_violations() == []


@pytest.mark.parametrize(
    ("module", "target"),
    [
        ("helixd.config", "helixd.link.connection"),  # a lower row importing a higher one
        ("helixd.mission.model", "helixd.recorder.events"),
        ("helixd.control.navigator", "helixd.files.yamlio"),  # same row, not below
        ("helixd.sim.core", "helixd.link.wire.codec"),  # the simulator stands apart
        ("helixd.runtime.daemon", "helixd.sim.server"),  # only the CLI starts a simulator
        ("helixd.runtime.daemon", "helixd.plant.physics"),  # nor the plant
        ("helixd.plant.json_physics", "helixd.sim.core"),  # the plant is below the simulator
        ("helixd.plant.physics", "helixd.control.kinematics"),  # an oracle: its own eq. 1
    ],
)
def test_the_checker_names_a_back_edge(module: str, target: str) -> None:
    assert violation(module, target) is not None


def test_the_checker_sees_function_local_and_type_checking_imports(tmp_path: Path) -> None:
    src = tmp_path / "probe.py"
    src.write_text(
        "from typing import TYPE_CHECKING\n"
        "if TYPE_CHECKING:\n    from helixd.link.connection import Autopilot\n"
        "def f():\n    from helixd.runtime import daemon\n"
    )
    found = imports_of("helixd.config", src)
    assert {"helixd.link.connection", "helixd.runtime.daemon"} <= found
    assert violation("helixd.config", "helixd.runtime.daemon") is not None


def test_no_import_loop_between_modules() -> None:
    graph = {m: imports_of(m) for m in MODULES}
    state: dict[str, int] = defaultdict(int)  # 0 new, 1 on the stack, 2 done
    loops: list[list[str]] = []

    def visit(node: str, stack: list[str]) -> None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph[node]):
            if state[nxt] == 1:
                loops.append([*stack[stack.index(nxt) :], nxt])
            elif state[nxt] == 0:
                visit(nxt, stack)
        stack.pop()
        state[node] = 2

    for module in sorted(graph):
        if state[module] == 0:
            visit(module, [])
    # a package's __init__ importing its own submodules is how a package exports
    real = [
        loop
        for loop in loops
        if not any(m.rpartition(".")[0] == n or n == m for m, n in itertools.pairwise(loop))
    ]
    assert real == [], " ; ".join(" → ".join(loop) for loop in real)


def test_prepare_touches_nothing_of_the_link() -> None:
    """What is built and checked before anything is sent never reaches the link, not even
    through the recorder's readers it uses (resume directories, the ground profile)."""
    graph = {m: imports_of(m) for m in MODULES}
    prepare = [m for m in MODULES if _room(m) == "prepare"]
    assert prepare
    reached: set[str] = set()
    todo = list(prepare)
    while todo:
        for nxt in graph[todo.pop()] - reached:
            reached.add(nxt)
            todo.append(nxt)
    assert sorted(m for m in reached if _room(m) in ("link", "runtime", "report")) == []


def test_no_reexport_shims_left() -> None:
    for gone in ("helixd.frames", "helixd.geometry", "helixd.control.angles", "helixd.vehicle"):
        assert gone not in MODULES


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


NOT_IN_THE_ORACLE = (
    "helixd.control",
    "helixd.link",
    "helixd.runtime.daemon",
    "helixd.runtime.flight",
    "helixd.link.vehicle",
)


def test_simulator_loads_nothing_of_the_controller_link_or_daemon() -> None:
    loaded = loaded_after_import("helixd.sim", "helixd.sim.server")
    assert "helixd.sim.server" in loaded  # the import really reached the simulator
    assert "helixd.plant.physics" in loaded  # and the plant under it
    bad = {m for m in helixd_modules(loaded) if m.startswith(NOT_IN_THE_ORACLE)}
    assert not bad, f"helixd.sim loads {sorted(bad)}"


def test_plant_loads_nothing_of_the_simulator_controller_link_or_daemon() -> None:
    loaded = loaded_after_import("helixd.plant", "helixd.plant.json_server")
    assert "helixd.plant.physics" in loaded  # the import really reached the plant
    bad = {m for m in helixd_modules(loaded) if m.startswith((*NOT_IN_THE_ORACLE, "helixd.sim"))}
    assert not bad, f"helixd.plant loads {sorted(bad)}"


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
    assert "helixd.mission.resolve" in loaded
    bad = {m for m in helixd_modules(loaded) if m.startswith("helixd.control")}
    assert not bad, f"helixd.mission loads {sorted(bad)}"


# One import path per name: every name is imported from the module that defines it, and a
# package's __init__.py re-exports nothing.
IMPORT_ROOTS = ("helixd", "tests", "tools")
# __init__.py files that define real code of their own (and may import what that code uses)
INIT_WITH_CODE = frozenset({"helixd.mission.formats"})


def _defined_names(path: Path) -> set[str]:
    """The names a module defines at module level: def, class, assignment or annotated
    assignment (``X: TypeAlias = ...`` included; Python 3.11 has no ``type`` statement), not a
    bare import; including inside a module-level if/try/with."""
    names: set[str] = set()

    def targets(node: ast.expr) -> None:
        if isinstance(node, ast.Name):
            names.add(node.id)
        elif isinstance(node, ast.Tuple | ast.List):
            for elt in node.elts:
                targets(elt)
        elif isinstance(node, ast.Starred):
            targets(node.value)

    def walk(body: list[ast.stmt]) -> None:
        for stmt in body:
            if isinstance(stmt, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                names.add(stmt.name)
            elif isinstance(stmt, ast.Assign):
                for target in stmt.targets:
                    targets(target)
            elif isinstance(stmt, ast.AnnAssign | ast.AugAssign):
                targets(stmt.target)
            elif isinstance(stmt, ast.If | ast.Try | ast.With):
                walk(stmt.body)
                walk(getattr(stmt, "orelse", []))
                for handler in getattr(stmt, "handlers", []):
                    walk(handler.body)
                walk(getattr(stmt, "finalbody", []))

    walk(ast.parse(path.read_text(encoding="utf-8")).body)
    return names


def _is_module(name: str) -> bool:
    return name in MODULES or (REPO / Path(*name.split("."))).is_dir()


def _shown(path: Path) -> str:
    return str(path.relative_to(REPO)) if path.is_relative_to(REPO) else path.name


def indirect_imports(paths: list[Path]) -> list[str]:
    """``file:line name`` for each ``from helixd.X import Name`` where ``Name`` is neither a
    submodule of ``helixd.X`` nor defined at module level in ``helixd.X``."""
    defined: dict[str, set[str]] = {}
    found: list[str] = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.ImportFrom) or node.level or node.module is None:
                continue
            module = node.module
            if module != "helixd" and not module.startswith("helixd."):
                continue
            if module not in MODULES:
                found.append(f"{_shown(path)}:{node.lineno} {module}: no such module")
                continue
            if module not in defined:
                defined[module] = _defined_names(MODULES[module])
                if module == "helixd":
                    defined[module].add("__version__")  # computed by its __getattr__ (PEP 562)
            for alias in node.names:
                if alias.name in defined[module] or _is_module(f"{module}.{alias.name}"):
                    continue
                where = f"{_shown(path)}:{node.lineno}"
                found.append(f"{where} {alias.name} from {module}, which does not define it")
    return found


def _python_files() -> list[Path]:
    return sorted(p for root in IMPORT_ROOTS for p in (REPO / root).rglob("*.py"))


def test_every_name_is_imported_from_the_module_that_defines_it() -> None:
    offenders = indirect_imports(_python_files())
    assert offenders == [], "\n".join(offenders)


def test_the_import_checker_names_a_reexported_name(tmp_path: Path) -> None:
    probe = tmp_path / "probe.py"
    probe.write_text(
        "from helixd.mav.constants import MAV_CMD_DO_SET_SERVO\n"  # defined there
        "from helixd.mav import servo_functions\n"  # a submodule
        "from helixd.link.services.preflight import DO_SET_SERVO_FUNCTIONS\n"  # only imported there
    )
    offenders = indirect_imports([probe])
    assert len(offenders) == 1
    assert offenders[0].endswith(
        ":3 DO_SET_SERVO_FUNCTIONS from helixd.link.services.preflight, which does not define it"
    )


def test_package_inits_import_no_helixd_module() -> None:
    offenders = []
    for module, path in MODULES.items():
        if path.name != "__init__.py" or module in INIT_WITH_CODE:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                names = [f"{'.' * node.level}{node.module or ''}"]
            else:
                continue
            bad = [n for n in names if n.startswith(("helixd", "."))]
            offenders += [f"{path.relative_to(REPO)}:{node.lineno} imports {n}" for n in bad]
    assert offenders == [], "\n".join(offenders)
