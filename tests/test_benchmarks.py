"""The benchmark suite's smoke run (`python -m benchmarks --quick`), on the benchmarks that take seconds.

Every benchmark checks that ours and the peer agree before it times anything and raises otherwise, so a
passing run here means the peers installed by the `test` extra (Pinocchio, MuJoCo, modern_robotics,
scipy) still give our answers. The heavier quick benchmarks (simulate, design, sweep: each compiles an
implicit ODE solve) run with `-m slow`. Timings are not asserted: performance is recorded in
benchmarks/RESULTS.md, not tested.
"""

import json

import pytest
from benchmarks.__main__ import main

CHEAP = ["chain", "chain_peers", "unfold"]
HEAVY = ["simulate", "design", "sweep"]


def _run(names, tmp_path, capsys):
    out = tmp_path / "results.json"
    argv = ["--quick", "--json", str(out)]
    for name in names:
        argv += ["--only", name]
    assert main(argv) == 0, capsys.readouterr().err
    results = json.loads(out.read_text())
    rows = results["results"]
    assert rows, "no benchmark rows"
    return rows


@pytest.mark.slow  # the peers' agreement is tested where each quantity is (Pinocchio, MuJoCo, scipy)
def test_quick_benchmarks_agree_with_their_peers(tmp_path, capsys):
    rows = _run(CHEAP, tmp_path, capsys)
    names = " ".join(row["name"] for row in rows)
    for expected in ("forward_dynamics", "mass_matrix", "unfold corner cube", "unfold waterbomb"):
        assert expected in names


@pytest.mark.slow
def test_heavy_quick_benchmarks_agree_with_their_peers(tmp_path, capsys):
    rows = _run(HEAVY, tmp_path, capsys)
    assert any("sweep" in row["name"] for row in rows)
