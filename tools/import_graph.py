"""Import-graph figures of a package (default helixd/): rooms, levels, loops.

A room is a top-level module or package of helixd (helixd.link, helixd.config, ...). Levels is
the longest chain of rooms importing each other (loops collapsed to one node); a room loop is a
set of rooms importing each other in a circle; a module loop the same between single modules.
Printed twice: with module-level imports only, and with function-local and TYPE_CHECKING
imports counted too. ``--edges`` lists which rooms each room imports.

    python tools/import_graph.py [PACKAGE_DIR] [--edges]

The layer table itself is enforced by tests/test_layers.py.
"""

from __future__ import annotations

import ast
import sys
from collections import defaultdict
from collections.abc import Iterable
from pathlib import Path

Graph = dict[str, set[str]]


def module_names(root: Path) -> dict[str, Path]:
    out: dict[str, Path] = {}
    for path in sorted(root.rglob("*.py")):
        parts = list(path.relative_to(root.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = path
    return out


def _resolve(name: str, mods: dict[str, Path]) -> str | None:
    while name and name not in mods:
        name = name.rpartition(".")[0]
    return name or None


def _targets(node: ast.AST, package: str, mods: dict[str, Path]) -> list[str]:
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    if not isinstance(node, ast.ImportFrom):
        return []
    base = node.module or ""
    if node.level:
        up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
        base = ".".join([*up, base] if base else up)
    subs = [f"{base}.{a.name}" for a in node.names if f"{base}.{a.name}" in mods]
    return subs if len(subs) == len(node.names) else [*subs, base]


def import_graphs(root: Path) -> tuple[dict[str, Path], Graph, Graph]:
    """Modules, and their helixd imports: module-level only, and all of them."""
    mods = module_names(root)
    top: Graph = defaultdict(set)
    every: Graph = defaultdict(set)
    prefix = root.name
    for name, path in mods.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        tree = ast.parse(path.read_text(encoding="utf-8"))
        local_nodes: set[int] = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.If):
                local_nodes.update(id(n) for n in ast.walk(node) if n is not node)
        for node in ast.walk(tree):
            for target in _targets(node, package, mods):
                if not (target == prefix or target.startswith(prefix + ".")):
                    continue
                resolved = _resolve(target, mods)
                if resolved is None or resolved == name:
                    continue
                every[name].add(resolved)
                if id(node) not in local_nodes:
                    top[name].add(resolved)
    return mods, top, every


def strongly_connected(nodes: Iterable[str], graph: Graph) -> list[list[str]]:
    """Tarjan's strongly connected components."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp: list[str] = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            out.append(comp)

    sys.setrecursionlimit(10_000)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return out


def room(module: str) -> str:
    return ".".join(module.split(".")[:2])


def room_graph(graph: Graph) -> Graph:
    rooms: Graph = defaultdict(set)
    for a, targets in graph.items():
        for b in targets:
            ra, rb = room(a), room(b)
            if ra != rb and "." in ra and "." in rb:
                rooms[ra].add(rb)
    return rooms


def levels(rooms: list[str], graph: Graph) -> int:
    comps = strongly_connected(rooms, graph)
    comp_of = {v: k for k, comp in enumerate(comps) for v in comp}
    depth: dict[int, int] = {}
    for k, comp in enumerate(comps):  # Tarjan emits components in reverse topological order
        below = [depth[comp_of[w]] + 1 for v in comp for w in graph.get(v, ()) if comp_of[w] != k]
        depth[k] = max(below, default=0)
    return max(depth.values(), default=-1) + 1


def main(argv: list[str]) -> None:
    args = [a for a in argv if not a.startswith("--")]
    root = Path(args[0]) if args else Path("helixd")
    mods, top, every = import_graphs(root)
    rooms = sorted({room(m) for m in mods if "." in m})
    for label, graph in (("module-level imports", top), ("all imports", every)):
        rg = room_graph(graph)
        room_loops = [c for c in strongly_connected(rooms, rg) if len(c) > 1]
        module_loops = [c for c in strongly_connected(list(mods), graph) if len(c) > 1]
        print(
            f"[{label}] rooms={len(rooms)} levels={levels(rooms, rg)} "
            f"room-loops={len(room_loops)} module-loops={len(module_loops)}"
        )
        for comp in room_loops:
            print("  room loop:", " ".join(sorted(comp)))
        for comp in module_loops:
            print("  module loop:", " ".join(sorted(comp)))
    if "--edges" in argv:
        rg = room_graph(every)
        for name in sorted(rg):
            print(name, "->", " ".join(sorted(rg[name])))


if __name__ == "__main__":
    main(sys.argv[1:])
