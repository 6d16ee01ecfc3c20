"""The documentation (`docs/`, `mkdocs.yml`): it builds strictly, it documents every public name, the
physics guide has every section the code links to, and every Python block of its pages runs.

**Code blocks.** Every fenced ```` ```python ```` block of every page under `docs/` runs, the blocks of a
page in order in one namespace (a page reads as one script), in a temporary working folder. Two
markers, each on the line right before a block:

- ``<!-- docs-test: slow -->``: the block compiles something expensive of its own (a ramp input, a
  gradient, a second fit); it runs with the slow tests (``pytest -m slow``), the rest of its page in
  the default run. Later blocks must not depend on it.
- ``<!-- docs-test: skip REASON -->``: the block cannot run in a test (it needs a cluster, say),
  with the reason.

Other languages (``bash``, ``toml``, ``text``) are not run.
"""

import ast
import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PHYSICS = DOCS / "physics.md"
MARKER = re.compile(r"^\s*<!--\s*docs-test:\s*(?P<kind>skip|slow)\b(?P<reason>.*?)-->\s*$")
FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>`{3,}|~{3,})\s*(?P<lang>[\w+-]*)")
# Everything the build needs besides the package itself (`pip install -e ".[docs]"`).
DOCS_MODULES = (
    "mkdocs",
    "material",
    "mkdocstrings",
    "mkdocstrings_handlers.python",
    "mkdocs_autorefs",
    "mkdocs_jupyter",
    "pymdownx",
    "griffe_public_redundant_aliases",
)
# Every public sub-package has an API page (docs/api/NAME.md); the command line has its own page.
API_PAGES = tuple(
    sorted(
        path.name
        for path in (ROOT / "origami_jax").iterdir()
        if (path / "__init__.py").is_file() and not path.name.startswith("_") and path.name != "cli"
    )
)
BUILD_TIMEOUT_S = 600


def _missing_docs_modules() -> list[str]:
    missing = []
    for name in DOCS_MODULES:
        try:
            found = importlib.util.find_spec(name) is not None
        except ModuleNotFoundError:  # a parent package is missing
            found = False
        if not found:
            missing.append(name)
    return missing


needs_docs_packages = pytest.mark.skipif(
    bool(_missing_docs_modules()),
    reason=(
        f"the documentation packages are not installed ({', '.join(_missing_docs_modules())}): "
        'pip install -e ".[docs]"'
    ),
)


# ---- code blocks -------------------------------------------------------------------------------


def _closes(line: str, indent: str, fence: str) -> bool:
    """Whether `line` closes a block opened by `fence` at `indent` (CommonMark: the same character,
    at least as many, nothing else)."""
    stripped = line.strip()
    return line.startswith(indent) and len(stripped) >= len(fence) and set(stripped) == {fence[0]}


class Block(NamedTuple):
    """A ```python block of a page: where it starts, its code, and whether it is slow."""

    line: int
    code: str
    slow: bool


def python_blocks(path: Path) -> list[Block]:
    """The page's ```python blocks, in order, without the skipped ones.

    **Raises:** `ValueError` for an unclosed fence, a skip marker without a reason, or a marker not
    followed by a Python block.
    """
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks: list[Block] = []
    marker: re.Match | None = None
    i = 0
    while i < len(lines):
        found = MARKER.match(lines[i])
        if found:
            marker = found
            if found.group("kind") == "skip" and not found.group("reason").strip(" :"):
                raise ValueError(f"{path}:{i + 1}: a docs-test skip marker needs a reason.")
            i += 1
            continue
        opening = FENCE.match(lines[i])
        if not opening:
            if lines[i].strip() and marker is not None:
                raise ValueError(
                    f"{path}:{i + 1}: a docs-test marker must come right before a block."
                )
            i += 1
            continue
        indent, fence, lang = opening.group("indent", "fence", "lang")
        start = i + 1
        body: list[str] = []
        i += 1
        while i < len(lines) and not _closes(lines[i], indent, fence):
            body.append(lines[i][len(indent) :] if lines[i].startswith(indent) else lines[i])
            i += 1
        if i == len(lines):
            raise ValueError(f"{path}:{start}: unclosed code fence.")
        i += 1
        kind = None if marker is None else marker.group("kind")
        if lang in ("python", "py"):
            if kind != "skip":
                blocks.append(Block(start + 1, "\n".join(body) + "\n", kind == "slow"))
        elif marker is not None:
            raise ValueError(f"{path}:{start}: docs-test markers are for Python blocks only.")
        marker = None
    return blocks


PAGES = sorted(p for p in DOCS.rglob("*.md") if python_blocks(p))
SLOW_PAGES = [p for p in PAGES if any(block.slow for block in python_blocks(p))]


def _ids(pages):
    return [p.relative_to(DOCS).as_posix() for p in pages]


def test_the_guides_have_code():
    names = set(_ids(PAGES))
    for page in ("getting-started.md", "guides/unfold.md", "guides/simulate.md", "guides/sweep.md"):
        assert page in names, f"{page} has no Python block to run"


def test_block_extraction(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "text\n```python\nx = 1\n```\n"
        "!!! note\n    ```python\n    y = x + 1\n    ```\n"
        "```bash\nls\n```\n"
        "<!-- docs-test: skip needs a cluster -->\n```python\nraise SystemExit\n```\n"
        "````python\n```\nz = 3\n````\n"
        "<!-- docs-test: slow -->\n```python\nw = 4\n```\n"
    )
    blocks = python_blocks(page)
    assert [b.code for b in blocks] == ["x = 1\n", "y = x + 1\n", "```\nz = 3\n", "w = 4\n"]
    assert [b.line for b in blocks] == [3, 7, 17, 22]
    assert [b.slow for b in blocks] == [False, False, False, True]
    page.write_text("<!-- docs-test: skip -->\n```python\nx = 1\n```\n")
    with pytest.raises(ValueError, match="needs a reason"):
        python_blocks(page)
    page.write_text("<!-- docs-test: slow -->\ntext\n```python\nx = 1\n```\n")
    with pytest.raises(ValueError, match="right before a block"):
        python_blocks(page)


def _run_page(page: Path, *, slow: bool) -> None:
    import matplotlib.pyplot as plt

    namespace: dict = {"__name__": "__docs__"}
    try:
        for block in python_blocks(page):
            if block.slow and not slow:
                continue
            where = f"{page.relative_to(ROOT)}:{block.line}"
            exec(compile(block.code, where, "exec"), namespace)  # noqa: S102 (running the docs is the test)
    finally:
        plt.close("all")


@pytest.mark.parametrize("page", PAGES, ids=_ids(PAGES))
def test_page_code_runs(page, tmp_path, monkeypatch):
    """The page's blocks, without those marked slow."""
    monkeypatch.chdir(tmp_path)  # pages write their files here
    _run_page(page, slow=False)


@pytest.mark.slow
@pytest.mark.parametrize("page", SLOW_PAGES, ids=_ids(SLOW_PAGES))
def test_page_code_runs_with_slow_blocks(page, tmp_path, monkeypatch):
    """The whole page, the blocks marked slow included."""
    monkeypatch.chdir(tmp_path)
    _run_page(page, slow=True)


# ---- the physics guide's sections --------------------------------------------------------------

# `docs/physics.md, "Inputs", "Numerics"`, `docs/physics.md ("Numerics")`, `the physics guide,
# "Fluids and drag"`: the quoted titles after a mention of the guide. A title may wrap onto the next
# line of a docstring (`"Calibrating the extended\n    model"`): its whitespace is collapsed.
_MENTION = re.compile(r'(?:docs/physics\.md|physics guide)[\s,(]*((?:"[^"]+"[\s,]*(?:and\s+)?)+)')


def _section_mentions() -> dict[str, set[str]]:
    texts = {p: p.read_text(encoding="utf-8") for p in sorted((ROOT / "origami_jax").rglob("*.py"))}
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        cells = json.loads(notebook.read_text(encoding="utf-8"))["cells"]
        texts[notebook] = "\n".join("".join(cell["source"]) for cell in cells)
    mentions: dict[str, set[str]] = {}
    for path, text in texts.items():
        for match in _MENTION.finditer(text):
            for title in re.findall(r'"([^"]+)"', match.group(1)):
                title = " ".join(title.split())
                mentions.setdefault(title, set()).add(str(path.relative_to(ROOT)))
    return mentions


def test_physics_guide_has_every_section_the_code_links_to():
    headings = set(re.findall(r"^#{1,4} +(.+?) *$", PHYSICS.read_text(encoding="utf-8"), re.M))
    mentions = _section_mentions()
    assert len(mentions) >= 8, f"too few section links found; is the pattern stale? {mentions}"
    missing = {title: sorted(where) for title, where in mentions.items() if title not in headings}
    assert not missing, f"sections linked from the code but absent from docs/physics.md: {missing}"


def test_physics_guide_says_nothing_internal():
    text = PHYSICS.read_text(encoding="utf-8")
    for word in ("SPEC", "issue #", "TODO", "TBD"):
        assert word not in text, f"docs/physics.md mentions {word!r}"


# ---- the build ---------------------------------------------------------------------------------


def _public_names(package: str) -> list[str]:
    """Names a sub-package exports (`from ._x import Name as Name`), or the public top-level
    functions of its modules for a package of modules (`plotting`)."""
    folder = ROOT / "origami_jax" / package
    tree = ast.parse((folder / "__init__.py").read_text(encoding="utf-8"))
    names = [
        f"{package}.{alias.asname}"
        for node in tree.body
        if isinstance(node, ast.ImportFrom)
        for alias in node.names
        if alias.asname is not None and alias.asname == alias.name
    ]
    if names:
        return names
    for module in sorted(folder.glob("[!_]*.py")):
        body = ast.parse(module.read_text(encoding="utf-8")).body
        names += [
            f"{package}.{module.stem}.{node.name}"
            for node in body
            if isinstance(node, ast.FunctionDef | ast.ClassDef) and not node.name.startswith("_")
        ]
    return names


@needs_docs_packages
def test_strict_build_documents_every_public_name(tmp_path):
    site = tmp_path / "site"
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1", PYTHONPATH=str(ROOT))
    process = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=BUILD_TIMEOUT_S,
    )
    log = process.stdout + process.stderr
    assert process.returncode == 0, f"mkdocs build --strict failed:\n{log[-6000:]}"
    for package in API_PAGES:
        page = (site / "api" / package / "index.html").read_text(encoding="utf-8")
        names = _public_names(package)
        assert names, package
        undocumented = [n for n in names if f'id="origami_jax.{n}"' not in page]
        assert not undocumented, f"api/{package}.md does not document {undocumented}"
    cli = (site / "cli" / "index.html").read_text(encoding="utf-8")
    from origami_jax.cli._main import SUBCOMMANDS

    for command in (module.__name__.rsplit("._", 1)[-1] for module in SUBCOMMANDS):
        assert f"origami-jax {command}" in cli, f"the CLI reference lacks `{command}`"
    benchmarks = (site / "benchmarks" / "index.html").read_text(encoding="utf-8")
    assert "Benchmark results" in benchmarks
    history = (site / "benchmarks" / "history" / "index.html").read_text(encoding="utf-8")
    assert "Benchmark history" in history
    assert "Capabilities" in (site / "status" / "index.html").read_text(encoding="utf-8")
    for notebook in sorted((ROOT / "notebooks").glob("*.ipynb")):
        assert (site / "notebooks" / notebook.stem / "index.html").is_file(), notebook.name
