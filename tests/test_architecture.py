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


#: The layers of docs/architecture.md, bottom first: a package or top-level module imports only
#: from its own layer or those below (and, within a layer, not across the pairs in APART). The
#: root package (``coplan/__init__``: its lazy facade) sits at the bottom, with the shared types.
LAYERS = (
    ("coplan", "kinds", "errors", "ties", "progress", "output", "workers", "plancsv", "provenance"),
    ("kinematics", "plan"),
    ("problem",),
    ("allocate", "verify", "schema"),
    ("planners",),
    ("row",),
    ("pipeline", "viz"),
    ("report", "sweep", "live"),
    ("cli", "optimal", "plausible", "generate"),  # (the command on top; the documented re-export modules, which nothing imports)
)
APART = {("kinematics", "plan"), ("allocate", "verify"), ("verify", "allocate"), ("pipeline", "viz"), ("viz", "pipeline"),
         ("report", "sweep"), ("sweep", "report"), ("report", "live"), ("live", "report"), ("sweep", "live"), ("live", "sweep")}


def _part(module: str) -> str:
    """The package (or top-level module) of coplan a module belongs to: ``coplan.row.live`` -> ``row``."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "coplan"


def _upward(graph: dict[str, set[str]]) -> list[str]:
    """Every import of ``graph`` that points up the LAYERS, or across a pair of APART."""
    layer = {name: k for k, names in enumerate(LAYERS) for name in names}
    return sorted(f"{m} -> {t}" for m, ts in graph.items() for t in ts
                  if (a := _part(m)) != (b := _part(t)) and (layer[a] < layer[b] or (a, b) in APART))


def test_every_package_has_a_layer():
    assert {_part(m) for m in MODULES} == {name for names in LAYERS for name in names}


def test_the_layer_rule_finds_an_upward_import():
    assert _upward({"coplan.kinematics.fk": {"coplan.cli.commands"}, "coplan.cli.commands": {"coplan.kinematics.fk"}}) \
        == ["coplan.kinematics.fk -> coplan.cli.commands"]
    assert _upward({"coplan.viz.plots": {"coplan.pipeline"}}) == ["coplan.viz.plots -> coplan.pipeline"]


def test_dependencies_point_one_way():
    """Nothing in a lower layer imports a higher one (the CLI on top, the shared types at the bottom)."""
    up = _upward(_graph())
    assert not up, "imports against the layers:\n" + "\n".join(up)
