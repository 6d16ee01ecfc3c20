"""MkDocs hooks of the documentation build (`mkdocs.yml`, `hooks:`).

- The notebooks in `notebooks/` and the benchmark figures in `benchmarks/` are pages and images of the
  site without being copied into `docs/`: they are added to the build as virtual files (before
  mkdocs-jupyter looks for notebooks, hence the priority).
- The command-line reference (`docs/cli.md`) is generated from the argument parser
  (`origami_jax.cli.build_parser()`): every subcommand's `--help`, so it cannot drift from the code.
"""

import argparse
import io
import os
import sys
from contextlib import redirect_stdout
from pathlib import Path

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[2]
CLI_MARKER = "<!-- cli-reference -->"
# Virtual files: (folder of the repository, glob, folder in the site).
EXTERNAL = (
    ("notebooks", "*.ipynb", "notebooks"),
    ("benchmarks", "*.png", "benchmarks"),
)


def on_config(config):
    # `mkdocs serve` rebuilds when these change too.
    for folder in {folder for folder, _, _ in EXTERNAL} | {"origami_jax"}:
        if str(ROOT / folder) not in config.watch:
            config.watch.append(str(ROOT / folder))
    return config


@event_priority(100)  # before mkdocs-jupyter turns .ipynb files into pages
def on_files(files: Files, config) -> Files:
    for folder, pattern, target in EXTERNAL:
        for path in sorted((ROOT / folder).glob(pattern)):
            uri = f"{target}/{path.name}"
            if files.get_file_from_path(uri) is None:
                # A real file of the repository (its source folder is the repository's root, so
                # `uri` is also its path there); not `File.generated`, whose source path
                # mkdocs-jupyter's wrapper of notebook files does not see.
                assert uri == f"{folder}/{path.name}"
                files.append(File(uri, str(ROOT), config.site_dir, config.use_directory_urls))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_reference())
    return markdown


def _help(parser: argparse.ArgumentParser) -> str:
    buffer = io.StringIO()
    with redirect_stdout(buffer):
        parser.print_help()
    return buffer.getvalue().rstrip()


def cli_reference() -> str:
    """Markdown: the top-level `--help`, then one section per subcommand with its `--help`."""
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))  # document this checkout's package
    from origami_jax.cli import build_parser

    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "80"  # argparse wraps to the terminal's width: make the page stable
    try:
        parser = build_parser()
        parts = ["## `origami-jax`", "", "```text", _help(parser), "```", ""]
        for action in parser._actions:  # argparse keeps its subparsers here and nowhere public
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    parts += [f"## `origami-jax {name}`", "", "```text", _help(sub), "```", ""]
    finally:
        if columns is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = columns
    return "\n".join(parts)
