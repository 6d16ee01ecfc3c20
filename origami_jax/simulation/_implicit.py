"""`ImplicitStep`: a fixed-step engine for contact-rich folding, selected by `SolveOptions(solver=...)`.

Each step of length ``h`` from ``(q_n, v_n)`` finds ``q_{n+1}`` as the root of the incremental
problem of implicit (backward) Euler, as Incremental Potential Contact does (Li et al., SIGGRAPH
2020),

    r(q) = M(q_n) (q − q_n − h v_n) + h² (C(q_n, v_n) v_n + G(q_n) − F(q, (q − q_n)/h, τ_{n+1})) = 0,

with ``F`` the system's generalized force (hinge springs and input torque, drag, contact:
`FoldingSystem.generalized_force`) taken at the end of the step, and sets
``v_{n+1} = (q_{n+1} − q_n)/h``. Inertia and the velocity terms are taken at the start of the step;
every force is implicit, so stiff hinges, drag and the contact barrier cost no step size. The
scheme is first-order accurate and dissipative (backward Euler damps oscillations of period ``T`` by
about ``2π² (h/T)²`` of their energy per period, more as ``h/T`` grows).

**BDF2** (`ImplicitStep(scheme="bdf2")`). The second-order backward differentiation formula has the
same residual with ``(h, q_n, v_n)`` replaced by ``(β, q̂, v̂)``: with equal steps ``q̂ = (4 q_n −
q_{n−1})/3``, ``v̂ = (4 v_n − v_{n−1})/3``, ``β = 2h/3`` (the variable-step formula where the
step changes between sample intervals: `_bdf2_start`), the inertia and velocity terms taken at the
state extrapolated linearly to the step's end, and ``v_{n+1} = (q_{n+1} − q̂)/β``. Its first step
(and a step more than 2.4 times its predecessor, where variable-step BDF2 loses stability) is an
Euler step. Second-order accurate and far less dissipative: an oscillation loses about
``(ωh)³/2`` of its energy per radian of phase instead of Euler's ``ωh``, so ringing keeps its
energy as in the adaptive solve (an impact does not: below). Like Euler it is A-stable and L-stable (stiff
hinges, drag and the barrier cost no step size); unlike it, it is not monotone, so a step can
overshoot slightly where Euler would stop short, and the energy can rise for a step or two after
an impact (it is G-stable, a norm of two consecutive states falls, not the energy of one).

**Impacts are inelastic in fixed steps.** A step long against an impact cannot follow the panel
into the barrier and back: the L-stable schemes (both) damp that fast motion out. Two flaps
launched at each other (0.5 µs steps, no drag, 8.3 energy units of kinetic energy): the resolved
adaptive solve loses 0.52 at the impact (the contact's damping) and the flaps rebound; Euler
loses 9.0 (all their motion: they stop dead); BDF2 loses 8.3 within the impact and gets 2.6 back
over the next steps (5.7 net). Restarting BDF2 with an Euler step after each contact event was
tried: it returns nothing, but makes the impact as inelastic as Euler's, and its verdicts on 200
scattered cube nets agreed less with the adaptive engine's (194 against 197). The
same substitution (a predicted state and a scaled step) is how PolyFEM's IPC time integrators
(`ImplicitEuler`, `BDF`, `ImplicitNewmark`) share one incremental potential. Agitation takes the
Euler scheme only (its fluctuation–dissipation balance is Euler's).

**Newton.** At most `ImplicitStep.newton_iterations` Newton iterations from the predictor ``q_n + h
v_n + h² a_n`` (BDF2: ``q̂ + β v̂``), ``a_n`` the last step's change of velocity over its length
where no contact acts for sure (free flight: the step's root is then nearer by a factor of ``h``
and takes one Newton update fewer; at a contact, where the velocity jumps, ``a_n = 0``), stopping
once the next update would move no coordinate more than 1e-10 rad (not taken), or once the error
that update would leave, estimated from the rate of contraction ``θ`` of the last two updates, is
within it (taken, capped like any update, as Hairer and Wanner stop the Newton iterations of
implicit Runge–Kutta methods: ``θ/(1 − θ)`` of the update where the Gauss–Newton matrix converges
linearly at a contact, ``θ²/(1 − θ)`` where the matrix is the exact Jacobian and convergence
quadratic; one matrix fewer per step, the root the same to the test), or once the last one moved
none that far. Their matrix
(`ImplicitStep.jacobian`) is by default the Gauss–Newton one: the plate contact's barrier and
damping by their pairs' gap gradients (`PlateContact.force_jacobians`, as IPC's Newton iterations
use its barrier's Hessian), the rest of ``r`` (inertia, hinges, drag, inputs: a few coordinates) by
forward-mode differentiation; or the exact Jacobian of all of ``r`` (`_jacobian`). With the
Gauss–Newton matrix, a step whose predictor's first update is shorter than 1e-3 rad in every
member of a batch holds that rest from the predictor through its iterations (simplified Newton,
as implicit Runge–Kutta codes reuse their Jacobian: the drag's forward derivative is the larger
part of a linearisation; the root is the same, the contraction then linear); a step with a longer
first update (a hinge released from rest, an impact) differentiates it at every iterate, since
the drag's derivative, in proportion to each point's speed, changes there by its own size. Each
update is capped, as in IPC, by the contact's continuous collision detection: the largest step
moves no coordinate more than `ImplicitStep.max_update` and is ``0.9`` of the fraction of the path
that stays clear, checked chord after chord, each moving no coordinate more than ``max_update /
ccd_pieces`` (`PlateContact.time_of_impact`; models without it, such
as the sampled `PanelContact`, are capped in size only), then up to `ImplicitStep.halvings`
halvings look for a decrease of ``|r|²`` (the first with Armijo's decrease, else the best, else no
move). Every member of a `vmap`ped batch takes the same steps, and its iterations are bounded by
the same counts: a member that converged waits at most those few iterations for the others, never
for more steps (`early_exit=False` fixes every count: the same work always, at a measured 2–3× the
cost on a cube net). The price of bounded work is that a step whose Newton iterations did not
converge is not refused: `Trajectory.stats["newton_error"]` reports the largest remaining Newton
update of any step, or the error estimated left where the last update was taken on that estimate
(rad; small against the motion when the steps converged).

**Working set.** Each step evaluates the plate contact's pairs of least gap at its start
(`ImplicitStep.active_pairs`, `PlateContact.select_pairs`), not every pair of the pattern: a pair
beyond the activation gap has no force, so the step is the same while no pair left out comes
within it (counted in `Trajectory.stats["contacts_left_out"]`); the collision check bounds the
left-out pairs from their least gap, so none passes through a plate either way. The working set
is carried from step to step while the vertices stay well within its least gap's margin
(`PlateContact.next_working_set`), and where that least gap shows every pair beyond the
activation gap, or clear of an update's whole path, the contact's force and collision check are
exactly zero and clear without evaluating a pair: a fold's free flight costs what it costs without
contact, with the same steps.

**Agitation.** An agitated system (`FoldingSystem(agitation=...)`, Langevin forcing in balance with
the drag's viscous part) receives a random impulse ``L(q_n) √h ξ_n`` in each step, ``ξ_n`` standard
normal drawn from the agitation's key folded with the step's number (the same draws for the same
seed and step, whatever the batch; the states reproduce bitwise where the member is computed alone
or in the same chunk: in a `vmap`ped chunk its Newton iterations run until the slowest member's
have converged, which moves its last bits, and the noise amplifies them like any chaotic
folding), ``L Lᵀ = 2 k_B T D(q_n)`` (`Agitation.noise_matrix`): implicit
Euler for the drift with an Euler–Maruyama increment, ``M (v_{n+1} − v_n) = h F + L √h ξ_n``. Its
stationary distribution is Boltzmann's to first order in ``h``: a harmonic hinge's ``⟨k θ²⟩``
comes out ``k_B T (1 + O(ω₀ h))`` (implicit Euler's numerical damping takes energy from the noise;
the test's closed form of the discrete scheme gives the factor), so keep ``ω₀ h`` small where the
distribution matters. The impulse's dependence on ``q_n`` (through ``D``) is held fixed under
differentiation (its square root's derivative is undefined where ``D``'s eigenvalues coincide);
the temperature's is exact.

**Closed loops.** A crease pattern's loops (`LoopedPanels`: the cut creases carry no inertia; the
adaptive solvers hold the closure ``c(q) = 0`` inside `forward_dynamics`) enter the residual as a
stiff penalty, ``r += w Jᵀ W c(q)`` (`LoopedPanels.whitened_closure_force`: each vertex's rows
whitened, ``W_v = (J_v J_vᵀ + δ)⁻¹``, as the constrained dynamics do), ``w`` = `_LOOP_HOLD` times
the mean diagonal of the step's contact-free Newton matrix at its start, and the cut creases get
`LoopedPanels`' regularising inertia (`LoopedPanels.regularised_mass_matrix`). The loops then
open by ~1/`_LOOP_HOLD` of a step's motion (as ``h²``). The flat state is a bifurcation the steps cannot resolve under a sudden release
(`check_off_bifurcation`; a pattern's fold starts pre-folded: `start_bias`).

**Gradients.** The derivative of each step is that of its root by the implicit function theorem,
``∂q_{n+1} = −J⁻¹ ∂r`` with the exact ``J = ∂r/∂q`` at the root (`_root`, a custom JVP: computed
only when differentiating), not the derivative of the iterations, which run on values without
derivatives. Reverse mode recomputes the residual's linearisation per step (`jax.checkpoint`)
rather than storing the contact's intermediates. Exact for the discrete map where the Newton
iterations converged, and away from the onset of contact, where the barrier switches on and the
map is only once differentiable.
"""

import dataclasses
import math

import equinox as eqx
import equinox.internal as eqxi
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..system import FoldingSystem
from ._inputs import AbstractInput
from ._results import RESULTS

# IPC's fraction of the time of impact a line search may take.
_TOI_FRACTION = 0.9
# `early_exit`: Newton iterations stop once an update moves no coordinate more than this, or the
# error the next one leaves (`_error_after`) is within it, rad.
_CONVERGED = 1e-10
# `early_exit` with the Gauss–Newton matrix: where every first update of a step is shorter than
# this (rad), the matrix's contact-free part is held from the predictor for the step's iterations.
_HOLD_BELOW = 1e-3
# Armijo's sufficient decrease of |r|² along the Newton direction (slope −2|r|²).
_ARMIJO = 1e-4
_JACOBIANS = ("gauss-newton", "exact")
_SCHEMES = ("euler", "bdf2")
# BDF2 with variable steps is zero-stable for step ratios below 1 + √2; a larger jump of the step
# (a long interval after a short one) restarts it with one Euler step.
_BDF2_LARGEST_RATIO = 2.4
# `ImplicitStep.active_pairs`' default per plate (a convex panel's body): a closed cube net (6
# bodies, the base one of them) has 24 vertex–face and 41 edge–edge pairs within twice the
# activation gap, against 36 and 60 kept.
_PAIRS_PER_BODY = 16
# A crease pattern's loops: the closure penalty's weight over the step's other terms (`_loop_hold`).
# The loops then stay closed to ~1/_LOOP_HOLD of a step's motion; far larger and the Newton matrix
# (float64) loses the other terms' digits.
_LOOP_HOLD = 1e4
# A closed-loop start within this of flat (rad) at rest is at its bifurcation
# (`check_off_bifurcation`).
_FLAT = 1e-6


class ImplicitStep(eqx.Module):
    """Fixed-step implicit Euler with Newton iterations and a contact-capped line search (module
    docstring: the scheme). Pass it as `SolveOptions(solver=ImplicitStep(dt=1.0))`.

    **Fields** (all static: they fix the compiled program):
    - `dt`: the largest step, time units (MICRO: µs). The steps divide every interval between
      sample times into equal parts no longer than `dt`.
    - `newton_iterations`: Newton iterations per step (default 10; 6 until 2026-12-06: with 6,
      steps of a closing octahedron net ended with their residual only ~40× down and Newton
      updates of up to 3.6 rad left, and a cube net's largest was 8e-4 rad; with 10, 9e-3 and
      5e-6 rad, at the same cost for one fold, since the extra iterations run only where a step
      needs them).
    - `halvings`: trial step lengths per Newton iteration, each half the last (default 10, down
      to 2⁻⁹ of the longest). A Newton direction taken where a contact pair is just beyond the
      activation gap does not see the barrier it runs into: on the octahedron nets such steps
      needed 2⁻⁷ to decrease ``|r|²``, and with 5 trials (the default until 2026-12-05) they did
      not move, leaving 2–5 rad of Newton update; with 10, 3e-2. With `early_exit` the trials stop
      at the first acceptable one, so the later ones cost only where they are needed.
    - `max_update`: the largest change of any coordinate in one Newton update, rad (default 0.1).
    - `ccd_pieces`: chords of the longest Newton update's path checked for collisions (default
      4); a shorter update takes as few chords as keep each no longer in any coordinate than
      ``max_update / ccd_pieces`` (one for most: a converging step's updates are small), checked
      one after another until one is hit (without `early_exit`: every `ccd_pieces` chords).
    - `early_exit`: stop the Newton iterations once the next update would move no coordinate
      more than 1e-10 rad (that update is not taken: the state is converged), or would leave an
      error within that by the rate of convergence of the last two (taken without a trial: module
      docstring, **Newton**), or the last one moved none that far, and each line search at its
      first acceptable trial (default `True`; `False`
      runs every count in full, the same work for every step and member). Under `vmap` the
      batch iterates until its slowest member has converged, at most the counts above; a
      vmapped batch of 16 cube nets ran 2.6× faster than with the full counts, on the same roots
      to 1e-9 rad. Gradients are unchanged (they do not pass through the iterations).
    - `active_pairs`: how many of the plate contact's primitive pairs each step evaluates, those
      of least gap at the step's start (`PlateContact.select_pairs`; split between vertex–face
      and edge–edge pairs in proportion to their numbers). Default `None`: 16 per plate (per
      body, the base included, where every panel is convex; a non-convex panel's convex pieces
      count one each): 96 of a cube net's 253, of which a closed cube engages 65. The forces are every pair's
      as long as no pair left out comes within the activation gap during the step, which
      `Trajectory.stats["contacts_left_out"]` counts (steps where one did: raise it); the
      collision check covers every pair either way. At least the number of pairs: all of them,
      every step.
    - `jacobian`: the Newton iterations' matrix. `"gauss-newton"` (default): the contact's
      barrier and damping by their Gauss–Newton part (`PlateContact.force_jacobians`: each pair's
      gap gradient held fixed, as IPC does), everything else by forward-mode differentiation;
      contacts without it (the sampled `PanelContact`) or with adhesion or friction (whose own
      derivatives it leaves out) get the exact one. `"exact"`: forward-mode differentiation of the
      whole residual (several times the cost per iteration, quadratic convergence through contact).
      The root, and so a converged step, is the same; gradients always use the exact Jacobian.

    The collision check follows every vertex on a straight line between two states, while a
    hinge moves a vertex on an arc: a rotation ``φ`` at reach ``R`` departs from its chord by
    ``R φ² / 8``. `max_update` and `ccd_pieces` keep that (``R (max_update/ccd_pieces)² / 8``, 0.03
    µm at 400 µm) below the check's margin (`PlateContact`: half the film's thickness, 0.1 µm for
    a 0.2 µm film); raise `ccd_pieces` for larger nets or thinner films.

    - `scheme`: `"euler"` (default: implicit Euler, first order, dissipative) or `"bdf2"` (the
      second-order backward differentiation formula: module docstring, **BDF2**).

    With `"euler"`, first-order accurate (the error halves with `dt`) and dissipative; with
    `"bdf2"` second order (the error quarters). Use the adaptive default of `simulate` for
    accurate trajectories and this engine for robust contact and for batches. Steps
    long against an impact need more `newton_iterations` (an unconverged step may gain energy);
    contact models without `time_of_impact` (the sampled `PanelContact`) get no collision cap, and
    long steps let their panels tunnel through each other.
    """

    dt: float = eqx.field(static=True)
    newton_iterations: int = eqx.field(static=True, default=10)
    halvings: int = eqx.field(static=True, default=10)
    max_update: float = eqx.field(static=True, default=0.1)
    ccd_pieces: int = eqx.field(static=True, default=4)
    early_exit: bool = eqx.field(static=True, default=True)
    jacobian: str = eqx.field(static=True, default="gauss-newton")
    active_pairs: int | None = eqx.field(static=True, default=None)
    scheme: str = eqx.field(static=True, default="euler")

    def __check_init__(self):
        if self.scheme not in _SCHEMES:
            raise ValueError(
                f"ImplicitStep.scheme must be one of {', '.join(map(repr, _SCHEMES))}, got "
                f"{self.scheme!r}."
            )
        if self.jacobian not in _JACOBIANS:
            raise ValueError(
                f"ImplicitStep.jacobian must be one of {', '.join(map(repr, _JACOBIANS))}, got "
                f"{self.jacobian!r}."
            )
        if not (isinstance(self.dt, int | float) and math.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"ImplicitStep.dt must be a positive finite step, got {self.dt!r}.")
        if not (isinstance(self.max_update, int | float) and self.max_update > 0):
            raise ValueError(f"ImplicitStep.max_update must be positive, got {self.max_update!r}.")
        if self.active_pairs is not None and (
            isinstance(self.active_pairs, bool)
            or not isinstance(self.active_pairs, int)
            or self.active_pairs < 1
        ):
            raise ValueError(
                "ImplicitStep.active_pairs must be a positive integer or None (16 per plate), got "
                f"{self.active_pairs!r}."
            )
        for name in ("newton_iterations", "halvings", "ccd_pieces"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"ImplicitStep.{name} must be a positive integer, got {value!r}.")


FIXED_STEP_PRE_FOLD = 1e-3
"""The pre-fold (rad) a closed-loop pattern's fold by `ImplicitStep` starts from when none is given
(`start_bias`): a fixed step cannot choose a branch at the flat bifurcation (module docstring)."""


def start_bias(pattern, solver, bias: float) -> float:
    """The pre-fold (rad) a pattern's fold starts from (`CreasePattern.start_state`): `bias`, but
    `FIXED_STEP_PRE_FOLD` for a closed-loop pattern folded by `ImplicitStep` from flat (bias 0),
    whose fixed steps cannot pick the branch at the flat state. Nets and the adaptive solvers
    start where asked."""
    if bias == 0 and isinstance(solver, ImplicitStep) and getattr(pattern, "n_loops", 0) > 0:
        return FIXED_STEP_PRE_FOLD
    return bias


def check_off_bifurcation(system: FoldingSystem, inputs: AbstractInput, t0, q0, v0) -> None:
    """Refuse a closed-loop pattern released at once from the flat state at rest: its fixed steps
    cannot choose the branch there (a massless cut crease is held only at second order, so the
    first step overshoots off every branch). A release whose torque starts from zero (a ramp)
    leaves flat slowly enough to follow its branch; a pre-fold (`start_bias`) starts on it. For
    concrete arguments only (`simulate` skips it under a trace)."""
    mechanism = system.mechanism
    if not hasattr(mechanism, "closure"):
        return
    flat = float(np.max(np.abs(np.asarray(q0)), initial=0.0)) < _FLAT
    still = float(np.max(np.abs(np.asarray(v0)), initial=0.0)) == 0.0
    if not (flat and still):
        return
    angles, rates = mechanism.hinge_angles(q0), mechanism.hinge_rates(q0, v0)
    if float(jnp.max(jnp.abs(inputs.torque(t0, angles, rates, system)))) > 0.0:
        raise ValueError(
            "ImplicitStep cannot choose a closed-loop pattern's folding branch when it is released "
            "at once from the flat state (a bifurcation its fixed steps step over): start from a "
            f"small pre-fold (pattern.start_state(system, bias={FIXED_STEP_PRE_FOLD:g}); "
            "--bias), release it over a ramp (Step(ramp=...); --release-ramp US), or use an "
            "adaptive solver (--solver tsit5)."
        )


def steps_per_interval(solver: ImplicitStep, t0, ts) -> int:
    """How many equal steps `solver` takes between consecutive sample times (static): the longest
    interval of ``(t0, ts…)`` over `solver.dt`, rounded up."""
    times = np.concatenate([[float(t0)], np.asarray(ts, dtype=float)])
    longest = float(np.max(np.diff(times))) if times.size > 1 else 0.0
    return max(1, math.ceil(longest / solver.dt * (1 - 1e-12)))


def _without_derivatives(tree):
    return jax.tree.map(lambda x: jax.lax.stop_gradient(x) if eqx.is_array(x) else x, tree)


def _residual(
    system: FoldingSystem, inputs: AbstractInput, t_next, h, q_n, v_n, mass, bias, hold, q
):
    """``r(q)`` of the module docstring (force·time² units), shape `(n,)`; with closed loops
    (`hold` not `None`, `_loop_hold`) plus the penalty ``hold · Jᵀ W c(q)`` that holds them
    closed."""
    mechanism = system.mechanism
    v = (q - q_n) / h
    tau = inputs.torque(t_next, mechanism.hinge_angles(q), mechanism.hinge_rates(q, v), system)
    r = mass @ (q - q_n - h * v_n) + h * h * (bias - system.generalized_force(q, v, tau))
    if hold is not None:
        r = r + hold * mechanism.whitened_closure_force(q)
    return r


def _start_terms(system: FoldingSystem, inputs: AbstractInput, t_next, h, q_n, v_n, noise, history):
    """What a step's residual holds fixed from its start: ``(h, q_n, v_n, M, C v + G − impulse/h,
    hold)`` (`_residual`). Under BDF2 (`history` not `None`, `_bdf2_start`) the first three are the
    scheme's ``(β, q̂, v̂)``, and the inertia and velocity terms are taken at the state extrapolated
    to the step's end."""
    mechanism = system.mechanism
    q_at, v_at = q_n, v_n
    if history is not None:
        h, q_n, v_n, q_at, v_at = _bdf2_start(h, q_n, v_n, history)
    loops = hasattr(mechanism, "closure")
    # A crease pattern's cut creases carry no inertia of their own: regularised as the
    # constrained dynamics do (`LoopedPanels.regularised_mass_matrix`).
    if loops:
        mass = mechanism.regularised_mass_matrix(q_at)
        bias = mechanism.bias_force(q_at, v_at)
    elif hasattr(mechanism, "mass_matrix_and_bias"):  # one evaluation of the kinematics for both
        mass, bias = mechanism.mass_matrix_and_bias(q_at, v_at)
    else:
        mass, bias = mechanism.mass_matrix(q_at), mechanism.bias_force(q_at, v_at)
    if noise is not None:
        bias = bias - _impulse(system, h, q_n, noise) / h
    hold = _loop_hold(system, inputs, t_next, h, q_n, v_n, mass, bias) if loops else None
    return h, q_n, v_n, mass, bias, hold


def _bdf2_start(h, q_n, v_n, history):
    """BDF2's step from ``(q_n, v_n)`` with the previous state ``(q_{n−1}, v_{n−1})`` a step of
    ``h / ω`` back (`history` = ``(q_{n−1}, v_{n−1}, ω)``; ``ω = 0``: none, an Euler step):
    ``(β, q̂, v̂, q_e, v_e)`` such that the step is implicit Euler's residual with ``(h, q_n, v_n)``
    replaced by ``(β, q̂, v̂)``, ``q_{n+1} = q̂ + β v_{n+1}`` and ``v_{n+1} = v̂ + β a_{n+1}``
    (variable-step BDF2: ``q̂ = ((1+ω)² q_n − ω² q_{n−1})/(1+2ω)``, ``β = h (1+ω)/(1+2ω)``), and
    ``(q_e, v_e)`` the state linearly extrapolated to the step's end, where the scheme's inertia
    and velocity terms belong (second order)."""
    q_prev, v_prev, ratio = history
    ahead = (1 + ratio) ** 2 / (1 + 2 * ratio)
    behind = ratio**2 / (1 + 2 * ratio)
    q_hat = ahead * q_n - behind * q_prev
    v_hat = ahead * v_n - behind * v_prev
    beta = h * (1 + ratio) / (1 + 2 * ratio)
    return beta, q_hat, v_hat, q_n + ratio * (q_n - q_prev), v_n + ratio * (v_n - v_prev)


def _without_contact(system: FoldingSystem) -> FoldingSystem:
    return eqx.tree_at(lambda s: s.contact, system, None, is_leaf=lambda x: x is None)


def _loop_hold(system, inputs, t_next, h, q_n, v_n, mass, bias):
    """A crease pattern's closure penalty weight ``hold``: `_LOOP_HOLD` times the mean diagonal of
    the tree creases' Newton matrix without contact at the step's start (inertia, hinge springs
    and drag over the step: the penalty outweighs whatever the step's other terms are), held fixed
    under differentiation."""
    bare = _without_contact(system)
    matrix = jax.jacfwd(
        lambda q: _residual(bare, inputs, t_next, h, q_n, v_n, mass, bias, None, q)
    )(jax.lax.stop_gradient(q_n))
    weight = jnp.mean(jnp.abs(jnp.diagonal(matrix))[: system.mechanism.n_tree])
    return jax.lax.stop_gradient(_LOOP_HOLD * weight)


def _residual_from_start(system, inputs, t_next, h, q_n, v_n, noise, history, q):
    h, q_n, v_n, mass, bias, hold = _start_terms(
        system, inputs, t_next, h, q_n, v_n, noise, history
    )
    return _residual(system, inputs, t_next, h, q_n, v_n, mass, bias, hold, q)


def _impulse(system: FoldingSystem, h, q_n, noise):
    """The agitation's random impulse over a step, ``L(q_n) √h ξ`` (force·time, `(n,)`; module
    docstring), zero without agitation. ``L``'s dependence on ``q_n`` is not differentiated: the
    unit-temperature square root is held fixed and scaled by ``√T``."""
    agitation = system.agitation
    if agitation is None:
        return jnp.zeros_like(q_n)
    unit = eqx.tree_at(lambda a: a.temperature, agitation, jnp.ones_like(agitation.temperature))
    root = jax.lax.stop_gradient(
        unit.noise_matrix(system.mechanism, system.drag, system.units, q_n)
    )
    temperature = agitation.temperature
    hot = temperature > 0
    # √T's derivative is infinite at 0 K: kept finite there (a cold system's noise is zero).
    scale = jnp.where(hot, jnp.sqrt(jnp.where(hot, temperature, 1.0)), 0.0)
    return scale * (root @ noise) * jnp.sqrt(h)


def step_noise(system: FoldingSystem, index, size: int):
    """The standard normal draws ``ξ_n`` `(size,)` of step `index` (the agitation's key folded with
    it), or `None` without agitation."""
    agitation = system.agitation
    if agitation is None:
        return None
    key = jax.random.fold_in(jax.lax.stop_gradient(agitation.key), index)
    return jax.random.normal(key, (size,))


def _jacobian(residual, q):
    """``(∂r/∂q, r(q))``: one linearisation of `residual` at `q`, applied to the unit vectors one
    after another (`jax.lax.map`). The same columns as `jax.jacfwd`, which pushes the unit vectors
    through together: on a CPU that batched pass through the contact force's own linearisation and
    transpose costs 3–4× the sequential one (cube net, 253 primitive pairs: 9.5 against 2.9 ms)."""
    r, tangent = jax.linearize(residual, q)
    columns = jax.lax.map(tangent, jnp.eye(q.shape[0], dtype=q.dtype))
    return columns.T, r


def _all_trials(merit, q, dq, longest, m0, halvings: int):
    """The line search of `_step` with its `halvings` trials ``α_j = longest / 2^j`` evaluated
    together (one vectorised merit over the trials rather than one after another: on a CPU a
    residual of a few hundred contact pairs costs its operations' dispatch more than its
    arithmetic, so `halvings` trials in one pass cost little more than one). The choice is the
    sequential one's: the first ``α_j`` with Armijo's decrease, else the one of least merit below
    ``m0`` (the earliest of equals), else 0."""
    alphas = longest * 0.5 ** jnp.arange(halvings, dtype=q.dtype)
    merits = jax.vmap(lambda a: merit(q + a * dq))(alphas)
    armijo = merits <= (1 - 2 * _ARMIJO * alphas) * m0
    least = jnp.argmin(merits)
    best = jnp.where(merits[least] < m0, alphas[least], 0.0)
    return jnp.where(jnp.any(armijo), alphas[jnp.argmax(armijo)], best)


def _pair_counts(contact, solver: ImplicitStep) -> tuple[int, int] | None:
    """The working set of `solver.active_pairs` for `contact`: ``(vertex–face, edge–edge)`` pair
    counts in proportion to the tables', or `None` where every pair is evaluated (a contact without
    a working set, or a budget at least the number of pairs)."""
    if contact is None or not hasattr(contact, "select_pairs"):
        return None
    tables = contact.tables
    n_vf, n_ee = len(tables.vertex_face), len(tables.edge_edge)
    total = n_vf + n_ee
    budget = solver.active_pairs
    if budget is None:
        budget = _PAIRS_PER_BODY * tables.vertices.shape[0]
    if budget >= total:
        return None
    k_vf = min(n_vf, max(1, round(budget * n_vf / total)))
    return k_vf, min(n_ee, budget - k_vf)


def _gauss_newton_applies(system: FoldingSystem, solver: ImplicitStep) -> bool:
    """Whether `solver`'s Newton matrix takes the contact's Gauss–Newton part (`ImplicitStep`,
    field `jacobian`)."""
    contact = system.contact
    return (
        solver.jacobian == "gauss-newton"
        and contact is not None
        and hasattr(contact, "force_jacobians")
        and getattr(contact, "adhesion", None) is None
        and getattr(contact, "friction", None) is None
    )


def _newton_matrix(system, inputs, solver, t_next, h, q_n, v_n, mass, bias, hold):
    """``(q, held) ↦ (J, r(q), exact, J₀)``, and the residual: the Newton iterations' matrix
    (`ImplicitStep.jacobian`), whether it is the exact Jacobian of ``r`` at `q`, and its part
    without the contact ``J₀``. With the Gauss–Newton contact, everything but the contact is
    differentiated (`jax.jacfwd`: inertia, hinges, drag and inputs), or that part's `held` matrix
    from an earlier iterate is taken instead, and the contact gives its own force and
    derivatives; otherwise everything is differentiated, and ``J₀`` is `None` (nothing to
    hold)."""

    def residual(q):
        return _residual(system, inputs, t_next, h, q_n, v_n, mass, bias, hold, q)

    if not _gauss_newton_applies(system, solver):

        def exact_matrix(q, held=None):
            jac, r = _jacobian(residual, q)
            return jac, r, jnp.ones((), bool), None

        return exact_matrix, residual
    bare = _without_contact(system)

    def bare_residual(q):
        r = _residual(bare, inputs, t_next, h, q_n, v_n, mass, bias, hold, q)
        return r, r

    def matrix(q, held=None):
        if held is None:
            jac, r = jax.jacfwd(bare_residual, has_aux=True)(q)
        else:  # the contact-free part's Jacobian from an earlier iterate (`_step`)
            jac, r = held, bare_residual(q)[0]
        force, d_dq, d_dv = system.contact.force_jacobians(system.mechanism, q, (q - q_n) / h)
        # Exact where the contact does not act (its force and derivatives zero: every pair beyond
        # the activation gap, where the barrier vanishes with its derivatives) and nothing is held.
        exact = ~(jnp.any(force != 0) | jnp.any(d_dq != 0) | jnp.any(d_dv != 0)) & (held is None)
        return jac - h * h * d_dq - h * d_dv, r - h * h * force, exact, jac

    return matrix, residual


@eqx.filter_custom_jvp
def _root(q, system, inputs, t_next, h, q_n, v_n, noise, history):
    """`q`, the converged root of the step's residual, whose derivative is that of the root by the
    implicit function theorem, ``−J⁻¹ ∂r`` (exact ``J`` at the root; `_root_jvp`): the derivative
    of the discrete map whatever the Newton iterations did."""
    return q


@_root.def_jvp
def _root_jvp(primals, tangents):
    q, *args = primals
    _, *arg_tangents = tangents

    def residual(args):
        return _residual_from_start(*args, q)

    # Recomputed, not stored, by reverse mode (the contact's intermediates, per step).
    _, dr = eqx.filter_jvp(eqx.filter_checkpoint(residual), (args,), (arg_tangents,))
    jac, _ = _jacobian(lambda q: _residual_from_start(*args, q), q)
    return q, -jnp.linalg.solve(jac, dr)


def _step(
    system: FoldingSystem,
    inputs: AbstractInput,
    solver: ImplicitStep,
    t_next,
    h,
    q_n,
    v_n,
    noise,
    history=None,
    selection=None,
    acceleration=None,
):
    """One step from ``(q_n, v_n)`` to ``t_next = t_n + h``: ``(q, v, newton_error,
    left_out, selection)``, `left_out` whether a contact pair outside the step's working set came
    within the activation gap (`ImplicitStep.active_pairs`), `selection` the next step's working
    set (a `PairSelection`, chosen where this step ends: `PlateContact.next_working_set`; `None`
    without one). `noise`: the step's standard normal draws of an agitated system
    (`step_noise`), else `None`. `history`: BDF2's previous state and step ratio (`_bdf2_start`),
    `None` for implicit Euler. `selection`: this step's working set, as the previous step
    returned it (`None`: chosen at ``q_n``).
    `acceleration`: implicit Euler's predictor's acceleration (the last step's change of
    velocity over its length), used in free flight only (`_in_free_flight`); `None`: none."""
    contact = system.contact
    capped = hasattr(contact, "time_of_impact")
    # The iterations run without derivatives; `_root` carries them (IFT).
    s_system, s_inputs, s_h, s_q, s_v, s_history = _without_derivatives(
        (system, inputs, h, q_n, v_n, history)
    )
    counts = _pair_counts(contact, solver)
    if counts is not None:
        if selection is None:
            working = s_system.contact.select_pairs(s_system.mechanism, s_q, counts)
        else:
            working = dataclasses.replace(
                s_system.contact, selection=jax.lax.stop_gradient(selection)
            )
        s_system = eqx.tree_at(lambda s: s.contact, s_system, working)
    # The scheme's (h, q_n, v_n): implicit Euler's, or BDF2's (β, q̂, v̂) (`_bdf2_start`).
    s_beta, s_q_hat, s_v_hat, mass, bias, hold = _start_terms(
        s_system, s_inputs, t_next, s_h, s_q, s_v, noise, s_history
    )
    newton_matrix, residual = _newton_matrix(
        s_system, s_inputs, solver, t_next, s_beta, s_q_hat, s_v_hat, mass, bias, hold
    )

    def largest_step(q, dq):
        """The line search's longest trial: no coordinate moving more than `max_update`, and 0.9 of
        the time of impact where a pair would meet, checked on chords of the path, each moving no
        coordinate more than ``max_update / ccd_pieces`` (at most `ccd_pieces` of them; one for
        the short updates of a converging step), one after another until one is hit."""
        longest = jnp.max(jnp.abs(dq))
        alpha = jnp.where(longest > solver.max_update, solver.max_update / longest, 1.0)
        if not capped:
            return alpha
        pieces = solver.ccd_pieces

        def impact(a, b):
            return s_system.contact.time_of_impact(s_system.mechanism, a, b)  # type: ignore[union-attr]

        if solver.early_exit:
            # Chords no longer (in any coordinate) than the longest update's `ccd_pieces` chords:
            # the same bound on how far a rotating vertex departs from its chord.
            reach = alpha * longest / (solver.max_update / pieces)
            count = jnp.clip(jnp.ceil(reach), 1, pieces).astype(jnp.int32)
            chord = alpha * dq / count

            def clear_so_far(carry):
                j, toi = carry
                return (j < count) & (toi >= 1)

            def next_chord(carry):
                j, _ = carry
                start = q + j.astype(q.dtype) * chord
                return j + 1, impact(start, start + chord)

            j, toi = jax.lax.while_loop(clear_so_far, next_chord, (0, jnp.ones((), q.dtype)))
            clear = jnp.where(toi < 1, (j - 1 + toi) / count, 1.0)
        else:  # the same work every time: every chord, side by side
            ends = q + (alpha * jnp.arange(pieces + 1, dtype=q.dtype) / pieces)[:, None] * dq
            toi = jax.vmap(impact)(ends[:-1], ends[1:])
            hit = toi < 1
            first = jnp.argmax(hit)
            clear = jnp.where(jnp.any(hit), (first + toi[first]) / pieces, 1.0)
        return alpha * jnp.where(clear >= 1, 1.0, _TOI_FRACTION * clear)

    def merit(q):
        r = residual(q)
        m = r @ r
        return jnp.where(jnp.isfinite(m), m, jnp.inf)

    def linearised(q, held=None):
        """The Newton matrix and residual at `q`, ``|r|²``, whether the matrix is the exact
        Jacobian there, and its contact-free part (`_newton_matrix`; `held`: that part held)."""
        jac, r, exact, bare = newton_matrix(q, held)
        return jac, r, r @ r, exact, bare

    def direction(jac, r):
        """The Newton update from `(jac, r)` (zero where not finite) and the largest coordinate of
        the update as solved (NaN where not finite: the step's `newton_error`)."""
        solved = jnp.linalg.solve(jac, r)
        dq = jnp.where(jnp.all(jnp.isfinite(solved)), -solved, 0.0)
        return dq, jnp.max(jnp.abs(solved))

    def line_search(q, dq, at_q, final=False, held=None):
        """`q` moved along `dq` by the first trial length with Armijo's decrease (else the one of
        least merit below ``|r(q)|²``, else none), the linearisation there (`linearised`; `at_q`
        is the one at `q`) and how far it moved (largest coordinate). Each trial linearises the
        residual rather than only evaluating it: the trial taken is where the next Newton update
        starts, so its matrix is not computed twice (most steps take their first trial). `final`:
        the longest trial taken without evaluating it (the linearisation returned is `at_q`'s).
        `held`: the matrix's contact-free part held (`linearised`)."""
        m0 = at_q[2]

        def trial(carry):
            j, alpha, first, best, best_m, kept = carry
            evaluated = linearised(q + alpha * dq, held)
            m = evaluated[2]
            m = jnp.where(jnp.isfinite(m), m, jnp.inf)
            armijo = (m <= (1 - 2 * _ARMIJO * alpha) * m0) & jnp.isnan(first)
            first = jnp.where(armijo, alpha, first)
            better = m < best_m
            best = jnp.where(better, alpha, best)
            # The trial taken: the first with Armijo's decrease (the search stops there), else
            # the best so far.
            kept = jax.tree.map(
                lambda new, old: jnp.where(armijo | better, new, old), evaluated, kept
            )
            return j + 1, 0.5 * alpha, first, best, jnp.minimum(m, best_m), kept

        zero = jnp.zeros((), q.dtype)
        longest = largest_step(q, dq)
        start = (0, longest, jnp.full((), jnp.nan, q.dtype), zero, m0, at_q)
        searching = lambda c: (c[0] < solver.halvings) & jnp.isnan(c[2]) & ~final  # noqa: E731
        _, _, first, best, _, kept = jax.lax.while_loop(searching, trial, start)
        alpha = jnp.where(final, longest, jnp.where(jnp.isnan(first), best, first))
        return q + alpha * dq, kept, jnp.max(jnp.abs(alpha * dq)), alpha

    # The predictor, capped like an update (q_n is clear of contact).
    drift = s_q_hat + s_beta * s_v_hat - s_q
    if acceleration is not None:
        free = _in_free_flight(s_system, s_q)
        if free is not None:
            drift = drift + jnp.where(free, s_beta * s_beta, 0.0) * jax.lax.stop_gradient(
                acceleration
            )
    q = s_q + largest_step(s_q, drift) * drift
    if solver.early_exit:
        # Each iteration moves along the last direction and computes the next one at the new
        # state. They stop once that next update is within `_CONVERGED` (not taken: the state is
        # converged) or the last move was (the line search found no decrease, or the collision
        # cap stops it). Where the error the next update would leave, estimated from the rate
        # of convergence (`_error_after`), is within it, the last iteration takes that update
        # without evaluating the residual there (one linearisation fewer per step), capped by the
        # collision check like any update (its length is then the error, else the estimate).
        def iterate(carry, held=None):
            i, q, dq, size, at_q, moved = carry
            estimate = _error_after(size, moved, at_q[3])
            final = estimate <= _CONVERGED
            q, at_q, moved, alpha = line_search(q, dq, at_q, final, held)
            new_dq, new_size = direction(*at_q[:2])
            dq = jnp.where(final, dq, new_dq)
            size = jnp.where(final, jnp.where(alpha < 1, size, estimate), new_size)
            return i + 1, q, dq, size, at_q, jnp.where(final, 0.0, moved)

        def iterating(carry):
            i, _, _, size, _, moved = carry
            going = (size > _CONVERGED) & (moved > _CONVERGED)
            return (i < solver.newton_iterations) & going

        at_q = linearised(q)
        start = (0, q, *direction(*at_q[:2]), at_q, jnp.full((), jnp.inf, q.dtype))

        def afresh():
            return jax.lax.while_loop(iterating, iterate, start)

        contact_free = at_q[4]  # `None` where the matrix has no such part (`_newton_matrix`)
        if contact_free is None:
            _, q, _, error, _, _ = afresh()
        else:
            # Where every member's first update is short, the iterates stay near the predictor:
            # the matrix's contact-free part is held from there (Newton's simplified iterations;
            # the root is the same, the convergence linear). Not where a hinge is released from
            # rest or a panel is stopped, whose updates move far, and whose drag's derivative (in
            # proportion to each point's speed) changes by its own size.
            def held():
                return jax.lax.while_loop(iterating, lambda c: iterate(c, contact_free), start)

            short = eqxi.unvmap_all(start[3] < _HOLD_BELOW)
            _, q, _, error, _, _ = jax.lax.cond(short, held, afresh)
    else:

        def iterate(_, q):
            jac, r, m0, _, _ = linearised(q)
            dq, _ = direction(jac, r)
            alpha = _all_trials(merit, q, dq, largest_step(q, dq), m0, solver.halvings)
            return q + alpha * dq

        q = jax.lax.fori_loop(0, solver.newton_iterations, iterate, q)
        error = direction(*linearised(q)[:2])[1]
    left_out = jnp.zeros((), bool)
    if counts is not None:
        # The next step's working set, chosen where this one ends (its start).
        selection, left_out = s_system.contact.next_working_set(s_system.mechanism, q, counts)
    q = _root(jax.lax.stop_gradient(q), system, inputs, t_next, h, q_n, v_n, noise, history)
    if history is None:
        return q, (q - q_n) / h, jax.lax.stop_gradient(error), left_out, selection
    beta, q_hat, _, _, _ = _bdf2_start(h, q_n, v_n, history)
    return q, (q - q_hat) / beta, jax.lax.stop_gradient(error), left_out, selection


def _error_after(size, moved, exact):
    """The Newton error left after taking an update of largest coordinate `size` that followed a
    move of `moved` (rad; ``inf`` where no move came before): from the rate of contraction ``θ =
    size / moved``, ``θ size / (1 − θ)`` for the linear convergence of the Gauss–Newton matrix at a
    contact (as Hairer and Wanner's stopping test for the Newton iterations of implicit
    Runge–Kutta methods), ``θ² size / (1 − θ)`` for the quadratic convergence of a matrix that is
    the exact Jacobian (`exact`: the next update ``≈ C size²`` with ``C = size / moved²``). ``inf``
    (no estimate) without a previous move or where ``θ ≥ 1/2``."""
    theta = size / moved
    rate = jnp.where(exact, theta * theta, theta)
    known = jnp.isfinite(moved) & (theta < 0.5)
    return jnp.where(known, rate * size / (1 - jnp.where(known, theta, 0.0)), jnp.inf)


def _in_free_flight(system: FoldingSystem, q):
    """Whether no contact acts at ``q`` for sure: `True` without contact, the working set's word
    (`PlateContact.surely_apart`) with one, `None` where the contact cannot tell."""
    contact = system.contact
    if contact is None:
        return jnp.ones((), bool)
    if not hasattr(contact, "surely_apart"):
        return None
    return contact.surely_apart(system.mechanism, q)


def _where(condition, new, old):
    """`new` where `condition`, else `old`, leaf by leaf (`None` stays `None`)."""
    return jax.tree.map(lambda a, b: jnp.where(condition, a, b), new, old)


def integrate(
    system: FoldingSystem,
    inputs: AbstractInput,
    solver: ImplicitStep,
    t0: Float[Array, ""],
    ts: Float[Array, " t"],
    q0: Float[Array, " n"],
    v0: Float[Array, " n"],
    steps: int,
) -> tuple[Array, Array, dict[str, Array], RESULTS]:
    """The states ``(q, v)`` at the sample times `ts` (each `(t, n)`), statistics and a result code:
    `steps` equal implicit steps (`_step`) between consecutive times of ``(t0, ts…)``; a sample at
    the time of the last (``ts[0] = t0``, repeated times) repeats its state."""
    starts = jnp.concatenate([jnp.reshape(t0, (1,)), ts[:-1]])
    bdf2 = solver.scheme == "bdf2"

    def interval(state, span):
        t_start, t_end, index = span
        length = t_end - t_start
        moves = length > 0
        h = jnp.where(moves, length / steps, 1.0)

        def step(carry, j):
            (q, v, error, left_out), previous, selection, acceleration = carry
            noise = step_noise(system, index * steps + j.astype(jnp.int32), q.shape[0])
            history = None
            if bdf2:
                q_prev, v_prev, h_prev = previous
                ratio = h / jnp.where(h_prev > 0, h_prev, 1.0)
                # No previous step, or a jump of the step BDF2 is unstable for: an Euler step.
                usable = (h_prev > 0) & (ratio <= _BDF2_LARGEST_RATIO)
                history = (q_prev, v_prev, jnp.where(usable, ratio, 0.0))
            q_next, v_next, e, out, used = _step(
                system,
                inputs,
                solver,
                t_start + (j + 1) * h,
                h,
                q,
                v,
                noise,
                history,
                selection,
                acceleration,
            )
            q_next = jnp.where(moves, q_next, q)
            v_next = jnp.where(moves, v_next, v)
            if bdf2:
                previous = _where(moves, (q, v, h), previous)
            selection = _where(moves, used, selection)
            if not bdf2:  # Euler's predictor's (`_step`)
                change = jax.lax.stop_gradient((v_next - v) / h)
                acceleration = _where(moves, change, acceleration)
            error = jnp.maximum(error, jnp.where(moves, e, 0.0))
            state = (q_next, v_next, error, left_out + (moves & out).astype(jnp.int32))
            return (state, previous, selection, acceleration), None

        def steps_across(state):
            return jax.lax.scan(step, state, jnp.arange(steps, dtype=ts.dtype))[0]

        # An empty interval (a repeated sample time: `simulate`'s padding) takes no steps; under
        # `vmap` with a batched `moves` both branches run, masked as before.
        state = jax.lax.cond(moves, steps_across, lambda state: state, state)
        return state, state[0][:2]

    zero = jnp.zeros((), q0.dtype)
    # BDF2's previous state and step (none yet: its first step is an Euler step).
    previous = (q0, v0, zero) if bdf2 else None
    # The contact's working set, carried from step to step while it has room
    # (`PlateContact.next_working_set`).
    counts = _pair_counts(system.contact, solver)
    selection = None
    if counts is not None:
        s_system, s_q = _without_derivatives((system, q0))
        selection = s_system.contact.select_pairs(s_system.mechanism, s_q, counts).selection
    # Implicit Euler's predictor's acceleration: none before the first step.
    acceleration = None if bdf2 else jnp.zeros_like(v0)
    start = ((q0, v0, zero, jnp.zeros((), jnp.int32)), previous, selection, acceleration)
    indices = jnp.arange(ts.shape[0], dtype=jnp.int32)
    ((_, _, error, left_out), _, _, _), (q, v) = jax.lax.scan(
        interval, start, (starts, ts, indices)
    )
    count = jnp.sum(ts > starts).astype(jnp.int32) * steps
    finite = jnp.all(jnp.isfinite(q)) & jnp.all(jnp.isfinite(v))
    result = RESULTS.where(finite, RESULTS.successful, RESULTS.nonfinite_state)
    stats = {
        "num_steps": count,
        "num_accepted_steps": count,
        "num_rejected_steps": jnp.zeros((), jnp.int32),
        "newton_error": jax.lax.stop_gradient(error),
        "contacts_left_out": left_out,
    }
    return q, v, stats, result
