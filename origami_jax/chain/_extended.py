"""The accordion beyond the paper's model: bending-arc hinges with mass, fluid inertia, viscous drag.

`accordion_system(design, n, hinges=..., fluid=...)` builds its extended variants here (the paper's
model, point hinges and hinge drag, stays on the serial-chain engine). The flaps are a panel tree
(`origami_jax.net`), written out from the design's numbers so that every one of them may be traced
(a design fit frees any of them):

- **Geometry.** Hinge ``i`` runs along ``x`` through ``(0, y_i, 0)``; with arc hinges its strip of
  length ``l_i = ρ |θ_target,i|`` leaves it along ``+y`` and flap ``i`` (``L × w``, thickness ``t₁``)
  starts at its end: ``y_{i+1} = y_i + l_i + L``. Point hinges: ``l_i = 0`` (the paper's geometry).
- **Hinges** (`"arc"`): `origami_jax.net.StripTree`, the strip's own mass ``(ρ₁t₁ + ρ₂t₂) w_h l``
  and inertia along the arc; the spring is the design's stiffness model (`"bilayer"`: the bending
  energy of the Timoshenko bilayer).
- **Fluid**: any of `"hinge"` (the paper's ``b θ̇|θ̇|``), `"panel"` (quadratic pressure drag on every
  flap from its own motion, `PanelDrag`, ``C_D ρ_f`` of the design, the paper's ``/16``
  normalisation when its `drag_model` is `"paper"`), `"added_mass"` and `"viscous"`
  (`fluid_loads`); `"extended"` is ``("panel", "added_mass", "viscous")``.
"""

import dataclasses

import jax.numpy as jnp
import numpy as np

from ..contact import PanelContact
from ..fluid import (
    CombinedDrag,
    FluidLoads,
    PanelDrag,
    PanelQuadrature,
    fluid_loads,
    polygon_quadrature,
    rectangle_added_inertia,
)
from ..net import PanelTree, strip_tree
from ..system import FoldingSystem, HingeDesign, HingeDrag, Hinges
from ._chain import plate_inertia

FLUID_PARTS = ("hinge", "panel", "added_mass", "viscous")
"""The fluid effects `accordion_system(fluid=...)` combines (module docstring)."""
EXTENDED_FLUID = ("panel", "added_mass", "viscous")
"""`fluid="extended"`: quadratic panel drag, added inertia and viscous drag."""


def fluid_parts(fluid) -> tuple[str, ...]:
    """`fluid` (`"paper"`, `"extended"` or a sequence of `FLUID_PARTS`) as a sorted tuple of parts.

    **Raises:** `ValueError` for an unknown name, no drag at all, or both drags at once.
    """
    if fluid == "paper":
        return ("hinge",)
    if fluid == "extended":
        return EXTENDED_FLUID
    if isinstance(fluid, str):
        fluid = (fluid,)
    parts = tuple(fluid)
    unknown = [p for p in parts if p not in FLUID_PARTS]
    if unknown or not parts:
        raise ValueError(
            f"fluid must be 'paper', 'extended' or a sequence of {FLUID_PARTS}, got {fluid!r}."
        )
    if "hinge" in parts and "panel" in parts:
        raise ValueError(
            "fluid: 'hinge' (the paper's drag) and 'panel' (drag on every panel) are two models of "
            "the same pressure drag; choose one."
        )
    return tuple(p for p in FLUID_PARTS if p in parts)


def _panels(design: HingeDesign, size, n: int, lengths, gravity, arc: bool):
    """The `n` flaps of `size` (`(flap_length, flap_width)`, may be traced) on a panel tree,
    hinge `i` `lengths[i]` after flap `i − 1` (arc hinges' strips)."""
    length, width = size
    dtype = jnp.result_type(float)
    starts = jnp.concatenate(
        [jnp.zeros(1, dtype), jnp.cumsum(lengths + length)[:-1]]
    )  # y_i of each hinge
    e_x, e_y = jnp.array([1.0, 0.0, 0.0]), jnp.array([0.0, 1.0, 0.0])
    points = starts[:, None] * e_y
    centres = (starts + lengths + 0.5 * length)[:, None] * e_y
    frames = jnp.broadcast_to(jnp.eye(4, dtype=dtype), (n, 4, 4)).at[:, :3, 3].set(centres)
    mass, inertia = plate_inertia(length, width, design.t_structural, design.structural.density)
    return PanelTree(
        tuple(range(-1, n - 1)),
        jnp.broadcast_to(e_x, (n, 3)),
        points,
        frames,
        jnp.broadcast_to(mass, (n,)),
        None,
        jnp.broadcast_to(inertia, (n, 3, 3)),
        gravity=gravity,
        arc_lengths=lengths if arc else None,
    )


def _quadrature(size, n: int):
    """`PanelDrag`'s quadrature of `n` rectangular flaps, from a unit square scaled by the (possibly
    traced) flap size `(flap_length, flap_width)`: body frames at the flaps' centres, ``x`` across,
    ``y`` along."""
    length, width = size

    square = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    unit_points, unit_weights = polygon_quadrature(square, 2)
    count = len(unit_weights)
    scale = jnp.stack([jnp.asarray(width), jnp.asarray(length)])
    points = jnp.concatenate([unit_points * scale, jnp.zeros((count, 1))], axis=-1)
    normals = jnp.zeros((count * n, 3)).at[:, 2].set(1.0)
    return PanelQuadrature(
        jnp.tile(points, (n, 1)),
        jnp.tile(unit_weights * width * length, n),
        normals,
        tuple(int(b) for b in np.repeat(np.arange(n), count)),
    )


def extended_accordion(
    design: HingeDesign,
    size,
    n: int,
    targets,
    release_times,
    gravity,
    *,
    hinges: str,
    fluid,
    contact: bool,
    strip_nodes: int,
) -> FoldingSystem:
    """The accordion with arc or point hinges on a panel tree and any fluid parts (module docstring).
    Arguments as `accordion_system`'s; `size` its `(flap_length, flap_width)`."""

    parts = fluid_parts(fluid)
    if hinges not in ("point", "arc"):
        raise ValueError(f"hinges must be 'point' or 'arc', got {hinges!r}.")
    target = jnp.asarray(targets, dtype=jnp.result_type(float))
    radius = design.radius()
    dtype = target.dtype
    lengths = radius * jnp.abs(target) if hinges == "arc" else jnp.zeros(n, dtype)
    panels = _panels(design, size, n, lengths, gravity, hinges == "arc")
    if hinges == "arc":
        mechanism = strip_tree(
            panels,
            areal_density=design.strip_areal_density(),
            width=design.hinge_width,
            thickness=design.t_structural + design.t_hinge,
            nodes=strip_nodes,
        )
    else:
        mechanism = panels
    stiffness = design.stiffness(n)
    drags = []
    if "hinge" in parts:
        drags.append(HingeDrag(design.drag(n, *size)))
    if "panel" in parts:
        drags.append(
            PanelDrag(
                _quadrature(size, n),
                design.drag_coefficient * design.b_scale,
                design.fluid.density,
                0.5 if design.drag_model == "paper" else 1.0,
            )
        )
    if "added_mass" in parts or "viscous" in parts:
        loads = accordion_fluid_loads(
            design,
            size,
            mechanism,
            stiffness,
            target,
            added_mass="added_mass" in parts,
            viscous="viscous" in parts,
        )
        mechanism = loads.mechanism
        if loads.viscous is not None:
            drags.append(loads.viscous)
    drag = drags[0] if len(drags) == 1 else CombinedDrag(tuple(drags))
    hinges_ = Hinges(stiffness, target, radius, release_times)
    contact_model = None
    if contact:
        contact_model = PanelContact.for_system(
            mechanism,
            np.asarray(stiffness),
            np.asarray(target),
            thickness=np.asarray(design.t_structural),
            base_outline=_base(size),
        )
    return FoldingSystem(mechanism, hinges_, drag, contact=contact_model, units=design.units)


def accordion_fluid_loads(
    design: HingeDesign, size, mechanism, stiffness, target, *, added_mass=True, viscous=True
) -> FluidLoads:
    """`fluid_loads` on the accordion's `n` flaps (rectangles ``L × w`` of `size`, `(L, w)`, chord
    ``L``) in the design's fluid, with its added-mass coefficient."""
    n = mechanism.n_hinges
    length, width = size
    unit = rectangle_added_inertia(length, width, 1.0)
    return fluid_loads(
        mechanism,
        jnp.broadcast_to(unit, (n, 6, 6)),
        jnp.broadcast_to(length, (n,)),
        stiffness,
        target,
        density=design.fluid.density,
        viscosity=design.fluid.viscosity,
        coefficient=design.added_mass_coefficient,
        added_mass=added_mass,
        viscous=viscous,
    )


def _base(size) -> np.ndarray:
    """The membrane before the first crease, a flap-sized rectangle ``y ∈ [−L, 0]`` (world), for
    flaps of `size` `(L, w)`."""
    length, width = float(size[0]), float(size[1])
    return np.array(
        [
            [-width / 2, -length, 0.0],
            [width / 2, -length, 0.0],
            [width / 2, 0.0, 0.0],
            [-width / 2, 0.0, 0.0],
        ]
    )


def tip_contact_angle(radius: float, strip_length: float, flap_length: float) -> float:
    """The fold angle (rad, in ``(π, 2π)``) at which a flap of length ``L`` on an arc hinge of strip
    length ``l`` (bending radius ``ρ`` at its target π) touches the panel it folded onto with its
    far edge: ``z_tip(q) = l (1 − cos q)/q + L sin q = 0`` (bisection, host). With a point hinge it is
    ``π``: any overshoot is interpenetration. `radius` is unused but for the docstring's reading
    (``l = ρ π``)."""
    del radius

    def height(q):
        return strip_length * (1 - np.cos(q)) / q + flap_length * np.sin(q)

    lo, hi = np.pi, 2 * np.pi
    if height(lo + 1e-12) <= 0:
        return float(np.pi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if height(mid) > 0 else (lo, mid)
    return 0.5 * (lo + hi)


def eqx_replace(design: HingeDesign, **static) -> HingeDesign:
    """`design` with static fields (`stiffness_model`, `drag_model`) replaced."""
    return dataclasses.replace(design, **static)
