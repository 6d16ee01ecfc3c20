"""Agitation: random forcing of a folding device by its bath (Langevin dynamics).

A device in a fluid at temperature ``T`` is kicked by the fluid's molecules; the same fluid resists
its motion. The fluctuation–dissipation theorem ties the two: a linear drag ``f = −D(q) v`` comes
with a random force of covariance ``2 k_B T D(q) δ(t − t')``, so that the device's states settle
into the Boltzmann distribution (each harmonic hinge ``⟨k θ²⟩ = k_B T``, each velocity degree of
freedom ``⟨½ m v²⟩ = ½ k_B T``). With an agitated `FoldingSystem` `simulate` solves

    M(q) dv = (forces) dt + L(q) dW,    L Lᵀ = 2 k_B T D(q),

with ``W`` a Brownian motion, seeded and reproducible (a `diffrax.VirtualBrownianTree`: the same
seed gives the same path whatever steps the solver takes).

``D(q) = −∂f_drag/∂v`` at ``v = 0``: the drag's linear (viscous) part, exact for linear drag and the
linear response of any other. The paper's drag (``−b θ̇|θ̇|``, quadratic) has none and cannot be
agitated: give the system a viscous part (`origami_jax.fluid.ViscousDrag`, or the fluid models of
nets and the extended accordion, which carry one).

`temperature` is the bath's for thermal noise (300 K: ``k_B T`` = 4.1 zJ, far below a microscale
hinge's folding energy, pJ) or an effective temperature standing for mechanical agitation of the
bath (stirring, ultrasound), the regime of Dodd, Damasceno & Glotzer (PNAS 115, E6690, 2018), whose
nets fold under noise comparable to their folding energies.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float, UInt

from .._validate import is_traced
from ._drag import AbstractDrag
from ._mechanism import AbstractMechanism
from ._units import UnitSystem

BOLTZMANN = 1.380649e-23
"""Boltzmann's constant, J/K (exact, SI 2019)."""


class Agitation(eqx.Module):
    """Random forcing at a (possibly effective) temperature, in balance with the drag (module
    docstring).

    **Fields:**
    - `temperature`: ``T``, kelvin (scalar; traced, so a sweep over it compiles once).
    - `key`: the seed's PRNG key data, `uint32[2]` (`Agitation(T, seed=3)`; batch it to run
      independent realisations under `vmap`).
    - `resolution` (static): the Brownian path's time resolution, as a fraction of the simulated
      span (default ``2⁻²⁰``, ~1e-6): keep it below the smallest step the solver takes.

    **Raises:** `ValueError` for a temperature that is not finite and ≥ 0 (when known).
    """

    temperature: Float[Array, ""]
    key: UInt[Array, "2"]
    resolution: float = eqx.field(static=True, default=2.0**-20)

    def __init__(
        self,
        temperature: Float[ArrayLike, ""],
        seed: int | UInt[ArrayLike, "2"] = 0,
        *,
        resolution: float = 2.0**-20,
    ):
        if not is_traced(temperature):
            host = np.asarray(temperature, dtype=float)
            if host.shape != () or not np.isfinite(host) or host < 0:
                raise ValueError(
                    f"the agitation temperature must be a finite number >= 0 (kelvin), got "
                    f"{temperature!r}."
                )
        if isinstance(seed, bool):
            raise ValueError(f"the agitation seed must be an integer, got {seed!r}.")
        if isinstance(seed, int | np.integer):
            key = jax.random.PRNGKey(int(seed))
        else:
            key = jnp.asarray(seed, dtype=jnp.uint32)
            if key.shape[-1:] != (2,):
                raise ValueError(
                    f"the agitation seed must be an integer or a PRNG key (uint32[2]), got shape "
                    f"{key.shape}."
                )
        if not (isinstance(resolution, float) and 0 < resolution < 1):
            raise ValueError(f"resolution must be a float in (0, 1), got {resolution!r}.")
        self.temperature = jnp.asarray(temperature, dtype=float)
        self.key = key
        self.resolution = resolution

    def thermal_energy(self, units: UnitSystem) -> Float[Array, ""]:
        """``k_B T`` in the energy unit of `units` (MICRO: pJ = µN·µm)."""
        return self.temperature * units.from_si(BOLTZMANN, length=2, time=-2, mass=1)

    def noise_matrix(
        self,
        mechanism: AbstractMechanism,
        drag: AbstractDrag,
        units: UnitSystem,
        q: Float[Array, " nq"],
    ) -> Float[Array, "nv nv"]:
        """``L(q)`` with ``L Lᵀ = 2 k_B T D(q)``, ``D = −∂f_drag/∂v`` at ``v = 0`` symmetrised and
        its negative eigenvalues (round-off) clipped; force units per √time."""
        damping = viscous_damping(mechanism, drag, q)
        damping = 0.5 * (damping + damping.T)
        values, vectors = jnp.linalg.eigh(damping)
        scale = jnp.sqrt(2 * self.thermal_energy(units) * jnp.clip(values, 0.0))
        return vectors * scale

    def check_drag(self, mechanism: AbstractMechanism, drag: AbstractDrag, q: Array) -> None:
        """Raise (one line, before compiling) when a known drag has no linear part at ``q`` to
        balance the noise."""
        if is_traced(q, drag, mechanism):
            return
        # Evaluated now even inside a trace (only the agitation's key may be traced there).
        with jax.ensure_compile_time_eval():
            damping = viscous_damping(mechanism, drag, q)
        if not np.any(np.abs(np.asarray(damping)) > 0):
            raise ValueError(
                "agitation needs a drag with a linear (viscous) part to balance the noise, but "
                "this system's drag has none at rest (the paper's quadratic hinge drag): add a "
                "ViscousDrag (origami_jax.fluid) or use a fluid model that has one."
            )

    def diffusion(
        self,
        mechanism: AbstractMechanism,
        drag: AbstractDrag,
        units: UnitSystem,
        q: Float[Array, " nq"],
    ) -> Float[Array, "nv nv"]:
        """How a Brownian increment ``dW`` `(nv,)` changes the velocities: ``dv = M(q)⁻¹ L(q) dW``."""
        return jnp.linalg.solve(
            mechanism.mass_matrix(q), self.noise_matrix(mechanism, drag, units, q)
        )


def viscous_damping(
    mechanism: AbstractMechanism, drag: AbstractDrag, q: Float[Array, " nq"]
) -> Float[Array, "nv nv"]:
    """The drag's linear (viscous) part at ``q``: ``D = −∂f_drag/∂v`` at ``v = 0`` (force·time per
    velocity unit, `(nv, nv)`)."""
    zero = jnp.zeros(mechanism.n_velocities, dtype=q.dtype)
    return -jax.jacfwd(lambda v: drag.force(mechanism, q, v))(zero)
