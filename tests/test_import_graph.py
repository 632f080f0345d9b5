"""The product's import graph: no cycle between modules, and the layers import downwards only.

Every module of the product packages (``drivers/``, ``daemon/``, ``processing/``) is parsed
with :mod:`ast`; every ``import`` and ``from ... import`` counts, at module level or
inside a function (a lazy import is still an import). An edge goes to the most specific
module named: ``from a.b import c`` is an edge to ``a.b.c`` when that is a module, else
to ``a.b``. Parent packages are not edges of their own (importing ``a.b.c`` runs
``a/__init__`` first, but that is how packages work, not a cycle).

The layers, lowest first: drivers (``nomad200``, ``sonarsim``), the daemon
(``sonarlog``, ``sonard``), processing (``sonarproc``). Nothing imports from a layer
above its own.
"""

from __future__ import annotations

import ast
import functools
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Package -> layer (0 lowest). A module may import from its own layer or below.
LAYERS = {"nomad200": 0, "sonarsim": 0, "sonarlog": 1, "sonard": 1, "sonarproc": 2}
PACKAGE_DIRS = [ROOT / "drivers", ROOT / "daemon", ROOT / "processing"]

#: Cycles known outside the surface stage, to be broken by their owners; each is the
#: sorted tuple of its modules. Keep this empty: a new cycle fails the test.
KNOWN_CYCLES: set[tuple[str, ...]] = set()


def _modules() -> dict[str, Path]:
    """Module name -> file, for every product package."""
    found: dict[str, Path] = {}
    for base in PACKAGE_DIRS:
        for package in sorted(p for p in base.iterdir() if p.name in LAYERS):
            for path in sorted(package.rglob("*.py")):
                parts = list(path.relative_to(base).with_suffix("").parts)
                if parts[-1] == "__init__":
                    parts = parts[:-1]
                found[".".join(parts)] = path
    return found


def _is_type_checking(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _imports(tree: ast.AST, *, typing_only: bool) -> Iterator[ast.Import | ast.ImportFrom]:
    """The import statements of a module, at any depth; those under ``if TYPE_CHECKING``
    only with ``typing_only``."""
    stack: list[ast.AST] = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and _is_type_checking(node) and not typing_only:
            stack.extend(node.orelse)
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            yield node
        stack.extend(ast.iter_child_nodes(node))


def _target(name: str, modules: dict[str, Path]) -> str | None:
    """The most specific product module ``name`` names (None outside the product)."""
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


def import_graph(*, typing_only: bool = False) -> dict[str, set[str]]:
    """Module -> the product modules it imports (itself excluded)."""
    return {module: set(targets) for module, targets in _graph(typing_only).items()}


@functools.cache
def _parsed(path: Path) -> ast.Module:
    """A module's syntax tree, parsed once for both graphs."""
    return ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


@functools.cache
def _graph(typing_only: bool) -> dict[str, frozenset[str]]:
    """:func:`import_graph`, built once per session (parsing every module is most of the
    cost of these tests, and the sources do not change while they run)."""
    modules = _modules()
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for module, path in modules.items():
        is_package = path.name == "__init__.py"
        for node in _imports(_parsed(path), typing_only=typing_only):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                base = node.module or ""
                if node.level:
                    here = module.split(".") if is_package else module.split(".")[:-1]
                    up = here[: len(here) - (node.level - 1)]
                    base = ".".join([*up, base] if base else up)
                names = [f"{base}.{alias.name}" for alias in node.names] or [base]
                names = [n if _target(n, modules) == n else base for n in names]
            for name in names:
                target = _target(name, modules)
                if target is not None and target != module:
                    graph[module].add(target)
    return {module: frozenset(targets) for module, targets in graph.items()}


def _cycles(graph: dict[str, set[str]]) -> list[tuple[str, ...]]:
    """The strongly connected components with more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    out: list[tuple[str, ...]] = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                parent = work[-1][0]
                low[parent] = min(low[parent], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    top = stack.pop()
                    on_stack.discard(top)
                    component.append(top)
                    if top == node:
                        break
                if len(component) > 1:
                    out.append(tuple(sorted(component)))
    return out


def test_the_graph_sees_every_package_and_lazy_imports() -> None:
    graph = import_graph()
    assert {m.split(".")[0] for m in graph} == set(LAYERS)
    # a function-level import counts: the pipeline loads the surface stage lazily
    assert "sonarproc.pipeline.surfacefit" in graph["sonarproc.pipeline.mapping"]


def test_cycle_finder_finds_a_cycle_and_not_a_chain() -> None:
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [("a", "b", "c")]
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": set()}) == []


def test_no_import_cycle_between_product_modules() -> None:
    found = set(_cycles(import_graph()))
    new = sorted(found - KNOWN_CYCLES)
    assert not new, "import cycles:\n" + "\n".join(" <-> ".join(c) for c in new)
    stale = sorted(KNOWN_CYCLES - found)
    assert not stale, f"known cycles that are gone (drop them from KNOWN_CYCLES): {stale}"


@pytest.mark.parametrize("typing_only", [False, True])
def test_layers_import_downwards_only(typing_only: bool) -> None:
    graph = import_graph(typing_only=typing_only)
    upward = sorted(
        (module, target)
        for module, targets in graph.items()
        for target in targets
        if LAYERS[target.split(".")[0]] > LAYERS[module.split(".")[0]]
    )
    assert not upward, "imports from a higher layer:\n" + "\n".join(
        f"{m} -> {t}" for m, t in upward
    )


#: The surface stage's subpackages, in the order they may import each other (each from
#: those before it only).
SURFACE_ORDER = ["planar", "extraction", "fitting", "echoes", "evaluation", "reflectors"]


def test_surface_subpackages_import_in_order() -> None:
    prefix = "sonarproc.surfaces."

    def rank(module: str) -> int | None:
        part = module[len(prefix) :].split(".")[0] if module.startswith(prefix) else ""
        return SURFACE_ORDER.index(part) if part in SURFACE_ORDER else None

    graph = import_graph()
    assert any(rank(m) is not None for m in graph)
    wrong = sorted(
        (module, target)
        for module, targets in graph.items()
        for target in targets
        if (r := rank(module)) is not None and (t := rank(target)) is not None and t > r
    )
    assert not wrong, "\n".join(f"{m} -> {t}" for m, t in wrong)
