"""The compactness study's script (`benchmarks/compactness_study.py`): its configurations carry
the documented values in the design's units, and its table reads the stored pilot files. Cheap:
nothing is simulated (the pilot itself is hours of CPU; its numbers are in docs/data/)."""

import json
from pathlib import Path

import numpy as np
import pytest
from benchmarks.compactness_study import CONFIGS, configured, describe, run_times, table

from origami_jax.fab_yield import SETTLE_TIME
from origami_jax.system import KOH_SOLUTION

DATA = Path(__file__).resolve().parents[1] / "docs" / "data" / "compactness_pilot"


def test_surface_configuration_is_the_top_of_the_koh_range():
    """`surface`: w = 10 mJ/m², γ = w × 0.2 µm, µ = 0.3 (docs/physics.md's KOH ranges), converted
    to MICRO by hand: an energy per area µN·µm/µm² = 1e-6 N·1e-6 m/1e-12 m² = 1 J/m²; an energy
    per length µN = 1e-6 J/m; a speed µm/µs = 1 m/s. Exact conversions: rtol 1e-12."""
    net = configured("cube_net_10", "surface")
    assert net.hinges == "point"
    activation = float(net.system(net.default_design(KOH_SOLUTION)).contact.activation)  # µm
    np.testing.assert_allclose(float(net.adhesion.work), 0.01 / 1.0, rtol=1e-12)
    np.testing.assert_allclose(float(net.adhesion.line), 0.01 * 0.2e-6 / 1e-6, rtol=1e-12)
    np.testing.assert_allclose(float(net.adhesion.range), 2 * activation, rtol=1e-12)
    np.testing.assert_allclose(float(net.friction.coefficient), 0.3, rtol=1e-12)
    np.testing.assert_allclose(float(net.friction.slip), 0.01 / 1.0, rtol=1e-12)
    control = configured("cube_net_10", "control")
    assert control.adhesion is None and control.friction is None
    # The paper's dynamics in the bath: no fluid inertia, released at once.
    assert control.fluid_inertia(control.default_design(KOH_SOLUTION)) == (False, False)
    assert control.release_ramp is None
    assert configured("cube_net_10", "arc").hinges == "arc"
    assert describe("control") == {"config": "control", "hinges": "point"}
    with pytest.raises(ValueError, match="config must be one of"):
        configured("cube_net_10", "sticky")
    assert sorted(CONFIGS) == ["arc", "arc-surface", "bath", "control", "quasi-static", "surface"]
    # `bath`: the package's defaults (each net's own quasi-static ramp, its own run time).
    bath = configured("cube_net_10", "bath")
    assert bath.release_ramp == "auto" and bath.added_mass is None
    assert run_times("bath", None) == (None, SETTLE_TIME)


def test_quasi_static_configuration_releases_slowly_in_the_baths_inertia():
    """`quasi-static`: the control with the fluid's inertia and viscosity and a 30 ms release
    ramp, run to the ramp + 6 ms and settled to twice that; the others keep 1500 µs and the
    yield's default settling."""
    net = configured("cube_net_10", "quasi-static")
    assert net.added_mass and net.viscous and net.release_ramp == 30_000.0
    assert net.adhesion is None and net.friction is None
    # Settled to twice the end time: 42 ms after the 30 ms ramp.
    assert run_times("quasi-static", None) == (36_000.0, 42_000.0)
    assert run_times("control", None) == (1500.0, SETTLE_TIME)
    assert run_times("control", 900.0) == (900.0, SETTLE_TIME)


def _family_of(folder: Path) -> str:
    """The family of a stored run: its first net's name without the number."""
    return json.loads((folder / "family.json").read_text())["nets"][0]["name"].rsplit("_", 1)[0]


def test_table_reads_the_stored_pilot():
    """Every stored pilot run's nets appear in the table with their counts, and each run's ρ is
    printed as stored (or said undefined where the yields are all equal)."""
    folders = sorted(p.parent for p in DATA.glob("*/family.json"))
    if not folders:
        pytest.skip("no stored pilot")
    # One table per family of nets (the cube nets' runs side by side, the octahedra's apart).
    families: dict[str, list[Path]] = {}
    for folder in folders:
        families.setdefault(_family_of(folder), []).append(folder)
    for folder in folders:
        text = table(families[_family_of(folder)])
        record = json.loads((folder / "family.json").read_text())
        for net in record["nets"]:
            folded = net["counts"].get("folded", 0)
            assert f"| {net['name']} |" in text
            assert f"{folded}/{net['n_samples']}" in text
        for c in record["spearman"].values():
            shown = "undefined" if c["rho"] is None or c["rho"] != c["rho"] else f"{c['rho']:+.2f}"
            assert f"{record['config']}: Spearman ρ vs {c['measure']} {shown}" in text
