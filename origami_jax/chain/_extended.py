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

import jax.numpy as jnp
import numpy as np

from ..system import FoldingSystem, HingeDesign, HingeDrag, Hinges

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


def _panels(design: HingeDesign, n: int, lengths, gravity, arc: bool):
    from ..net import PanelTree
    from ._chain import plate_inertia

    length, width = design.flap_length, design.flap_width
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


def _quadrature(design: HingeDesign, n: int):
    """`PanelDrag`'s quadrature of `n` rectangular flaps, from a unit square scaled by the (possibly
    traced) flap size: body frames at the flaps' centres, ``x`` across, ``y`` along."""
    from ..fluid import PanelQuadrature, polygon_quadrature

    square = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]])
    unit_points, unit_weights = polygon_quadrature(square, 2)
    count = len(unit_weights)
    size = jnp.stack([design.flap_width, design.flap_length])
    points = jnp.concatenate([unit_points * size, jnp.zeros((count, 1))], axis=-1)
    normals = jnp.zeros((count * n, 3)).at[:, 2].set(1.0)
    return PanelQuadrature(
        jnp.tile(points, (n, 1)),
        jnp.tile(unit_weights * design.flap_width * design.flap_length, n),
        normals,
        tuple(int(b) for b in np.repeat(np.arange(n), count)),
    )


def extended_accordion(
    design: HingeDesign,
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
    Arguments as `accordion_system`'s."""
    from ..fluid import CombinedDrag, PanelDrag, fluid_loads, rectangle_added_inertia
    from ..net import strip_tree

    parts = fluid_parts(fluid)
    if hinges not in ("point", "arc"):
        raise ValueError(f"hinges must be 'point' or 'arc', got {hinges!r}.")
    target = jnp.asarray(targets, dtype=jnp.result_type(float))
    radius = design.radius()
    dtype = target.dtype
    lengths = radius * jnp.abs(target) if hinges == "arc" else jnp.zeros(n, dtype)
    panels = _panels(design, n, lengths, gravity, hinges == "arc")
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
        drags.append(HingeDrag(design.drag(n)))
    if "panel" in parts:
        drags.append(
            PanelDrag(
                _quadrature(design, n),
                design.drag_coefficient * design.b_scale,
                design.fluid.density,
                0.5 if design.drag_model == "paper" else 1.0,
            )
        )
    if "added_mass" in parts or "viscous" in parts:
        unit = rectangle_added_inertia(design.flap_length, design.flap_width, 1.0)
        loads = fluid_loads(
            mechanism,
            jnp.broadcast_to(unit, (n, 6, 6)),
            jnp.broadcast_to(design.flap_length, (n,)),
            stiffness,
            target,
            density=design.fluid.density,
            viscosity=design.fluid.viscosity,
            coefficient=design.added_mass_coefficient,
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
        from ..contact import PanelContact

        contact_model = PanelContact.for_system(
            mechanism,
            np.asarray(stiffness),
            np.asarray(target),
            thickness=np.asarray(design.t_structural),
            base_outline=_base(design),
        )
    return FoldingSystem(mechanism, hinges_, drag, contact=contact_model, units=design.units)


def _base(design: HingeDesign) -> np.ndarray:
    """The membrane before the first crease, a flap-sized rectangle ``y ∈ [−L, 0]`` (world)."""
    length, width = float(design.flap_length), float(design.flap_width)
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


def accordion_diagnostics(design: HingeDesign, n: int = 3) -> dict:
    """Where the extended accordion differs from the paper's, in numbers (the paper job and
    `notebooks/paper_vs_extended.ipynb` print them). MICRO units (µm, µs, ng).

    **Arguments:** `design`, a [`origami_jax.system.HingeDesign`][] (its fluid sets the fluid
    terms; both stiffness formulas are evaluated whatever its `stiffness_model`); `n`, the number
    of flaps.

    **Returns:** a dict of host floats and lists of `n` floats (one per hinge):

    - `fluid` (name) and `fluid_density` (ng/µm³); `stiffness_paper` and `stiffness_bilayer` (µN·µm/rad, hinge 1): the paper's
      ``w(E₁'t₁³ + E₂'t₂³)/(3l)`` and the bonded bilayer's (docs/physics.md, "The hinge is a bending
      arc");
    - `radius_um` (ρ, µm), `strip_length_um` (``l = ρ |θ_target,1|``, µm), `strip_mass_ng` and
      `flap_mass_ng` (ng, hinge and flap 1);
    - `inertia_mid_fold_paper`, `inertia_mid_fold_arc`, `inertia_mid_fold_arc_fluid` (`n`,
      ng·µm²): the mass matrix's diagonal half-way to the target for point hinges, arc hinges with
      their strips, and arc hinges with the fluid's added inertia;
    - `fluid_frequency_rad_per_us`, `reynolds`, `gamma_real`, `gamma_imag` (`n` each): the
      frequency at which the fluid terms are evaluated, the Reynolds number and the real
      (inertia) and imaginary (damping) parts of Sader's hydrodynamic function, per flap;
    - `tip_contact_angle_over_pi`: the fold angle (over π) at which flap 1's far edge touches the
      base (`tip_contact_angle`).

    **Raises:** `ValueError` from the design's own checks (e.g. a non-positive thickness).
    """
    from ..fluid import fluid_loads, rectangle_added_inertia
    from ..net import strip_tree
    from ._system import accordion_system, alternating_targets

    target = alternating_targets(n, design.theta_final)
    middle = 0.5 * target
    paper_design = eqx_replace(design, stiffness_model="paper")
    bilayer_design = eqx_replace(design, stiffness_model="bilayer")
    point = accordion_system(paper_design, n)
    radius = float(design.radius())
    lengths = radius * np.abs(np.asarray(target))
    panels = _panels(design, n, jnp.asarray(lengths), None, True)
    arc = strip_tree(
        panels,
        areal_density=design.strip_areal_density(),
        width=design.hinge_width,
        thickness=design.t_structural + design.t_hinge,
    )
    stiffness = bilayer_design.stiffness(n)
    unit = rectangle_added_inertia(design.flap_length, design.flap_width, 1.0)
    loads = fluid_loads(
        arc,
        jnp.broadcast_to(unit, (n, 6, 6)),
        jnp.broadcast_to(design.flap_length, (n,)),
        stiffness,
        target,
        density=design.fluid.density,
        viscosity=design.fluid.viscosity,
        coefficient=design.added_mass_coefficient,
    )
    flap_mass = float(panels.masses[0])
    strip_mass = float(design.strip_areal_density() * jnp.mean(design.hinge_width)) * lengths[0]

    def diagonal(mechanism):
        return np.asarray(jnp.diagonal(mechanism.mass_matrix(middle))).tolist()

    return {
        "fluid": design.fluid.name,
        "fluid_density": float(design.fluid.density),
        "stiffness_paper": float(paper_design.stiffness(n)[0]),
        "stiffness_bilayer": float(stiffness[0]),
        "radius_um": radius,
        "strip_length_um": float(lengths[0]),
        "flap_mass_ng": flap_mass,
        "strip_mass_ng": strip_mass,
        "inertia_mid_fold_paper": diagonal(point.mechanism),
        "inertia_mid_fold_arc": diagonal(arc),
        "inertia_mid_fold_arc_fluid": diagonal(loads.mechanism),
        "fluid_frequency_rad_per_us": np.asarray(loads.frequency).tolist(),
        "reynolds": np.asarray(loads.reynolds).tolist(),
        "gamma_real": np.asarray(loads.gamma[0]).tolist(),
        "gamma_imag": np.asarray(loads.gamma[1]).tolist(),
        "tip_contact_angle_over_pi": tip_contact_angle(
            radius, float(lengths[0]), float(design.flap_length)
        )
        / np.pi,
    }


def eqx_replace(design: HingeDesign, **static) -> HingeDesign:
    """`design` with static fields (`stiffness_model`, `drag_model`) replaced."""
    import dataclasses

    return dataclasses.replace(design, **static)
