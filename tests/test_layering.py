"""The package's house rules, checked on its source (docs/development.md, "Layers"): subpackages import
only downwards (the import-linter contract in pyproject.toml), no module takes part in an import
circle, internal imports sit at the top of modules, and no block of lines is repeated."""

import ast
import contextlib
import io
import re
from pathlib import Path

import grimp
from importlinter.cli import lint_imports

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "origami_jax"

# Import circles still there, each a set of modules; empty it as they go.
ALLOWED_CYCLES: dict[frozenset[str], str] = {}


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


# ---- imports inside functions ---------------------------------------------------------------------

_CLI = (
    "the command's machinery (JAX, matplotlib, the FOLD reader) loads when the command runs: "
    "`origami-jax --help` loads no JAX (tests/test_compile.py) and takes ~0.2 s, to which "
    "`origami_jax.fold` alone would add ~0.1 s"
)
_VIEW = (
    "`origami_jax.view` loads no JAX until an adapter needs the physics (its docstring): ~0.3 s to "
    "import, against ~3 s with the physics"
)
_PLOTTING = "plotting draws finished results with matplotlib alone: it loads no physics (JAX)"
_BEING_REDUCED = (
    "being reduced (issue 49): a file under other work, its imports move after it lands"
)

# File (under origami_jax/) → (at most this many imports of the package's own modules inside
# functions, why). Lower a count when you can; a file at zero leaves the list.
FUNCTION_IMPORTS: dict[str, tuple[int, str]] = {
    "cli/_common.py": (4, _CLI),
    "cli/_design.py": (3, _CLI),
    "cli/_export.py": (4, _CLI),
    "cli/_fold.py": (11, _CLI),
    "cli/_painter.py": (2, _CLI),
    "cli/_panels.py": (1, _CLI),
    "cli/_paper_calibration.py": (2, _CLI),
    "cli/_paper_dynamics.py": (7, _CLI),
    "cli/_paper_extended.py": (2, _CLI),
    "cli/_paper_unfolding.py": (2, _CLI),
    "cli/_simulate.py": (6, _CLI),
    "cli/_sweep.py": (6, _CLI),
    "cli/_unfold.py": (4, _CLI),
    "cli/_view.py": (4, _CLI),
    "cli/_yield.py": (16, _CLI),
    "view/_adapters.py": (3, _VIEW),
    "view/_sources.py": (6, _VIEW),
    "plotting/fab_yield.py": (3, _PLOTTING),
}


def _sources():
    for path in sorted(PACKAGE.rglob("*.py")):
        yield path.relative_to(PACKAGE).as_posix(), path.read_text()


def _function_imports(source: str) -> list[tuple[int, str]]:
    """`(line, module)` of every import of the package's own modules inside a function."""
    found = []

    def walk(node, inside):
        for child in ast.iter_child_nodes(node):
            if inside and isinstance(child, ast.ImportFrom):
                module = "." * child.level + (child.module or "")
                if child.level or module.startswith("origami_jax"):
                    found.append((child.lineno, module))
            elif inside and isinstance(child, ast.Import):
                found.extend(
                    (child.lineno, a.name) for a in child.names if a.name.startswith("origami_jax")
                )
            function = isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
            walk(child, inside or function)

    walk(ast.parse(source), False)
    return found


def test_internal_imports_sit_at_the_top_of_modules():
    over, gone = [], []
    for name, source in _sources():
        found = _function_imports(source)
        allowed = FUNCTION_IMPORTS.get(name, (0, ""))[0]
        if len(found) > allowed:
            over.append(f"{name}: {len(found)} > {allowed}: {found}")
        if name in FUNCTION_IMPORTS and not found:
            gone.append(name)
    assert not over, "imports inside functions (move them to the top):\n" + "\n".join(over)
    assert not gone, f"no imports inside functions any more, take them off FUNCTION_IMPORTS: {gone}"
    assert set(FUNCTION_IMPORTS) <= {name for name, _ in _sources()}


# ---- private modules of other subpackages ---------------------------------------------------------

# File → (at most this many imports of another subpackage's private module, why). A subpackage's
# interface is its `__init__`: import its public names, or make a name public when it is part of it.
PRIVATE_IMPORTS: dict[str, tuple[int, str]] = {
    "design/_lstsq.py": (1, "`simulation._results.promote`: a result-code helper, not yet placed"),
    "cli/_yield.py": (
        1,
        "`fab_yield._estimate._process`: the command checks `--process` before anything runs; "
        "not yet part of fab_yield's interface",
    ),
}


def _private_imports(name: str, source: str) -> list[tuple[int, str]]:
    """`(line, module)` of every import (anywhere in the file) of a private module (`_x`) of another
    subpackage than the file's own."""
    package = name.split("/")[0]
    depth = name.count("/")  # 1 inside a subpackage, 0 at the top (origami_jax/x.py)
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                parts = (node.module or "").split(".") if node.module else []
                if node.level != depth + 1:
                    continue  # inside the file's own subpackage
            elif (node.module or "").startswith("origami_jax."):
                parts = node.module.split(".")[1:]
            else:
                continue
            modules = [parts + [alias.name] for alias in node.names] if len(parts) == 1 else [parts]
            for target in modules:
                shared = target[:1] and target[0].startswith(
                    "_"
                )  # origami_jax._x: the bottom helpers
                if (
                    len(target) >= 2
                    and not shared
                    and target[0] != package
                    and target[1].startswith("_")
                ):
                    found.append((node.lineno, ".".join(target[:2])))
                    break
    return found


def test_other_subpackages_are_imported_by_their_public_names():
    over, gone = [], []
    for name, source in _sources():
        found = _private_imports(name, source)
        allowed = PRIVATE_IMPORTS.get(name, (0, ""))[0]
        if len(found) > allowed:
            over.append(f"{name}: {len(found)} > {allowed}: {found}")
        if name in PRIVATE_IMPORTS and not found:
            gone.append(name)
    assert not over, "imports of other subpackages' private modules:\n" + "\n".join(over)
    assert not gone, f"no private imports any more, take them off PRIVATE_IMPORTS: {gone}"


# ---- abstract or final ----------------------------------------------------------------------------

# Base classes of the package that are subclassed although not `Abstract*`: exceptions (a family of
# errors) and result enumerations (diffrax's way of extending its RESULTS).
SUBCLASSED_CONCRETE = {"FolderBusyError", "CLIError", "RESULTS"}


def test_classes_are_abstract_or_final():
    """A class of the package is either abstract (named `Abstract*`, never instantiated) or final
    (never subclassed): what two classes share goes into an abstract base, not into one of them."""
    defined, bases = set(), []
    for name, source in _sources():
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.ClassDef):
                defined.add(node.name)
                bases += [(name, node.name, ast.unparse(b).split(".")[-1]) for b in node.bases]
    concrete = [
        f"{file}: {cls}({base})"
        for file, cls, base in bases
        if base in defined and not base.startswith("Abstract") and base not in SUBCLASSED_CONCRETE
    ]
    assert not concrete, f"concrete classes subclassed: {concrete}"


# ---- repeated blocks ------------------------------------------------------------------------------

BLOCK = 6  # lines
_TRIVIAL = re.compile(r"^[\s()\[\]{},:;]*$|^(else|try|finally|pass|return|continue|break):?$")

# Files (under origami_jax/) that share a repeated block → why it stays for now.
ALLOWED_REPEATS: dict[frozenset[str], str] = {
    frozenset({"fab_yield/_ascent.py", "fab_yield/_estimate.py"}): _BEING_REDUCED,
    frozenset({"simulation/_simulate.py"}): _BEING_REDUCED,
    frozenset({"vertex/_descent.py"}): (
        "the descent's loop state declares the fields of the output it becomes (eqx.Module layouts)"
    ),
}


def _code_lines(source: str) -> list[tuple[int, str]]:
    """`(line number, text with white space folded)` of the lines that carry code: no blank lines,
    comments, imports, docstrings (or other lone strings), a signature's parameter lines, or lines
    of punctuation and bare keywords."""
    skip: set[int] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            skip.update(range(node.lineno, (node.end_lineno or node.lineno) + 1))
        elif isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant):
            skip.update(range(node.lineno, (node.end_lineno or node.lineno) + 1))
        elif isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            skip.update(range(node.lineno + 1, node.body[0].lineno))
    kept = []
    for number, line in enumerate(source.split("\n"), 1):
        text = " ".join(line.split())
        if number in skip or not text or text.startswith("#") or _TRIVIAL.match(text):
            continue
        kept.append((number, text))
    return kept


def _repeats() -> dict[frozenset[str], list[tuple[str, int]]]:
    """Files that share a block of `BLOCK` code lines (`_code_lines`, identical after folding white
    space) → the places: (file, first line), two or more, not overlapping."""
    places: dict[tuple[str, ...], list[tuple[str, int, int]]] = {}
    for name, source in _sources():
        kept = _code_lines(source)
        for k in range(len(kept) - BLOCK + 1):
            window = tuple(text for _, text in kept[k : k + BLOCK])
            places.setdefault(window, []).append((name, kept[k][0], kept[k + BLOCK - 1][0]))
    found: dict[frozenset[str], list[tuple[str, int]]] = {}
    for where in places.values():
        apart = []
        for name, first, last in sorted(where):
            if not (apart and apart[-1][0] == name and first <= apart[-1][2]):
                apart.append((name, first, last))
        if len(apart) > 1:
            key = frozenset(name for name, _, _ in apart)
            found.setdefault(key, []).extend((name, first) for name, first, _ in apart)
    return found


def test_no_block_of_lines_is_repeated():
    found = _repeats()
    new = {
        tuple(sorted(k)): sorted(set(v))[:4] for k, v in found.items() if k not in ALLOWED_REPEATS
    }
    assert not new, f"blocks of {BLOCK}+ identical lines (fold them into one helper): {new}"
    gone = [sorted(k) for k in set(ALLOWED_REPEATS) - set(found)]
    assert not gone, f"no repeated block any more, take them off ALLOWED_REPEATS: {gone}"


def test_the_repeat_finder_finds_repeats(tmp_path):
    body = "\n".join(f"    x{i} = f(x{i - 1}, {i})" for i in range(1, 8))
    source = f'def a(x0):\n    """Doc."""\n{body}\n    return x7\n\n\ndef b(x0):\n{body}\n'
    lines = [text for _, text in _code_lines(source)]
    assert lines[0] == "def a(x0):" and "Doc." not in " ".join(lines)
    window = tuple(lines[1 : 1 + BLOCK])
    assert [lines[k : k + BLOCK] for k in range(len(lines))].count(list(window)) == 2
