"""The package's house rules, checked on its source (docs/development.md, "Layers"): subpackages import
only downwards (the import-linter contract in pyproject.toml), no module takes part in an import
circle, internal imports sit at the top of modules, and no block of lines is repeated."""

import contextlib
import io
from pathlib import Path

import grimp
from importlinter.cli import lint_imports

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "origami_jax"

# Import circles still there, each a set of modules; empty it as they go.
ALLOWED_CYCLES: dict[frozenset[str], str] = {
    frozenset(
        {"origami_jax.fab_yield", "origami_jax.fab_yield._ascent", "origami_jax.plotting.fab_yield"}
    ): "being reduced (issue 49): `YieldAscent.figure` imports plotting (the contract's one ignore)",
}


def test_the_layers_contract_is_kept():
    """`lint-imports` with the contract in pyproject.toml (function-level imports count too)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = lint_imports(
            config_filename=str(ROOT / "pyproject.toml"), no_cache=True, no_logo=True
        )
    assert code == 0, out.getvalue()


def _import_graph() -> dict[str, set[str]]:
    """Module → the modules its import statements load (any of them, inside functions too; the ones
    under `if TYPE_CHECKING:` left out). Importing `a.b.c` runs `a/b/__init__.py` first, so the
    packages on the way count as imported too (except the importer's own, already loading)."""
    graph = grimp.build_graph("origami_jax", exclude_type_checking_imports=True, cache_dir=None)
    edges: dict[str, set[str]] = {}
    for module in graph.modules:
        targets = set()
        for imported in graph.find_modules_directly_imported_by(module):
            parts = imported.split(".")
            for k in range(2, len(parts) + 1):
                parent = ".".join(parts[:k])
                if parent != module and not module.startswith(parent + "."):
                    targets.add(parent)
        edges[module] = targets
    return edges


def _circles(edges: dict[str, set[str]]) -> list[frozenset[str]]:
    """The strongly connected components of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in sorted(edges):
        if start in index:
            continue
        work = [(start, iter(sorted(edges[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(edges.get(child, ())))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(frozenset(component))
    return found


def test_no_import_circles():
    circles = set(_circles(_import_graph()))
    new = [sorted(c) for c in circles - set(ALLOWED_CYCLES)]
    assert not new, f"import circles: {new}"
    gone = [sorted(c) for c in set(ALLOWED_CYCLES) - circles]
    assert not gone, f"these circles are gone, take them off ALLOWED_CYCLES: {gone}"


def test_the_circle_finder_finds_circles():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert _circles(edges) == [frozenset({"a", "b", "c"})]
