"""Design spaces: grids, Latin-hypercube and uniform samples, tables, products."""

import numpy as np
import pytest

from origami_jax.sweep import Grid, Range, Samples, Table


def test_grid_is_full_factorial_in_c_order():
    grid = Grid({"w": [1.0, 2.0], "e": [10, 20, 30], "fluid": ["air", "koh"]}, units={"w": "um"})
    columns = grid.columns()
    assert grid.size == len(grid) == 12 and grid.shape == (2, 3, 2)
    designs = list(zip(columns["w"], columns["e"], columns["fluid"], strict=True))
    expected = [(w, e, f) for w in (1.0, 2.0) for e in (10, 20, 30) for f in ("air", "koh")]
    assert designs == expected
    assert columns["e"].dtype == np.int64 and columns["fluid"].dtype.kind == "U"
    assert grid.unit("w") == "um" and grid.unit("e") == ""
    assert grid.categories("fluid") == ("air", "koh")


def test_lhs_is_stratified_in_every_parameter():
    n = 50
    samples = Samples(
        {"a": Range(0.0, 2.0), "b": Range(1e-6, 1e-3, scale="log"), "c": (-1, 1)}, n=n, seed=3
    )
    columns = samples.columns()
    unit = {
        "a": columns["a"] / 2.0,
        "b": (np.log(columns["b"]) - np.log(1e-6)) / (np.log(1e-3) - np.log(1e-6)),
        "c": (columns["c"] + 1) / 2,
    }
    for name, u in unit.items():
        strata = np.floor(u * n).astype(int)
        # Exactly one design in each of the n equal strata (in log space for the log range).
        assert sorted(strata.tolist()) == list(range(n)), name
    # Strata are paired by independent permutations, not in lock step.
    assert not np.array_equal(np.argsort(unit["a"]), np.argsort(unit["b"]))


def test_samples_are_seeded_and_in_range():
    ranges = {"a": Range(2.0, 3.0), "b": Range(0.1, 10.0, scale="log")}
    first = Samples(ranges, n=200, seed=7, method="uniform").columns()
    again = Samples(ranges, n=200, seed=7, method="uniform").columns()
    other = Samples(ranges, n=200, seed=8, method="uniform").columns()
    np.testing.assert_array_equal(first["a"], again["a"])
    assert not np.array_equal(first["a"], other["a"])
    assert first["a"].min() >= 2.0 and first["a"].max() < 3.0
    assert first["b"].min() >= 0.1 and first["b"].max() < 10.0
    # Log scale: about half of the designs below the geometric midpoint 1.0.
    assert 70 < int((first["b"] < 1.0).sum()) < 130
    lhs = Samples(ranges, n=200, seed=7).to_config()
    assert lhs["sha256"] != Samples(ranges, n=200, seed=8).to_config()["sha256"]


def test_table_and_product():
    table = Table.from_records([{"w": 1.0, "k": 2}, {"w": 3.0, "k": 4}], units={"w": "m"})
    assert table.size == 2 and table.columns()["k"].tolist() == [2, 4]
    space = Grid({"n": [2, 3]}, static=("n",)) * table
    columns = space.columns()
    assert space.size == 4 and space.static == ("n",)
    assert columns["n"].tolist() == [2, 2, 3, 3]
    assert columns["w"].tolist() == [1.0, 3.0, 1.0, 3.0]
    assert space.units == {"w": "m"}


@pytest.mark.parametrize(
    "make",
    [
        lambda: Grid({}),
        lambda: Grid({"a": []}),
        lambda: Grid({"a": [1.0, np.nan]}),
        lambda: Grid({"a": [1.0]}, static=("b",)),
        lambda: Grid({"design": [1.0]}),
        lambda: Range(1.0, 1.0),
        lambda: Range(0.0, 1.0, scale="log"),
        lambda: Samples({"a": (0, 1)}, n=0),
        lambda: Samples({"a": (0, 1)}, n=3, method="sobol"),
        lambda: Table({"a": [1, 2], "b": [1]}),
        lambda: Grid({"a": [1]}) * Grid({"a": [2]}),
    ],
)
def test_bad_spaces_are_refused_before_any_compute(make):
    with pytest.raises(ValueError):
        make()
