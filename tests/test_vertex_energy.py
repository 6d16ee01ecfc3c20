"""Charge energies (Eqs. 1–2) against plain NumPy, finite differences and rotation invariance."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from jax.test_util import check_grads

from origami_jax.vertex import (
    energy,
    nonseparable_energy,
    open_chain_vertex,
    separable_energy,
    waterbomb_base,
)

RTOL = 1e-12


def _numpy_energy(x, closed, kind, p):
    n = len(x)
    arcs = [(i, (i + 1) % n) for i in range(n if closed else n - 1)]
    total = 0.0
    for a, b in arcs:
        m = (x[a] + x[b]) / np.linalg.norm(x[a] + x[b])
        for v in range(n):
            if v in (a, b):
                continue
            # the package's geodesic angle is scale-free in the node (atan2 form)
            d = np.arccos(np.clip(np.dot(x[v] / np.linalg.norm(x[v]), m), -1, 1))
            total += d ** (-p) if kind == "separable" else d**p
    return total if kind == "separable" else 1.0 / total


VERTICES = {"waterbomb": waterbomb_base, "open": open_chain_vertex}


@pytest.mark.parametrize("kind,p", [("separable", 2.0), ("separable", 1.5), ("nonseparable", 4.0)])
@pytest.mark.parametrize("name", list(VERTICES))
def test_energy_matches_numpy(name, kind, p):
    vertex = VERTICES[name]()
    x = np.asarray(vertex.directions)
    ours = float(energy(vertex.directions, closed=vertex.closed, kind=kind, p=p))
    assert ours == pytest.approx(_numpy_energy(x, vertex.closed, kind, p), rel=1e-10)


@pytest.mark.parametrize("fn", [separable_energy, nonseparable_energy])
def test_gradient_finite_differences(fn):
    vertex = waterbomb_base()
    f = lambda x: fn(x, closed=True)
    check_grads(f, (vertex.directions,), order=1, modes=["fwd", "rev"], atol=1e-6, rtol=1e-6)
    # and against a central difference of the NumPy energy in one random direction
    rng = np.random.default_rng(0)
    direction = rng.normal(size=vertex.directions.shape)
    x = np.asarray(vertex.directions)
    kind = "separable" if fn is separable_energy else "nonseparable"
    p = 2.0 if kind == "separable" else 4.0
    h = 1e-6
    fd = (
        _numpy_energy(x + h * direction, True, kind, p)
        - _numpy_energy(x - h * direction, True, kind, p)
    ) / (2 * h)
    g = np.asarray(jax.grad(f)(vertex.directions))
    assert np.sum(g * direction) == pytest.approx(fd, rel=1e-6)


def test_gradient_in_p():
    vertex = open_chain_vertex()
    f = lambda p: separable_energy(vertex.directions, closed=False, p=p)
    check_grads(f, (jnp.asarray(2.0),), order=1, modes=["fwd", "rev"])


def test_rotation_invariance(getkey):
    vertex = waterbomb_base()
    q, _ = jnp.linalg.qr(jax.random.normal(getkey(), (3, 3)))
    rotated = vertex.directions @ q.T
    for kind in ("separable", "nonseparable"):
        a = energy(vertex.directions, closed=True, kind=kind)
        b = energy(rotated, closed=True, kind=kind)
        assert float(b) == pytest.approx(float(a), rel=RTOL)
        ga = jax.grad(lambda x, k=kind: energy(x, closed=True, kind=k))(vertex.directions)
        gb = jax.grad(lambda x, k=kind: energy(x, closed=True, kind=k))(rotated)
        np.testing.assert_allclose(np.asarray(gb), np.asarray(ga @ q.T), atol=1e-10)


def test_unknown_energy():
    with pytest.raises(ValueError, match="separable"):
        energy(waterbomb_base().directions, closed=True, kind="coulomb")
