"""CLI `origami-jax simulate` and the chain figures (GIF, frame strip, annotated angles)."""

import json

import equinox as eqx
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np

import origami_jax.simulation as sim
from origami_jax.chain import accordion, alternating_targets
from origami_jax.cli import main
from origami_jax.plotting import chain as chain_plots


def _fake_trajectory(n_t=40):
    times = jnp.linspace(0.0, 100.0, n_t)
    y = 1 - jnp.exp(-times / 20.0) * jnp.cos(times / 10.0)
    target = alternating_targets(3)
    theta = y[:, None] * target
    v = jnp.gradient(y, times)[:, None] * target
    return sim.Trajectory(
        times=times,
        theta=theta,
        theta_dot=v,
        theta_ddot=jnp.gradient(v, times, axis=0),
        tau=jnp.zeros_like(theta),
        target=target,
        stats={},
        result=sim.RESULTS.successful,
    )


def test_figures_and_animation(tmp_path):
    chain = accordion(3)
    trajectory = _fake_trajectory()
    metrics = sim.response_metrics(trajectory)
    fig = chain_plots.plot_joint_angles(trajectory, metrics, title="test")
    fig.savefig(tmp_path / "angles.png")
    plt.close(fig)
    fig = chain_plots.folding_frames(chain, trajectory, tmp_path / "frames.png", n_frames=3)
    plt.close(fig)
    gif = chain_plots.animate_folding(chain, trajectory, tmp_path / "fold.gif", n_frames=4)
    for name in ("angles.png", "frames.png", "fold.gif"):
        assert (tmp_path / name).stat().st_size > 1000
    assert gif.suffix == ".gif"
    corners = np.stack(chain.panel_polygons(np.zeros(3)))
    # Flat accordion: three 200 µm × 200 µm flaps side by side along y.
    # (The length comes from the plate inertia, sqrt(L² + t²): 1e-4 µm long for t = 0.2 µm.)
    np.testing.assert_allclose(corners[:, :, 1].min(), 0.0, atol=1e-3)
    np.testing.assert_allclose(corners[:, :, 1].max(), 600.0, atol=1e-3)


def test_the_frames_and_the_animation_share_one_poses_program(tmp_path, monkeypatch):
    # Their frame counts (6 and 24 in the fold command) are padded to one shape: one program to
    # compile and to load per command, and the poses those of the unpadded states, to the bit
    # (compiled alike: a program run once, `QUICK_COMPILE`).
    import equinox._errors
    import jax

    from origami_jax import _exported
    from origami_jax.plotting import frames as _frames

    monkeypatch.setattr(_exported, "_FOLDER", tmp_path)
    monkeypatch.setattr(_exported, "_LOADED", {})
    monkeypatch.setattr(equinox._errors, "EQX_ON_ERROR", "nan")
    monkeypatch.setattr(_frames, "_BATCHED_POSES", None)
    chain = accordion(3)
    states = np.asarray(_fake_trajectory(24).theta)
    for n in (1, 6, 24):
        poses = _frames._batched_poses(chain, states[:n])
        unpadded = jnp.asarray(states[:n])
        quick = jax.jit(jax.vmap(chain.body_poses)).lower(unpadded).compile(_exported.QUICK_COMPILE)
        expected = quick(unpadded)
        assert poses.shape == expected.shape
        np.testing.assert_array_equal(poses, np.asarray(expected))
    assert len(list(tmp_path.glob("batched_poses-*.bin"))) == 1


def test_cli_simulate_writes_trajectory_and_metrics(tmp_path, capsys):
    code = main(
        [
            "simulate",
            "--input",
            "step",
            "--flaps",
            "2",
            "--solver",
            "auto",
            "--t1",
            "300",
            "--n-save",
            "301",
            "--param",
            "k_scale=2",
            "--no-figures",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 0
    header = (tmp_path / "trajectory.csv").read_text().splitlines()[0]
    assert header.startswith("time [us],theta_1 [rad]") and "tau_2 [pN*m]" in header
    report = json.loads((tmp_path / "metrics.json").read_text())
    assert report["succeeded"] and report["params"] == {"k_scale": 2.0}
    assert len(report["metrics"]["rise_time"]) == 2
    # The default solver stays explicit in air: no switch time (JSON null, not a crash on inf).
    assert report["stats"]["switch_time"] is None and report["stats"]["num_steps"] > 0


def test_cli_simulate_rejects_bad_params(tmp_path, capsys):
    assert main(["simulate", "--param", "nonsense", "--out", str(tmp_path)]) == 2
    assert main(["simulate", "--param", "no_such_field=1", "--out", str(tmp_path)]) == 2


def test_host_side_reads_compile_nothing(caplog):
    """What a command does on the host with a finished run compiles no program: `jnp.asarray` and
    `==` on device arrays compile one per new shape in each process (~20 ms each, most of a warm
    command's eager work), where `jax.device_put` and NumPy compile none."""
    import logging

    import jax

    from origami_jax.simulation import RESULTS

    n = 7  # a shape nothing else in the suite uses
    trajectory = sim.Trajectory(
        times=jnp.linspace(0.0, 1.0, n),
        theta=jnp.zeros((n, 3)),
        theta_dot=jnp.zeros((n, 3)),
        theta_ddot=jnp.zeros((n, 3)),
        tau=jnp.zeros((n, 3)),
        target=jnp.zeros(3),
        stats={},
        result=RESULTS.successful,
    )
    with jax.log_compiles(True), caplog.at_level(logging.WARNING):
        caplog.clear()
        succeeded = trajectory.succeeded
        step = sim.Step(ramp=40_000.0 + n)
    assert bool(np.all(succeeded)) and float(step.ramp) == 40_007.0
    assert not [r for r in caplog.records if "Compiling" in r.getMessage()]
    failed = eqx.tree_at(lambda t: t.result, trajectory, RESULTS.nonfinite_state)
    assert not bool(failed.succeeded)
