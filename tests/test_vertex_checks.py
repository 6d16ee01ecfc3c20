"""Single-vertex inputs that used to be accepted with a wrong meaning, and sizes that used to hang.

- A fold angle beyond ±180° on an open vertex wrapped silently (190° valley became −170° mountain);
  a NaN fold angle passed the closure check (a NaN residual compares False with the tolerance).
- A flat disc folded along one straight line, 20 creases or more: the compiled validator saw
  crossings between collinear arcs that the eager one did not (signs of ±1e-17 determinants).
- `unfold(p=nan)` or `p=-2` ran; `random_vertex(key, 50, closed=True)` compiled for over 10 minutes.
- `HingeDesign(theta_final=100)` (degrees given as radians) made a 7.8 mm hinge without a word.
"""

import time

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from origami_jax.system import HingeDesign
from origami_jax.vertex import (
    InvalidVertexError,
    SingleVertex,
    arc_pair_clearances,
    fold_angles,
    open_chain_vertex,
    random_vertex,
    unfold,
    validate_vertex,
)
from origami_jax.vertex._geometry import arcs_cross


def test_fold_angles_beyond_180_degrees_are_refused_not_wrapped():
    sectors = np.radians([40.0, 50.0, 45.0])
    # 179° is a fold: it is kept, with its sign.
    vertex = SingleVertex.from_fold_angles(sectors, np.radians([179.0, -30.0]), closed=False)
    np.testing.assert_allclose(np.degrees(fold_angles(vertex)), [179.0, -30.0], atol=1e-9)
    for folds in ([190.0, -30.0], [30.0, -181.0]):
        with pytest.raises(InvalidVertexError, match=r"\[−180°, 180°\]"):
            SingleVertex.from_fold_angles(sectors, np.radians(folds), closed=False)


def test_a_nan_fold_angle_fails_the_closure_check():
    sectors = np.full(4, np.pi / 2)
    folds = np.zeros(4)
    SingleVertex.from_fold_angles(sectors, folds, closed=True)  # flat: closes
    folds[0] = np.nan
    with pytest.raises(InvalidVertexError, match="finite"):
        SingleVertex.from_fold_angles(sectors, folds, closed=True)


@pytest.mark.parametrize("n", [20])
def test_collinear_flaps_do_not_cross_in_the_compiled_validator(n):
    """A flat disc of n equal sectors folded by 60° along one straight line (creases 0 and n/2):
    every other crease is flat, so each half is one plane and non-adjacent arcs of a half lie on
    one great circle. The closest non-adjacent arcs are one sector apart: clearance 360°/n."""
    sectors = np.full(n, 2 * np.pi / n)
    folds = np.zeros(n)
    folds[0] = folds[n // 2] = np.radians(60.0)
    vertex = SingleVertex.from_fold_angles(sectors, folds, closed=True)  # validates (compiled)
    report = validate_vertex(vertex)
    np.testing.assert_allclose(np.degrees(report.min_clearance), 360.0 / n, rtol=1e-9)
    clearance, crossing = arc_pair_clearances(vertex.directions, True)  # eager
    assert not bool(jnp.any(crossing))
    compiled = jax.jit(arc_pair_clearances, static_argnums=1)(vertex.directions, True)
    np.testing.assert_array_equal(np.asarray(compiled[1]), np.asarray(crossing))
    np.testing.assert_allclose(np.asarray(compiled[0]), np.asarray(clearance), atol=1e-12)


def test_proper_crossings_are_still_found():
    # Two arcs of the equator and a meridian crossing it: a crossing, robustly.
    a1, a2 = jnp.array([1.0, -0.2, 0.0]), jnp.array([1.0, 0.2, 0.0])
    b1, b2 = jnp.array([1.0, 0.0, -0.1]), jnp.array([1.0, 0.0, 0.1])
    unit = lambda v: v / jnp.linalg.norm(v)
    assert bool(arcs_cross(unit(a1), unit(a2), unit(b1), unit(b2)))
    # Touching at an end point (a zero determinant) is not a crossing.
    assert not bool(arcs_cross(unit(a1), unit(a2), unit(jnp.array([1.0, 0.0, 0.0])), unit(b2)))


@pytest.mark.parametrize("p", [float("nan"), -2.0, 0.0, float("inf")])
def test_unfold_refuses_a_bad_energy_exponent(p):
    with pytest.raises(ValueError, match="positive finite"):
        unfold(open_chain_vertex(), p=p)


def test_unfold_refuses_a_bad_step_budget():
    with pytest.raises(ValueError, match="max_steps"):
        unfold(open_chain_vertex(), max_steps=0)


def test_random_vertex_of_many_creases_is_refused_or_fails_fast():
    start = time.perf_counter()
    with pytest.raises(ValueError, match="below min_sector"):
        random_vertex(jax.random.key(0), 50, closed=True)  # 50 sectors of 7.2° < 10°
    with pytest.raises(RuntimeError, match="rejected: .* a sector outside"):
        random_vertex(jax.random.key(0), 30, closed=True, max_tries=50)
    # With smaller sectors allowed, 50 creases build (the loop closure compiles in seconds now);
    # then the flaps cross, and the failure names that.
    with pytest.raises(RuntimeError, match="crossing"):
        random_vertex(jax.random.key(0), 50, closed=True, min_sector=np.radians(3), max_tries=5)
    assert time.perf_counter() - start < 120  # was > 10 min (compiling an unrolled 50-arc loop)


def test_random_vertex_still_draws_valid_vertices():
    vertex = random_vertex(jax.random.key(3), 4, closed=True)  # the size the sweep tests use
    report = validate_vertex(vertex)
    assert report.min_clearance >= np.radians(2.0) and not report.contacts
    folds = np.asarray(fold_angles(vertex))
    assert np.all(np.abs(folds) <= np.pi)


def test_hinge_design_refuses_a_fold_angle_in_degrees():
    with pytest.raises(ValueError, match="at most π"):
        HingeDesign.literature(theta_final=100.0)
    design = HingeDesign.literature(theta_final=np.pi)  # the paper's 180°: fine
    assert float(design.hinge_length()) == pytest.approx(np.pi * float(design.radius()))
    HingeDesign.literature(theta_final=np.float32(np.pi))  # π rounded up to float32 is π too
