"""The physics adapters of the sweep (`accordion-step`), and the model registry."""

import jax.numpy as jnp
import numpy as np
import pytest

from origami_jax.sweep import Grid, Table, available_models, get_model, sweep


def test_registry_lists_and_builds_models():
    models = available_models()
    assert set(models) == {"accordion-step", "net-fold", "vertex-unfold"}
    assert "accordion" in models["accordion-step"]
    with pytest.raises(ValueError, match="unknown model"):
        get_model("no-such-model")
    with pytest.raises(ValueError, match="fluid"):
        get_model("accordion-step", fluid="water")
    with pytest.raises(ValueError, match="unknown setting .tolerance.; its settings are n_flaps"):
        get_model("accordion-step", tolerance=1e-3)
    # The same kernel for the same settings (the sweep engine compiles a kernel once per object).
    kernel = get_model("accordion-step", n_flaps=2, t_end=500.0)
    assert get_model("accordion-step", t_end=500.0, n_flaps=2) is kernel
    assert get_model("accordion-step", n_flaps=2, t_end=600.0) is not kernel
    assert get_model("vertex-unfold", n_creases=6) is get_model("vertex-unfold", n_creases=6)


def test_accordion_refuses_unknown_parameters_and_fluids_before_compiling():
    kernel = get_model("accordion-step")
    with pytest.raises(ValueError, match="accepts"):
        sweep(kernel, Grid({"hinge_thickness": [1.0]}), progress=False)
    with pytest.raises(ValueError, match="knows"):
        sweep(kernel, Grid({"fluid": ["air", "water"]}), progress=False)


@pytest.mark.slow  # one compilation of the vmapped Kvaerno5 solve: minutes on a 2-core CPU
def test_accordion_step_matches_a_direct_simulation():
    from origami_jax.chain import accordion_system
    from origami_jax.simulation import (
        SaveAt,
        SolveOptions,
        Step,
        implicit_solver,
        response_metrics,
        simulate,
    )
    from origami_jax.system import KOH_SOLUTION, MICRO, HingeDesign

    kernel = get_model("accordion-step", t_end=1500.0, n_save=1501)
    space = Table(
        {
            "hinge_width": [60.0, -5.0, 150.0],
            "misfit_strain": [2.5e-3, 2.5e-3, 3e-3],
            "fluid": ["air", "air", "koh"],
        }
    )
    ds = sweep(kernel, space, chunk_size=3, progress=False)
    assert ds["result"].values.tolist() == [0, -1, 0]
    assert np.isnan(ds["rise_time"].values[1]).all()
    for i, fluid in ((0, None), (2, KOH_SOLUTION)):
        extra = {} if fluid is None else {"fluid": fluid}
        design = HingeDesign.literature(
            MICRO,
            hinge_width=float(space.columns()["hinge_width"][i]),
            misfit_strain=float(space.columns()["misfit_strain"][i]),
            **extra,
        )
        trajectory = simulate(
            accordion_system(design, 3),
            Step(),
            SolveOptions(saveat=SaveAt(n=1501), solver=implicit_solver()),
            t1=1500.0,
        )
        metrics = response_metrics(trajectory)
        np.testing.assert_allclose(ds["rise_time"].values[i], metrics.rise_time, rtol=1e-6)
        np.testing.assert_allclose(ds["overshoot"].values[i], metrics.overshoot, atol=1e-6)
        assert float(ds["stiffness"].values[i]) == pytest.approx(
            float(jnp.asarray(design.stiffness(3))[0])
        )


@pytest.mark.slow  # compiles the descent kernel (~20 s) and draws vertices on the host
def test_vertex_unfold_agrees_with_unfold():
    import jax

    from origami_jax.vertex import Verdict, random_vertex, unfold

    kernel = get_model("vertex-unfold", max_steps=400)
    ds = sweep(kernel, Grid({"n_creases": [4], "seed": [0, 1, 2]}), chunk_size=3, progress=False)
    assert ds["result"].values.tolist() == [0, 0, 0]
    for i, seed in enumerate((0, 1, 2)):
        reference = unfold(random_vertex(jax.random.key(seed), 4, closed=True), energy="separable")
        if reference.verdict == Verdict.FLAT_UNFOLDED and not reference.escapes:
            assert bool(ds["flat_unfolded"].values[i]) and bool(ds["certified"].values[i])


def test_accordion_cost_is_the_fastest_natural_frequency_times_the_run_length():
    # ω_max = sqrt(λ_max(M⁻¹K)): scaling every hinge stiffness by 4 doubles it; the flaps (M) are
    # untouched by k_scale. Checked against NumPy's generalized eigenvalues at the literature design.
    from origami_jax.chain import accordion_system, mass_matrix
    from origami_jax.system import MICRO, HingeDesign

    kernel = get_model("accordion-step", solver="tsit5", t_end=100.0)
    base = float(kernel.cost({"k_scale": jnp.asarray(1.0)}))
    assert float(kernel.cost({"k_scale": jnp.asarray(4.0)})) == pytest.approx(2 * base, rel=1e-12)
    design = HingeDesign.literature(MICRO)
    m = np.asarray(mass_matrix(accordion_system(design, 3).mechanism, jnp.zeros(3)))
    omega = np.sqrt(
        np.max(np.linalg.eigvals(np.linalg.solve(m, np.diag(design.stiffness(3)))).real)
    )
    assert base == pytest.approx(100.0 * omega, rel=1e-10)
    assert np.isinf(float(kernel.cost({"hinge_width": jnp.asarray(-1.0)})))  # invalid: last


def test_vertex_chunks_are_computed_one_at_a_time_and_a_sweep_of_them_finishes():
    # Two chunks of the vertex program computed at once on one CPU hung in XLA (jaxlib 0.10.2),
    # every time for 250 vertices of one size: its kernel asks for one at a time
    # (`Kernel.cpu_workers`), which a caller's `workers` overrides. In a fresh process, with a
    # deadline: a hang fails the test instead of the suite.
    import os

    from .helpers import run_python

    kernel = get_model("vertex-unfold")
    assert kernel.cpu_workers == 1
    done = run_python(
        """
        import json, jax
        jax.config.update("jax_enable_x64", True)
        from origami_jax.sweep import Grid, get_model, sweep
        space = Grid({"n_creases": [4], "seed": [float(s) for s in range(250)]})
        data = sweep(get_model("vertex-unfold"), space, progress=False)
        print(json.dumps({"workers": int(data.attrs["workers"]), "n": int(data.sizes["design"])}))
        """,
        {k: v for k, v in os.environ.items() if k != "JAX_COMPILATION_CACHE_DIR"},
    )
    assert done == {"workers": 1, "n": 250}
