"""A family of nets' yields against their compactness (`family_yield`, `origami-jax yield FAMILY`).

Spearman's ρ is checked against hand computations (ties included) and `scipy.stats.spearmanr`. The
family's bookkeeping (one folder per net, the same seed for each, resume skipping finished nets,
the table, the CSV and JSON, the CLI's refusals) runs with `yield_estimate` replaced by a stand-in
that returns chosen verdict counts at once; one slow test runs two small nets for real."""

import csv
import dataclasses
import io
import json
import math

import numpy as np
import pytest
from scipy import stats

import origami_jax.fab_yield as ojy
from origami_jax.fab_yield import _family
from origami_jax.fold import catalogue_path, net_geometry

# ---- Spearman ----------------------------------------------------------------------------------


def test_spearman_without_ties_is_the_d_squared_formula():
    # ranks differ by d = (−1, 1, −1, 1, 0): ρ = 1 − 6 Σd² / (n (n² − 1)) = 1 − 24/120 = 0.8.
    rho, p = ojy.spearman([1, 2, 3, 4, 5], [2, 1, 4, 3, 5])
    assert rho == pytest.approx(0.8, abs=1e-15)
    # t = ρ √((n − 2)/(1 − ρ²)) = 0.8 √(3/0.36), Student's t with 3 degrees of freedom.
    t = 0.8 * math.sqrt(3 / 0.36)
    assert p == pytest.approx(2 * stats.t.sf(t, 3), rel=1e-12)
    reference = stats.spearmanr([1, 2, 3, 4, 5], [2, 1, 4, 3, 5])
    assert (rho, p) == pytest.approx((reference.statistic, reference.pvalue), rel=1e-12)


def test_spearman_with_ties_uses_average_ranks():
    assert ojy.average_ranks([10, 20, 20, 30]) == [1.0, 2.5, 2.5, 4.0]
    assert ojy.average_ranks([3, 1, 3, 3]) == [3.0, 1.0, 3.0, 3.0]
    # x ranks (1, 2.5, 2.5, 4), y ranks (1, 3, 2, 4): deviations from 2.5 are (−1.5, 0, 0, 1.5)
    # and (−1.5, 0.5, −0.5, 1.5): ρ = 4.5 / √(4.5 · 5).
    rho, _ = ojy.spearman([1, 2, 2, 3], [1, 3, 2, 4])
    assert rho == pytest.approx(4.5 / math.sqrt(4.5 * 5), abs=1e-15)
    rng = np.random.default_rng(3)
    for _ in range(5):  # yields with ties (k / 8) against integer counts with ties
        x = rng.integers(0, 9, 11) / 8
        y = rng.integers(2, 6, 11)
        reference = stats.spearmanr(x, y)
        assert ojy.spearman(x, y) == pytest.approx(
            (reference.statistic, reference.pvalue), rel=1e-10
        )


def test_spearman_undefined_and_bad_input():
    rho, p = ojy.spearman([1.0, 1.0, 1.0], [1, 2, 3])  # every net folded: no ranking
    assert math.isnan(rho) and math.isnan(p)
    rho, p = ojy.spearman([1, 2], [2, 1])
    assert rho == -1.0 and math.isnan(p)
    assert ojy.spearman([1, 2, 3], [3, 2, 1]) == (-1.0, 0.0)
    with pytest.raises(ValueError, match="equal length >= 2"):
        ojy.spearman([1, 2, 3], [1, 2])
    with pytest.raises(ValueError, match="finite"):
        ojy.spearman([1, 2, math.nan], [1, 2, 3])


# ---- the family, with a stand-in estimate -------------------------------------------------------

FOLDED = {"cube_net_01": 1, "cube_net_02": 3, "cube_net_03": 2}  # of 4 samples


# With a precision (`SampleUntil`), the samples each net took.
TAKEN = {"cube_net_01": 20, "cube_net_02": 45, "cube_net_03": 30}


@dataclasses.dataclass
class _Estimate:
    counts: dict
    n_samples: int = 4
    seconds_per_sample: float = 0.5

    def to_dict(self):
        return {
            "counts": self.counts,
            "yield": self.counts["folded"] / self.n_samples,
            "n_samples": self.n_samples,
        }


@pytest.fixture
def fake(monkeypatch):
    """`yield_estimate` replaced: the counts of `FOLDED`, every call recorded."""
    calls = []

    def estimate(net, scatter, n, seed, *, design, process, solve, tolerances, run):
        calls.append(
            {"name": net.name, "n": n, "seed": seed, "out": run.out, "settle": run.t_settle}
        )
        if run.out is not None:
            run.out.mkdir(parents=True, exist_ok=True)
        folded = FOLDED[net.name]
        n = TAKEN[net.name] if isinstance(n, ojy.SampleUntil) else n
        return _Estimate({"folded": folded, "jammed": n - folded, "misfolded": 0,
                          "unfinished": 0, "invalid": 0}, n)  # fmt: skip

    monkeypatch.setattr(_family, "yield_estimate", estimate)
    return calls


def test_family_yield_table_and_correlations(fake, tmp_path):
    out = tmp_path / "family"
    family = ojy.family_yield(
        "cube_net_01,cube_net_02,cube_net_03", n_samples=4, seed=7, run=ojy.RunOptions(out=out)
    )
    # Every net from the same seed and samples, each in its own folder.
    assert [c["name"] for c in fake] == list(FOLDED)
    assert {(c["n"], c["seed"], c["settle"]) for c in fake} == {(4, 7, ojy.SETTLE_TIME)}
    assert [c["out"] for c in fake] == [out / n for n in FOLDED]
    assert family.names == tuple(FOLDED)
    yields = [FOLDED[n] / 4 for n in FOLDED]
    assert [r.fraction for r in family.rows] == yields
    assert family.rows[0].interval == ojy.wilson_interval(1, 4)
    for row in family.rows:  # compactness from the flat net, independently read
        geometry = net_geometry(catalogue_path(row.name))
        assert row.radius_of_gyration == pytest.approx(geometry.radius_of_gyration())
        assert row.vertex_connections == len(geometry.vertex_connections())
    for measure, key in (("radius_of_gyration", "radius_of_gyration"), ("vertex_connections",
                         "vertex_connections")):  # fmt: skip
        values = [getattr(r, key) for r in family.rows]
        rank = family.correlations[measure]
        if len(set(values)) > 1:
            assert rank.rho == pytest.approx(stats.spearmanr(yields, values).statistic)
        else:
            assert math.isnan(rank.rho)
        assert rank.n == 3
    # The CSV: a header and one line per net with every column of the table.
    rows = list(csv.DictReader(io.StringIO(family.to_csv())))
    assert [r["name"] for r in rows] == list(FOLDED)
    assert set(rows[0]) == {
        "name", "yield", "interval_low", "interval_high", "folded", "jammed", "misfolded",
        "unfinished", "invalid", "radius_of_gyration_um", "vertex_connections", "n_samples",
    }  # fmt: skip
    assert float(rows[1]["yield"]) == 0.75 and int(rows[1]["jammed"]) == 1
    assert float(rows[0]["radius_of_gyration_um"]) == pytest.approx(
        family.rows[0].radius_of_gyration
    )
    summary = json.loads(json.dumps(family.to_dict()))
    assert summary["nets"][2]["counts"]["folded"] == 2
    assert set(summary["spearman"]) == set(ojy.MEASURES)
    # Each finished net's summary is kept in its folder.
    stored = json.loads((out / "cube_net_02" / "estimate.json").read_text())
    assert stored["counts"]["folded"] == 3 and stored["settings"]["seed"] == 7


def test_family_resume_skips_finished_nets(fake, tmp_path):
    out = tmp_path / "family"
    names = ["cube_net_01", "cube_net_02", "cube_net_03"]
    first = ojy.family_yield(names, n_samples=4, run=ojy.RunOptions(out=out))
    # As if interrupted during the third net: its summary is not there yet.
    (out / "cube_net_03" / "estimate.json").unlink()
    fake.clear()
    again = ojy.family_yield(names, n_samples=4, run=ojy.RunOptions(out=out, resume=True))
    assert [c["name"] for c in fake] == ["cube_net_03"]  # the finished two are read back
    assert again.table() == first.table()
    assert [r.seconds_per_sample for r in again.rows] == [0.0, 0.0, 0.5]
    with pytest.raises(ValueError, match="other settings"):
        ojy.family_yield(names, n_samples=5, run=ojy.RunOptions(out=out, resume=True))


def test_family_to_a_precision_gives_each_net_its_own_count(fake, tmp_path):
    """With a `SampleUntil`, each net's estimate gets it (and samples as its yield needs): each
    row's yield and interval are over its own count; the settings record the precision, and a
    family resumed with another one is refused."""
    out = tmp_path / "family"
    until = ojy.SampleUntil(half_width=0.1, first=20, most=200)
    family = ojy.family_yield(list(FOLDED), n_samples=until, run=ojy.RunOptions(out=out))
    assert {c["n"] for c in fake} == {until}
    assert [r.n_samples for r in family.rows] == list(TAKEN.values())
    assert [r.fraction for r in family.rows] == [FOLDED[n] / TAKEN[n] for n in FOLDED]
    assert family.rows[1].interval == ojy.wilson_interval(3, 45)
    assert family.n_samples == 45 and family.settings["n_samples"]["half_width"] == 0.1
    assert "45 samples" in family.summary()
    again = ojy.family_yield(
        list(FOLDED), n_samples=until, run=ojy.RunOptions(out=out, resume=True)
    )
    assert again.table() == family.table()
    with pytest.raises(ValueError, match="other settings"):
        ojy.family_yield(list(FOLDED), n_samples=dataclasses.replace(until, half_width=0.05),
                         run=ojy.RunOptions(out=out, resume=True))  # fmt: skip


def test_family_refuses_what_is_not_a_family(fake):
    with pytest.raises(ValueError, match="at least two nets"):
        ojy.family_yield(["cube_net_01"])
    with pytest.raises(ValueError, match="named twice"):
        ojy.family_yield(["cube_net_01", "cube_net_01"])
    with pytest.raises(ValueError, match="'vertex_degree4' is not a net"):
        ojy.family_yield(["cube_net_01", "vertex_degree4"])
    with pytest.raises(ValueError, match="family's name"):
        ojy.family_yield("cube_net_01")
    assert fake == []  # refused before anything ran
    assert ojy.family_names("octahedron_nets") == [f"octahedron_net_{i:02d}" for i in range(1, 12)]
    assert ojy.family_names("a, b") == ["a", "b"] and ojy.family_names("cube_net_01") is None


def test_cli_family_writes_table_figure_and_resumes(fake, tmp_path, capsys):
    from origami_jax.cli import main

    out = tmp_path / "cli"
    argv = ["yield", "cube_net_01,cube_net_02,cube_net_03", "--samples", "4", "--no-progress"]
    argv += ["--out", str(out)]
    assert main(argv) == 0, capsys.readouterr().err
    result = json.loads((out / "family.json").read_text())
    assert [n["name"] for n in result["nets"]] == list(FOLDED)
    assert result["family"] == "cube_net_01,cube_net_02,cube_net_03"
    assert set(result["spearman"]) == {"radius_of_gyration", "vertex_connections"}
    assert (out / "family.csv").read_text().splitlines()[0].startswith("name,yield,interval_low")
    assert (out / "family.png").stat().st_size > 1000
    assert "Spearman rho vs radius_of_gyration" in capsys.readouterr().out
    assert main(argv) == 2  # the same folder again without --resume: refused in one line
    assert "--resume continues the family" in capsys.readouterr().err
    fake.clear()
    assert main([*argv, "--resume"]) == 0
    assert fake == []  # every net finished: none runs again
    capsys.readouterr()
    single = ["yield", "cube_net_01", "--samples", "4", "--out", str(out), "--resume"]
    assert main(single) == 2
    assert "holds a family of yield estimates" in capsys.readouterr().err
    # To a precision: every net its own count, in the table and the first line.
    fake.clear()
    precise = [*argv[:-1], str(tmp_path / "precise"), "--precision", "0.1", "--max-samples", "300"]
    assert main(precise) == 0, capsys.readouterr().err
    assert {c["n"] for c in fake} == {ojy.SampleUntil(0.1, first=4, most=300)}
    result = json.loads((tmp_path / "precise" / "family.json").read_text())
    assert [n["n_samples"] for n in result["nets"]] == list(TAKEN.values())
    assert "samples until ±0.1 (first 4, at most 300)" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--improve", "2"], "--improve takes one net, not a family"),
        (["--widths", "0.5,1"], "--widths takes one net, not a family"),
        (["--release", "0,0,0,0,0"], "--release takes one net, not a family"),
        (["--etch-front", "1,0,1"], "--etch-front takes one net, not a family"),
        (["--process", "hinge_width=1,2,3,4,5"], "a family takes one value per parameter"),
    ],
)
def test_cli_family_refuses_single_net_options(fake, tmp_path, capsys, flags, message):
    from origami_jax.cli import main

    argv = ["yield", "cube_nets", "--samples", "2", "--out", str(tmp_path / "x"), *flags]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1, err
    assert fake == [] and not (tmp_path / "x" / "family.json").exists()


# ---- for real ----------------------------------------------------------------------------------


FLAP = {  # one 200 µm square flap on a 200 µm square base, folding up 90°: the cheapest net
    "frame_unit": "um",
    "vertices_coords": [[0, 0], [200, 0], [200, 200], [0, 200], [200, 400], [0, 400]],
    "edges_vertices": [[2, 3], [0, 1], [1, 2], [3, 0], [2, 4], [4, 5], [5, 3]],
    "edges_assignment": ["V", "B", "B", "B", "B", "B", "B"],
    "edges_foldAngle": [90, 0, 0, 0, 0, 0, 0],
    "faces_vertices": [[0, 1, 2, 3], [3, 2, 4, 5]],
}


@pytest.mark.slow  # two nets' fold kernels compile (tens of seconds each on 2 cores)
def test_family_yield_runs_two_small_nets_like_their_own_estimates(tmp_path):
    flap = tmp_path / "flap.fold"
    flap.write_text(json.dumps(FLAP))
    # In the bath by default: the fluid's inertia, each net released over its quasi-static ramp.
    run = ojy.RunOptions(chunk_size=2, progress=False)
    family = ojy.family_yield(
        ["corner_cube", str(flap)], ojy.Scatter(), 2, seed=1,
        run=dataclasses.replace(run, out=tmp_path / "family"),
    )  # fmt: skip
    assert family.names == ("corner_cube", "flap")
    for row, source in zip(family.rows, ["corner_cube", str(flap)], strict=True):
        # The same seed scheme as one net's own estimate: the same samples, the same verdicts.
        alone = ojy.yield_estimate(source, ojy.Scatter(), 2, 1, run=run)
        assert row.counts == alone.counts
        assert sum(row.counts.values()) == 2
        assert (tmp_path / "family" / row.name / "sweep.nc").is_file()
    assert family.rows[1].vertex_connections == 0  # one crease, no seam
