"""The command line: help, version, subcommands listed, unimplemented parts honest."""

import subprocess
import sys

import pytest

from origami_jax import __version__
from origami_jax.cli import build_parser, main

SUBCOMMANDS = ("paper", "unfold", "simulate", "fold", "design", "sweep", "yield", "export", "view")


def test_help_lists_every_subcommand(capsys):
    with pytest.raises(SystemExit) as excinfo:
        main(["--help"])
    assert excinfo.value.code == 0
    text = capsys.readouterr().out
    for name in SUBCOMMANDS:
        assert name in text


def test_version(capsys):
    with pytest.raises(SystemExit):
        main(["--version"])
    assert __version__ in capsys.readouterr().out


def test_no_subcommand_is_a_usage_error(capsys):
    assert main([]) == 2


@pytest.mark.parametrize("name", SUBCOMMANDS)
def test_each_subcommand_has_help(name, capsys):
    with pytest.raises(SystemExit) as excinfo:
        main([name, "--help"])
    assert excinfo.value.code == 0
    assert "--out" in capsys.readouterr().out or name in ("export", "view")


def test_parser_builds_without_importing_physics():
    # `--help` must be quick: building the parser may not pull in the heavy parts.
    assert build_parser().prog == "origami-jax"


def test_module_entry_point_runs():
    result = subprocess.run(
        [sys.executable, "-m", "origami_jax", "--version"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr
    assert __version__ in result.stdout


def test_a_command_ends_its_process_with_its_output_whole_and_its_exit_code():
    """`main` ends a process of its own at once (`os._exit`, skipping the interpreter's
    teardown of the compiled programs): what the command printed to a pipe still arrives whole,
    and its exit code is the command's (0 for a listing, 2 for a net that does not exist)."""
    listing = subprocess.run(
        [sys.executable, "-m", "origami_jax", "fold", "--list"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert listing.returncode == 0, listing.stderr
    assert listing.stdout.rstrip().splitlines()[-1].startswith("octahedron_nets: ")
    missing = subprocess.run(
        [sys.executable, "-m", "origami_jax", "fold", "no_such_net"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert missing.returncode == 2
    assert "no shipped net of that name" in missing.stderr
