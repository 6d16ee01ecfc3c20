"""The benchmark suite's smoke run (`python -m benchmarks --quick`), on the benchmarks that take seconds.

Every benchmark checks that ours and the peer agree before it times anything and raises otherwise, so a
passing run here means the peers installed by the `test` extra (Pinocchio, MuJoCo, modern_robotics,
scipy) still give our answers. The heavier quick benchmarks (simulate, design, sweep: each compiles an
implicit ODE solve) run with `-m slow`. Timings are not asserted: performance is recorded in
benchmarks/RESULTS.md, not tested; its table is checked against the recorded JSON it is generated
from.
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


def test_results_table_is_the_recorded_json(tmp_path, monkeypatch, capsys):
    """benchmarks/RESULTS.md's table is what `python -m benchmarks.make_results` makes of the
    `benchmarks/results*.json` files (rerun it after recording results), every file is in it, and
    `--check` notices a table edited by hand."""
    from benchmarks import make_results

    assert make_results.main(["--check"]) == 0, capsys.readouterr().err
    text = make_results.RESULTS.read_text()
    files = make_results.load()
    assert files
    for name, data in files:
        assert f"`{name}`" in text
        for result in data["results"]:
            assert result["name"].replace("|", "/") in text
    edited = tmp_path / "RESULTS.md"
    edited.write_text(text.replace("| 1 (`results_cpu.json`) |", "| 2 (`results_cpu.json`) |", 1))
    assert edited.read_text() != text
    monkeypatch.setattr(make_results, "RESULTS", edited)
    assert make_results.main(["--check"]) == 1
    assert "differs from the JSON" in capsys.readouterr().err


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


@pytest.mark.slow  # builds a crease pattern's system (a few compiles); the peer is benchmark code
def test_bar_and_hinge_peer_forces_and_equilibrium():
    """The bar-and-hinge peer of the closed-loop benchmark on a 3×3 Miura-ori: its forces are minus the
    gradient of its spring energy (central differences, 1e-6 relative: the differences' truncation
    error at a 1e-4 µm step), its stiffness matrix the forces' Jacobian at the folded state (same), and
    the rigid folded state at the targets, placed by the panel tree's kinematics, is its equilibrium:
    every crease at its target, facets flat, bars at rest length (round-off, 1e-9)."""
    import numpy as np
    from benchmarks._bar_hinge import bar_hinge_model, folded_positions

    from origami_jax.loops import load_pattern
    from origami_jax.system import KOH_SOLUTION, HingeDesign

    pattern = load_pattern("miura_3x3")
    system = pattern.system(
        HingeDesign.literature(fluid=KOH_SOLUTION), contact=False, check_rigid=False
    )
    targets = np.asarray(system.hinges.target)
    bars = bar_hinge_model(pattern, system)
    folded = folded_positions(pattern, system, targets)
    crease = bars.hinge_crease >= 0
    angles = bars.angles(folded)
    assert np.max(np.abs(angles[crease] - targets[bars.hinge_crease[crease]])) < 1e-9
    assert np.max(np.abs(angles[~crease])) < 1e-9
    lengths = np.linalg.norm(folded[bars.bars[:, 1]] - folded[bars.bars[:, 0]], axis=-1)
    assert np.max(np.abs(lengths / bars.bar_length - 1)) < 1e-9
    scale = float(np.max(bars.bar_stiffness * bars.bar_length))
    zero = np.zeros_like(folded)
    assert np.max(np.abs(bars.forces(folded, zero)[bars.free])) < 1e-9 * scale

    def energy(x):
        length = np.linalg.norm(x[bars.bars[:, 1]] - x[bars.bars[:, 0]], axis=-1)
        rho = bars.angles(x)
        return 0.5 * np.sum(bars.bar_stiffness * (length - bars.bar_length) ** 2) + 0.5 * np.sum(
            bars.hinge_stiffness * (rho - bars.hinge_target) ** 2
        )

    rng = np.random.default_rng(0)
    x = folded + rng.normal(scale=2.0, size=folded.shape)  # µm, off equilibrium
    h = 1e-4
    gradient = np.zeros_like(x)
    for i in range(x.shape[0]):
        for c in range(3):
            step = np.zeros_like(x)
            step[i, c] = h
            gradient[i, c] = (energy(x + step) - energy(x - step)) / (2 * h)
    force = bars.forces(x, zero)
    assert np.max(np.abs(force + gradient)) < 1e-6 * np.max(np.abs(gradient))

    jacobian = np.zeros((x.size, x.size))
    for k in range(x.size):
        step = np.zeros(x.size)
        step[k] = h
        plus = bars.forces(folded + step.reshape(x.shape), zero).ravel()
        minus = bars.forces(folded - step.reshape(x.shape), zero).ravel()
        jacobian[:, k] = -(plus - minus) / (2 * h)
    stiffness = bars.stiffness_matrix(folded)
    assert np.max(np.abs(stiffness - jacobian)) < 1e-6 * np.max(np.abs(stiffness))


def test_fluid_peer_single_flap_closed_form():
    """The extended model's peer (`benchmarks._fluid_peer`: Pinocchio with the fluid's viscous wrench
    as `aba`'s external forces) on a single flap on a point hinge: the damping torque read back
    through `aba` is the closed form ``−C_a ω Im Γ (9/8) ρ_f π a⁴ w θ̇`` (1e-12: the same arithmetic,
    but the wrench goes through the shift from the flap's centre to the joint and Pinocchio's frame
    convention for `fext`: about the flap's centre instead of the hinge it would be 1/9 of it),
    at the hinge frequency ``√(k / I_hinge)`` of a plate about its edge (1e-12)."""
    import numpy as np
    import pinocchio as pin
    from benchmarks._fluid_peer import accordion_model, flap_size, viscous_rhs

    from origami_jax.system import HingeDesign

    design = HingeDesign.literature()
    theta = float(design.theta_final)
    k1 = np.asarray(design.stiffness(1))
    rhs, terms = viscous_rhs(design, 1, k1, np.zeros(1), np.array([theta]))
    q = np.array([0.7])
    model = accordion_model(design, 1)
    mass = pin.crba(model, model.createData(), q)[0, 0]
    torque = -mass * (rhs(0.0, np.r_[q, 1.0])[1] - rhs(0.0, np.r_[q, -1.0])[1]) / 2
    length, width = flap_size(design)
    a = 0.5 * length
    closed = (
        float(design.added_mass_coefficient)
        * terms["frequency"][0]
        * terms["gamma"][0].imag
        * 9
        / 8
        * float(design.fluid.density)
        * np.pi
        * a**4
        * width
    )
    assert abs(torque / closed - 1) < 1e-12
    thickness = float(design.t_structural)
    m = float(design.structural.density) * length * width * thickness
    hinge_inertia = m * (length**2 / 3 + thickness**2 / 12)
    assert abs(terms["frequency"][0] / np.sqrt(k1[0] / hinge_inertia) - 1) < 1e-12
    assert 10 < terms["reynolds"][0] < 100  # the air case: Im Γ is neither ~0 nor Stokes-dominated


@pytest.mark.slow  # builds two extended systems eagerly (~30 s on a loaded 2-core machine)
def test_fluid_peer_against_ours():
    """The extended model's peer (`benchmarks._fluid_peer`: viscous drag through `aba`'s `fext`,
    added inertia through `crba` + ``Σ Jᵀ A J`` with Kirchhoff's velocity terms) against our
    right-hand side of the 3-flap accordion with viscous drag and with added inertia at a folded,
    moving state (1e-11 relative: two independent implementations, Sader's Bessel ratio by scipy
    against our trapezoid rule, 1e-13, and the frequency fixed point iterated to round-off;
    measured 6e-16 with viscous drag and 4e-14 with added inertia)."""
    import numpy as np
    from benchmarks._fluid_peer import added_mass_rhs, flap_size, viscous_rhs

    from origami_jax.chain import accordion_system
    from origami_jax.system import HingeDesign

    design = HingeDesign.literature()
    theta = float(design.theta_final)
    n = 3
    targets = np.array([theta, -theta, theta])
    k, b = np.asarray(design.stiffness(n)), np.asarray(design.drag(n, *flap_size(design)))
    state = np.array([0.9, -1.7, 2.4, 0.03, -0.05, 0.08])  # rad, rad/µs
    for fluid, peer in (("viscous", viscous_rhs), ("added_mass", added_mass_rhs)):
        system = accordion_system(design, n, fluid=("hinge", fluid))
        ours = np.asarray(
            system.accelerations(state[:n], state[n:], system.hinges.stiffness * targets)
        )
        theirs = peer(design, n, k, b, targets)[0](0.0, state)[n:]
        assert np.max(np.abs(ours - theirs)) < 1e-11 * np.max(np.abs(theirs)), fluid
