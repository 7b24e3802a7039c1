"""The package's structure: no import cycles between modules, no private names across modules.

The import graph is read from the source with :mod:`ast` (nothing is imported): every
``import`` and ``from ... import`` anywhere in a module counts -- at the top, inside a function
(a lazy import), under ``if TYPE_CHECKING`` -- as an edge to the module it names (for ``from
package import name``, to the submodule ``package.name`` when there is one, else to the package).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
ROOT = SRC / "coplan"


def _modules() -> dict[str, tuple[Path, bool]]:
    """Dotted module name -> (file, is a package's __init__)."""
    out = {}
    for path in sorted(ROOT.rglob("*.py")):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        is_pkg = parts[-1] == "__init__"
        if is_pkg:
            parts = parts[:-1]
        out[".".join(parts)] = (path, is_pkg)
    return out


MODULES = _modules()


def _absolute(module: str, is_pkg: bool, level: int, name: str | None) -> str:
    """The absolute module name of a (possibly relative) ``from`` import in ``module``."""
    if level == 0:
        return name or ""
    base = module.split(".") if is_pkg else module.split(".")[:-1]
    if level > 1:
        base = base[: len(base) - (level - 1)]
    return ".".join(base + ([name] if name else []))


@functools.cache
def _imports(module: str) -> list[tuple[str, str | None, int]]:
    """``(target module, imported name or None, line)`` for every import of coplan code in ``module``.

    The name is set where a *name* (not a submodule) is taken from the target: ``from x import
    name``; and for ``x.name`` attribute uses of a module bound by ``import x`` or ``from .. import x``.
    """
    path, is_pkg = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    out: list[tuple[str, str | None, int]] = []
    bound: dict[str, str] = {}  # local name -> coplan module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            src = _absolute(module, is_pkg, node.level, node.module)
            if src != "coplan" and not src.startswith("coplan."):
                continue
            for alias in node.names:
                sub = f"{src}.{alias.name}"
                if sub in MODULES:
                    out.append((sub, None, node.lineno))
                    bound[alias.asname or alias.name] = sub
                else:
                    out.append((src, alias.name, node.lineno))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name == "coplan" or alias.name.startswith("coplan."):
                    out.append((alias.name, None, node.lineno))
                    if alias.asname:
                        bound[alias.asname] = alias.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound:
            out.append((bound[node.value.id], node.attr, node.lineno))
    return out


@functools.cache
def _graph() -> dict[str, set[str]]:
    return {m: {t for t, _, _ in _imports(m) if t in MODULES and t != m} for m in MODULES}


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each as a cycle
    through it (``a -> b -> ... -> a``)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    comps: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(comp)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    cycles = []
    for comp in comps:  # one concrete cycle through the component, for the message
        members, start = set(comp), min(comp)
        path, seen = [start], {start}
        while True:
            nxt = sorted(w for w in graph[path[-1]] if w in members)
            back = start if start in nxt else None
            if back:
                cycles.append(path + [start])
                break
            step = next((w for w in nxt if w not in seen), None)
            if step is None:
                cycles.append(sorted(comp))
                break
            path.append(step)
            seen.add(step)
    return cycles


def test_the_graph_sees_the_package():
    graph = _graph()
    assert "coplan.pipeline" in graph and "coplan.planners.optimal.planner" in graph
    assert "coplan.planners.coordinated.planner" in graph["coplan.planners.optimal.planner"]
    assert "coplan.pipeline" in graph["coplan.cli.commands"]  # a lazy import inside a function counts


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles_between_modules():
    cycles = _cycles(_graph())
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_no_module_imports_another_modules_private_name():
    bad = []
    for module in MODULES:
        for target, name, line in _imports(module):
            if target == module or name is None:
                continue
            if name.startswith("_") and not (name.startswith("__") and name.endswith("__")):
                bad.append(f"{MODULES[module][0].relative_to(SRC)}:{line}: {target}.{name}")
    assert not bad, "private names used across modules:\n" + "\n".join(bad)


@pytest.mark.parametrize("low, high", [
    ("coplan.kinematics", "coplan.problem"),
    ("coplan.problem", "coplan.allocate"),
    ("coplan.allocate", "coplan.planners"),
    ("coplan.verify", "coplan.planners"),
    ("coplan.verify", "coplan.allocate"),
    ("coplan.kinematics", "coplan.plan"),
    ("coplan.planners", "coplan.viz"),
    ("coplan.planners", "coplan.report"),
    ("coplan.planners", "coplan.pipeline"),
    ("coplan.verify", "coplan.pipeline"),
    ("coplan.pipeline", "coplan.cli"),
    ("coplan.report", "coplan.cli"),
    ("coplan.planners", "coplan.row"),
    ("coplan.verify", "coplan.row"),
    ("coplan.allocate", "coplan.row"),
    ("coplan.row", "coplan.pipeline"),
    ("coplan.row", "coplan.cli"),
    ("coplan.row", "coplan.live"),  # (a live row took the executed plan's planner name from the live cell's module)
    ("coplan.row", "coplan.report"),
    ("coplan.row", "coplan.sweep"),
    ("coplan.pipeline", "coplan.report"),
    ("coplan.pipeline", "coplan.sweep"),
    ("coplan.pipeline", "coplan.live"),
    ("coplan.planners", "coplan.live"),
    ("coplan.allocate", "coplan.verify"),
    ("coplan.viz", "coplan.pipeline"),
    ("coplan.live", "coplan.cli"),
    ("coplan.sweep", "coplan.cli"),
])
def test_dependencies_point_one_way(low, high):
    """Nothing in a lower stage imports a higher one (the CLI is on top, kinematics at the bottom)."""
    graph = _graph()
    up = sorted(f"{m} -> {t}" for m, ts in graph.items() if m == low or m.startswith(low + ".")
                for t in ts if t == high or t.startswith(high + "."))
    assert not up, f"{low} must not import {high}: " + ", ".join(up)
