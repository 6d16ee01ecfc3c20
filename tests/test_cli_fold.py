"""`origami-jax fold` without `--t1`: a run whose panels still move at the end is continued from where
it stopped, one segment at a time (`_fold.join_trajectories`), until it settles or the cap."""

import json

import jax.numpy as jnp
import numpy as np
import pytest

import origami_jax.simulation as sim
from origami_jax.cli import build_parser, main
from origami_jax.cli._fold import MAX_SEGMENTS, SEGMENT_US, join_trajectories


def _segment(t0, t1, n, angle0, steps, result=sim.RESULTS.successful):
    times = jnp.linspace(t0, t1, n)
    theta = (angle0 + 0.01 * (times - t0))[:, None] * jnp.array([1.0, -1.0])
    zeros = jnp.zeros_like(theta)
    stats = {
        "num_steps": jnp.asarray(steps),
        "num_accepted_steps": jnp.asarray(steps - 1),
        "num_rejected_steps": jnp.asarray(1),
        "max_steps": jnp.asarray(500_000),
        "switch_time": jnp.asarray(jnp.inf),
    }
    return sim.Trajectory(
        times=times,
        theta=theta,
        theta_dot=zeros + 0.01,
        theta_ddot=zeros,
        tau=zeros,
        target=jnp.array([1.5, -1.5]),
        stats=stats,
        result=result,
    )


def test_joined_trajectory_is_one_run_without_the_repeated_sample():
    first = _segment(0.0, 100.0, 11, 0.0, 40)
    then = _segment(100.0, 200.0, 11, 1.0, 25, result=sim.RESULTS.max_steps_reached)
    joined = join_trajectories(first, then)
    assert joined.times.shape == (21,) and joined.theta.shape == (21, 2)
    np.testing.assert_array_equal(joined.times, np.linspace(0.0, 200.0, 21))
    assert np.all(np.diff(np.asarray(joined.times)) > 0)  # the shared sample once
    np.testing.assert_array_equal(joined.theta[:11], first.theta)
    np.testing.assert_array_equal(joined.theta[11:], then.theta[1:])
    assert int(joined.stats["num_steps"]) == 65
    assert int(joined.stats["num_accepted_steps"]) == 63
    assert int(joined.stats["num_rejected_steps"]) == 2
    assert joined.result == sim.RESULTS.max_steps_reached  # the later run's code
    assert not bool(joined.succeeded)


def test_t1_is_optional_and_checked_when_given(capsys):
    args = build_parser().parse_args(["fold", "cube_net_01"])
    assert args.t1 is None
    assert SEGMENT_US * MAX_SEGMENTS >= 4000.0  # room for a net that rings in air
    assert main(["fold", "cube_net_01", "--t1", "-5", "--no-figures"]) == 2
    assert "--t1" in capsys.readouterr().err


@pytest.mark.slow  # compiles and folds a cube net with contact: about a minute on 2 cores
def test_a_cube_net_still_moving_at_the_first_segments_end_folds_on(tmp_path, capsys):
    # In the etch bath the cube net closes at ~1,350 µs: the first 1,000 µs end with it still
    # moving, the second segment finds it folded.
    code = main(["fold", "cube_net_01", "--fluid", "koh", "--no-figures", "--out", str(tmp_path)])
    assert code == 0, capsys.readouterr().err
    assert "folding on to 2000" in capsys.readouterr().out
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["verdict"] == "folded" and result["segments"] == 2
    assert result["t1"] == pytest.approx(2 * SEGMENT_US)
    assert 1000.0 < result["time_to_fold"] < 2000.0
    times = np.loadtxt(tmp_path / "trajectory.csv", delimiter=",", skiprows=1)[:, 0]
    assert times[-1] == pytest.approx(2 * SEGMENT_US) and np.all(np.diff(times) > 0)
