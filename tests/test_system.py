"""The folding system: one model object, one builder, the same model through every entry point."""

import json

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.design as ojd
import origami_jax.simulation as sim
from origami_jax.chain import Accordion, accordion, accordion_system
from origami_jax.cli import main
from origami_jax.sweep import get_model
from origami_jax.system import FoldingSystem, HingeDesign, HingeDrag, Hinges

# Every entry point integrates the same ODE at rtol 1e-9; their samples agree to the solvers' accuracy.
SAME_MODEL_RAD = 1e-6
THETA_FINAL = 2.5  # rad: not π, so a builder that ignores θ_final is caught
T1, N_SAVE, RTOL, ATOL = 300.0, 301, 1e-9, 1e-11


def _reference():
    design = HingeDesign.literature(theta_final=THETA_FINAL)
    system = accordion_system(design, 3)
    trajectory = sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(saveat=sim.SaveAt(n=N_SAVE), solver=diffrax.Tsit5(), rtol=RTOL, atol=ATOL),
        t1=T1,
    )
    return design, system, trajectory


def test_builder_targets_follow_theta_final():
    design, system, _ = _reference()
    np.testing.assert_allclose(system.hinges.target, [THETA_FINAL, -THETA_FINAL, THETA_FINAL])
    np.testing.assert_allclose(system.hinges.stiffness, design.stiffness(3))
    np.testing.assert_allclose(system.drag.coefficient, design.drag(3, 200.0, 200.0))
    np.testing.assert_allclose(system.hinges.radius, design.radius())
    assert Accordion(3)(design).hinges.target.shape == (3,)


def test_the_flaps_are_the_patterns():
    """The flap size is the accordion pattern's: it reaches the chain's masses (ρ L w t, SiNx
    3100 kg/m³ = 3.1e-3 ng/µm³, 200 nm), the paper's drag C_D ν (L w) L³ / 16 (air, 1.204e-6
    ng/µm³) and the sweep kernel's defaults; a bad size is refused in one line (1e-12: rounding)."""
    design = HingeDesign.literature()
    wide = Accordion(2, flap_length=150.0, flap_width=90.0)
    system = wide(design)
    np.testing.assert_allclose(system.mechanism.masses, 3.1e-3 * 150 * 90 * 0.2, rtol=1e-12)
    b = 1.17 * 1.204e-6 * 150 * 90 * 150**3 / 16
    np.testing.assert_allclose(system.drag.coefficient, [b, b], rtol=1e-12)
    assert wide.geometry(design.units) == {"flap_length": 150.0, "flap_width": 90.0}
    defaults = wide.kernel(t_end=10.0, n_save=3).settings["defaults"]
    assert (defaults["flap_length"], defaults["flap_width"]) == (150.0, 90.0)
    assert hash(wide) == hash(Accordion(2, flap_length=150, flap_width=90.0))  # compared by value
    with pytest.raises(ValueError, match="flap_length must be finite and positive"):
        Accordion(2, flap_length=-1.0)
    with pytest.raises(ValueError, match="unknown field"):
        wide.with_geometry(hinge_width=3.0)


@pytest.mark.slow  # three compiled solves of the accordion: ~17 s of the default suite
def test_same_design_through_every_entry_point(tmp_path):
    """CLI `simulate`, `design`'s forward model and the sweep kernel build the same system from the
    same design, with θ_final free: their responses agree with a direct `simulate` to solver accuracy."""
    _, _, reference = _reference()
    metrics = sim.response_metrics(reference)

    # 1. The command line (in-process; the same solve structure as the reference: compiled once).
    code = main(
        [
            "simulate",
            "--flaps", "3",
            "--solver", "tsit5",
            "--param", f"theta_final={THETA_FINAL}",
            "--t1", str(T1),
            "--n-save", str(N_SAVE),
            "--rtol", str(RTOL),
            "--atol", str(ATOL),
            "--no-figures",
            "--out", str(tmp_path),
        ]
    )  # fmt: skip
    assert code == 0
    table = np.loadtxt(tmp_path / "trajectory.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 1:4], reference.theta, atol=SAME_MODEL_RAD)
    report = json.loads((tmp_path / "metrics.json").read_text())
    np.testing.assert_allclose(report["metrics"]["rise_time"], metrics.rise_time, rtol=1e-6)

    # 2. `design`'s forward model, θ_final a free parameter set through its parameter space.
    hinge = HingeDesign.literature(theta_final=3.0)
    space = ojd.parameter_space(hinge, ["theta_final"], {"theta_final": (1.0, float(np.pi))})
    candidate = space.apply(hinge, jnp.array([THETA_FINAL]))
    options = sim.FIT_OPTIONS.replace(saveat=sim.SaveAt(n=N_SAVE), rtol=RTOL, atol=ATOL)
    settings = ojd.SimulationSettings(T1, n_flaps=3, options=options)
    trajectory, _ = ojd.response(candidate, settings)
    np.testing.assert_allclose(trajectory.theta, reference.theta, atol=SAME_MODEL_RAD)

    # 3. The sweep kernel, θ_final swept.
    kernel = get_model(
        "accordion-step", solver="tsit5", t_end=T1, n_save=N_SAVE, rtol=RTOL, atol=ATOL
    )
    out = jax.jit(kernel.fn)({"theta_final": jnp.asarray(THETA_FINAL)})
    assert int(out["result"]) == 0
    np.testing.assert_allclose(out["rise_time"], metrics.rise_time, rtol=1e-6)
    np.testing.assert_allclose(out["overshoot"], metrics.overshoot, atol=1e-5)


def test_generalized_force_is_the_papers_equation_11():
    _, system, _ = _reference()
    q = jnp.array([0.3, -0.7, 1.1])
    v = jnp.array([0.02, -0.05, 0.01])
    tau = jnp.array([10.0, -20.0, 30.0])
    k, b = system.hinges.stiffness, system.drag.coefficient
    np.testing.assert_allclose(
        system.generalized_force(q, v, tau), tau - k * q - b * v * jnp.abs(v), rtol=1e-14
    )
    # Drag only takes energy out.
    assert float(system.drag.dissipation(system.mechanism, q, v)) > 0
    energy = system.energy(q, v)
    np.testing.assert_allclose(
        energy,
        system.mechanism.kinetic_energy(q, v) + 0.5 * jnp.sum(k * q**2),
        rtol=1e-14,
    )


def test_bad_systems_are_refused():
    chain = accordion(3)
    with pytest.raises(ValueError, match="3"):
        FoldingSystem(chain, Hinges(1.0, jnp.zeros(2), 1.0), HingeDrag(jnp.zeros(3)))
    # A ValueError without run-time type checking; jaxtyping's TypeError (a TypeCheckError) with it.
    with pytest.raises((ValueError, TypeError), match="AbstractMechanism"):
        FoldingSystem("chain", Hinges(1.0, jnp.zeros(3), 1.0), HingeDrag(jnp.zeros(3)))  # pyright: ignore[reportArgumentType]
    with pytest.raises(ValueError, match="stiffness must be positive"):
        Hinges(-1.0, jnp.zeros(3), 1.0)
    with pytest.raises(ValueError, match="release_time"):
        Hinges(1.0, jnp.zeros(3), 1.0, release_time=-1.0)
    with pytest.raises(ValueError, match="shape"):
        Hinges(jnp.ones(2), jnp.zeros(3), 1.0)
    with pytest.raises((ValueError, TypeError), match="HingeDesign"):
        accordion_system(chain, 3)  # pyright: ignore[reportArgumentType]
    with pytest.raises(ValueError, match="n_flaps"):
        Accordion(0)


def test_rest_frequencies_are_the_springs_against_the_inertia():
    """Against scipy's generalized symmetric eigensolver on ``K = diag(k)`` (a chain's coordinates
    are its hinge angles) and ``M(0)``: agreement to 1e-10 relative (two routes to the same
    eigenvalues in float64). A chain of one flap: ``ω = sqrt(k / M₀₀)``. The cheap bound (each
    coordinate's Rayleigh quotient) is at most the largest, and that one for one flap."""
    import scipy.linalg

    system = accordion_system(HingeDesign.literature(), n_flaps=3)
    mechanism = system.mechanism
    mass = np.asarray(eqx.filter_jit(lambda m: m.mass_matrix(m.rest_state()[0]))(mechanism))
    stiffness = np.diag(np.asarray(system.hinges.stiffness))
    expected = np.sqrt(scipy.linalg.eigh(stiffness, mass, eigvals_only=True))
    frequencies = system.rest_frequencies()
    np.testing.assert_allclose(frequencies, expected, rtol=1e-10)
    bound = system.stiffest_rest_frequency_bound()
    assert frequencies[-1] * 0.2 < bound <= frequencies[-1] * (1 + 1e-12)
    one = accordion_system(HingeDesign.literature(), n_flaps=1)
    inertia = float(one.mechanism.mass_matrix(one.mechanism.rest_state()[0])[0, 0])
    closed_form = np.sqrt(float(one.hinges.stiffness[0]) / inertia)
    np.testing.assert_allclose(one.rest_frequencies(), [closed_form], rtol=1e-12)
    np.testing.assert_allclose(one.stiffest_rest_frequency_bound(), closed_form, rtol=1e-12)


@pytest.mark.slow  # a closed-loop pattern's system: ~15 s
def test_rest_frequencies_refuse_closed_loops():
    from origami_jax.loops import load_pattern

    with pytest.raises(ValueError, match="positive definite at rest"):
        load_pattern("miura_3x3").system().rest_frequencies()  # closed loops: constrained
