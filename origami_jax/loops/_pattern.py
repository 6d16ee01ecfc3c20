"""A crease pattern with closed loops from FOLD: its folding system, start state, verdict and frames.

`load_pattern("miura_3x3")` reads a catalogue name or a `.fold` file. A pattern whose faces form a tree
comes back as a [`origami_jax.net.Net`][] (the panel-tree engine, unchanged); one whose creases close
loops around interior vertices comes back as a [`origami_jax.loops.CreasePattern`][]:

- `pattern.system(design)` builds the [`origami_jax.system.FoldingSystem`][]: the panels on a
  spanning tree of the faces with the loop closure as constraints ([`origami_jax.loops.LoopedPanels`][]),
  one bilayer hinge per crease (stiffness from the design with hinge length ``ρ |θ_target|``, as for
  nets), panel drag, contact between panels (also between panels that meet only at a vertex, away
  from it);
- `pattern.start_state(system)` is the state a simulation starts from: flat, or with a small pre-fold
  `bias` along the branch the inputs choose (docs/physics.md, "Closed loops");
- `pattern.assess(system, trajectory)` judges the folding against the pattern's angles and reports
  which branch it took (which way each crease went): another branch is `misfolded`;
- `pattern.rigid_foldability()` says whether rigid panels can fold from flat to the targets, with the
  closure residual when they cannot (a square twist): `system()` refuses such a pattern instead of
  forcing it (pass `check_rigid=False` to simulate what rigid panels do anyway).
"""

import dataclasses
import os
from typing import Any, ClassVar, final

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._limits import CONTACT_SAMPLING
from .._validate import is_traced
from ..contact import (
    Adhesion,
    Friction,
    PanelContact,
    PlateContact,
    build_plate_tables,
    build_tables,
    check_sampling,
    contact_kind,
    sampling_pair,
)
from ..fluid import PanelDrag
from ..fold import (
    FoldFile,
    FoldFormatError,
    LoopGeometry,
    flat_fold,
    length_scale_from_unit,
    loop_geometry,
    read_fold,
    source_and_label,
)
from ..net import (
    AbstractPanelPattern,
    HostCache,
    Net,
    check_agitation_balanced,
    check_hinges_longer_than_film,
    check_loader_arguments,
    check_per_crease,
    check_physics_options,
    default_design,
    folding_animation,
    front_release,
    load_net,
    seam_gap_function,
    unit_front_direction,
    vertex_corners,
    warn_if_hinges_wider_than_creases,
    with_fluid_loads,
    with_surface_physics,
)
from ..simulation import assess, fold_outcome
from ..system import MICRO, Agitation, FoldingSystem, HingeDesign, Hinges
from . import _kinematics
from ._mechanism import LoopedPanels
from ._report import LoopFoldReport

# Baumgarte rate of the closure, as a multiple of the fastest hinge's natural frequency sqrt(k/I).
RATE_FACTOR = 1.0
# An unfolded form's loops that miss closing by at most this (rad) miss by the rounding of its
# coordinates (six digits of a unit-size form: ~1e-6), and are closed; more is not a rigid state.
FORM_CLOSURE_TOL = 1e-4


class NotRigidlyFoldableError(ValueError):
    """The pattern cannot fold from flat to its target angles with rigid panels (its facets would have
    to bend); `report` holds the `RigidFoldability` with the closure residual."""

    def __init__(self, message: str, report):
        super().__init__(message)
        self.report = report


# `start_state`: a pre-fold whose nearest closed state is closer to flat than this fraction of it has
# fallen to flat; it is then reached down the branch from the full fold, in steps each at most this
# shrink (at most so many: from a 10 rad fold to 1e-6 rad takes 45).
_COLLAPSED = 0.1
_SHRINK = 0.7
_SHRINK_STEPS = 60
OSCILLATION_BIAS = 0.01
"""How far along its branch (rad) a crease pattern's quasi-static ramp is linearised
(`CreasePattern.oscillation_state`): the slowest mode changed by less than 1e-3 between 0.001
and 0.05 rad on the catalogue's patterns."""

# The physics options of a crease pattern (`CreasePattern.with_model`) and their defaults.
PATTERN_MODEL = {
    "contact": True,
    "drag": "panel",
    "hinges": "point",
    "contact_sampling": CONTACT_SAMPLING,
    "check_rigid": True,
    "adhesion": None,
    "friction": None,
    "release_ramp": "auto",
    "added_mass": None,
    "viscous": None,
    "agitation": None,
}


@final
@dataclasses.dataclass(frozen=True, eq=False)
class CreasePattern(AbstractPanelPattern):
    """A flat crease pattern whose creases close loops (module docstring); an
    [`origami_jax.system.AbstractPattern`][].

    **Fields:** `geometry` (a `LoopGeometry`, lengths in the FOLD unit), `name`, `length_scale`
    (design length units per FOLD unit), `precision` (rad; default 0): how closely the pattern's
    own geometry lets its loops close, for a pattern unfolded from a folded form written to a few
    digits (its sector angles carry that rounding, so an overconstrained pattern such as a
    Miura-ori closes only to about it); the closure and rigid-foldability checks accept residuals
    up to it. Crease ``j`` of the systems it builds is the geometry's crease ``j`` (tree creases,
    then cut creases); body ``j`` is face ``geometry.tree.order[j + 1]``; the root face is the
    fixed base. The physics model its systems take unless `system` is told otherwise
    (`with_model`): `contact` (default `True`), `drag` (`"panel"`, the only one), `hinges`
    (`"point"`, the only one), `contact_sampling` (`(4, 2)`), `check_rigid` (`True`), `adhesion`
    and `friction` (`None`: off; an `origami_jax.contact.Adhesion` or `Friction` attaches it to the
    plate contact), as `system` documents them; `added_mass`, `viscous` (`None`: on in a liquid,
    the etch bath, off in a gas, as for nets: `fluid_inertia`); `release_ramp` (`"auto"`, the
    default: quasi-static where the panels carry the fluid's inertia, the paper's step
    otherwise; `None`: the step; a time, µs: each hinge's torque grows over it from its release,
    `release_input`); `agitation` (`None`: off; an `origami_jax.system.Agitation`, the bath's
    random force, carried by the systems as for nets: it needs the fluid's viscous drag and the
    fixed-step engine, `origami_jax.simulation.ImplicitStep`).
    """

    geometry: LoopGeometry
    name: str
    length_scale: float
    precision: float = 0.0
    host_cache: HostCache = dataclasses.field(default_factory=HostCache, repr=False)
    contact: bool | str = True
    drag: str = "panel"
    hinges: str = "point"
    contact_sampling: tuple[int, int] = CONTACT_SAMPLING
    check_rigid: bool = True
    adhesion: Adhesion | None = None
    friction: Friction | None = None
    release_ramp: float | str | None = "auto"
    added_mass: bool | None = None
    viscous: bool | None = None
    agitation: Agitation | None = None

    # ---- the pattern ----

    MODEL: ClassVar[dict[str, Any]] = PATTERN_MODEL

    def __post_init__(self):
        check_physics_options(self)

    @property
    def continues_from_angles(self) -> bool:
        return False  # its state holds the closure's coordinates, not only its hinge angles

    def release_times_from_front(self, direction, speed: float) -> np.ndarray:
        """Release times of an etch front (`origami_jax.loops.release_times_from_front`)."""
        return release_times_from_front(self, direction, speed)

    def resume_settings(self) -> dict:
        """What a stored sweep of this pattern records: its name and its closed loops."""
        return {"net": self.name, "closed_loops": self.n_loops}

    @property
    def n_loops(self) -> int:
        return self.geometry.n_loops

    @property
    def intended_angles(self) -> np.ndarray:
        """The pattern's fold angles (rad, `(m,)`): the shape a correct folding reaches."""
        return np.asarray(self.geometry.targets, dtype=float)

    @property
    def seams(self):
        return self.geometry.seams

    @property
    def crease_lengths(self) -> np.ndarray:
        """Each crease's length (the design's length units, µm by default; `(m,)`)."""
        return np.asarray(self.geometry.lengths, dtype=float) * self.length_scale

    @property
    def crease_edge_ids(self) -> tuple[tuple[int, ...], ...]:
        """The FOLD edges of each crease (as `origami_jax.net.Net.crease_edge_ids`)."""
        return self.geometry.crease_edges

    def _padded(self):
        def padded():
            g = self.geometry
            directions, index = _kinematics._padded(g.loop_directions, g.loop_creases)
            return directions, _kinematics._with_count(index, g.n_creases)

        return self.host_cache.get("padded", padded)

    def closure_residual(self, angles: Float[ArrayLike, "*batch m"]) -> np.ndarray:
        """Each loop's closure residual at `angles` (the rotation angle, rad, `(*batch, n_v)`)."""
        return self.geometry.closure_residual(np.asarray(angles, dtype=float))

    def check_angles(self, angles: Float[ArrayLike, " m"], what: str = "fold angles") -> None:
        """Raise `FoldFormatError` unless `angles` (rad, `(m,)`) are a state rigid panels can take:
        every vertex that folds flat (all its creases at 0 or ±180°) obeys Kawasaki's and Maekawa's
        theorems, and every loop closes to `CLOSURE_TOL` (or the pattern's `precision`)."""
        g = self.geometry
        angles = np.asarray(angles, dtype=float)
        if angles.shape != (g.n_creases,):
            raise ValueError(f"{what} must have shape ({g.n_creases},), got {angles.shape}.")
        if not np.all(np.isfinite(angles)):
            raise FoldFormatError(f"{what}: every crease needs a finite fold angle.")
        for v, creases in enumerate(g.loop_creases):
            values = angles[list(creases)]
            folded = np.abs(np.abs(values) - np.pi) < 1e-9
            if np.any(folded) and np.all(folded | (np.abs(values) < 1e-9)):
                sectors = g.loop_sectors[v]
                # Sectors between consecutive folded creases (flat ones merge their neighbours).
                start = int(np.flatnonzero(folded)[0])
                merged, current = [], 0.0
                for k in range(len(creases)):
                    i = (start + k) % len(creases)
                    current += sectors[i]
                    if folded[(i + 1) % len(creases)]:
                        merged.append(current)
                        current = 0.0
                alternating = abs(sum(merged[0::2]) - sum(merged[1::2]))
                vertex = int(g.loop_vertices[v])
                if len(merged) % 2 or alternating > 1e-6:
                    raise FoldFormatError(
                        f"{what}: vertex {vertex} folds flat (creases at ±180°) but its sectors "
                        f"violate Kawasaki's theorem (alternating sum {np.degrees(alternating):.4g}° "
                        f"over {len(merged)} folded creases, must be 0 with an even count): no flat "
                        "folded state exists there; change the crease pattern or the target angles"
                    )
                signs = np.sign(values[folded])
                if abs(int(np.sum(signs < 0)) - int(np.sum(signs > 0))) != 2:
                    raise FoldFormatError(
                        f"{what}: vertex {vertex} folds flat with {int(np.sum(signs < 0))} mountain "
                        f"and {int(np.sum(signs > 0))} valley creases; Maekawa's theorem needs "
                        "|M − V| = 2: flip one crease's assignment"
                    )
        residual = g.closure_residual(angles)
        if residual.size and float(np.max(residual)) > max(_kinematics.CLOSURE_TOL, self.precision):
            v = int(np.argmax(residual))
            degree = len(g.loop_creases[v])
            raise FoldFormatError(
                f"{what}: the faces around vertex {int(g.loop_vertices[v])} do not close (they miss "
                f"by a {np.degrees(residual[v]):.3g}° rotation): a degree-{degree} vertex has only "
                f"{degree - 3} free fold angles; fix edges_foldAngle, or start from "
                "CreasePattern.closest_state(angles)"
            )

    def closest_state(
        self, angles: Float[ArrayLike, " m"], *, keep_signs: bool = False
    ) -> np.ndarray:
        """A state near `angles` (rad) where every loop closes; with `keep_signs`, no crease
        crosses to the other side of flat from its sign in `angles` (the state stays on their
        branch; minimum-norm Gauss–Newton steps).

        Without `keep_signs`, the nearer of two closed states: Gauss–Newton steps truncated to the
        loops' well-conditioned directions (`_kinematics.close_nearby`), and minimum-norm ones.
        A pattern that folds with one degree of freedom (a Miura-ori) has a nearly singular
        direction besides its motion, along which minimum-norm steps leap: from the Miura 3×3's
        angles perturbed by 0.01 rad they went 20 rad away."""
        directions, index = self._padded()
        angles = np.asarray(angles, float)
        signs = np.sign(angles) if keep_signs else np.zeros_like(angles)
        projected = _kinematics.project(directions, index, angles, self.n_creases, signs)
        if keep_signs:
            return projected
        nearby = _kinematics.close_nearby(directions, index, angles, steps=20)
        closes = [
            float(np.max(self.closure_residual(theta), initial=0.0)) <= _kinematics.CLOSURE_TOL
            for theta in (nearby, projected)
        ]
        if closes[0] and (
            not closes[1] or np.linalg.norm(nearby - angles) <= np.linalg.norm(projected - angles)
        ):
            return nearby
        return projected

    def oscillation_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Where the quasi-static release ramp linearises the panels' motion
        (`origami_jax.simulation.quasi_static_ramp`'s `about`): the closed state
        `OSCILLATION_BIAS` (0.01 rad) from flat along the branch of the pattern's angles
        (`start_state`), and the crease rates that keep its loops closed there (`(m,)` and
        `(m, d)`). Flat, where the branches meet, allows motions no branch does, and there the
        slowest mode was up to 2.4 times slower than on the branch. `None` (flat, the spanning
        tree's bound) where no such state can be placed: no angles, or not rigidly foldable."""

        def build():
            if not np.all(np.isfinite(self.intended_angles)):
                return None
            try:
                theta, _ = self.start_state(bias=OSCILLATION_BIAS)
            except ValueError:
                return None
            directions, index = self._padded()
            return theta, _kinematics.motion_basis(directions, index, theta)

        return self.host_cache.get("oscillation_state", build)

    def rigid_foldability(self, targets: Float[ArrayLike, " m"] | None = None, *, steps: int = 20):
        """Can rigid panels fold from flat to `targets` (default the pattern's angles)? A
        `RigidFoldability` (continuation along the targets' direction; see `_kinematics.rigid_path`)."""
        targets = self.intended_angles if targets is None else np.asarray(targets, float)
        key = ("rigid", targets.tobytes(), steps)
        directions, index = self._padded()
        return self.host_cache.get(
            key, lambda: _kinematics.rigid_path(directions, index, targets, self.n_creases, steps)
        )

    def branch(self, angles: Float[ArrayLike, " m"], *, tolerance: float = np.radians(0.5)):
        """Which way each crease folds at `angles` (rad): +1 valley, −1 mountain, 0 within
        `tolerance` of flat, `(m,)` ints."""
        angles = np.asarray(angles, dtype=float)
        return np.where(np.abs(angles) < tolerance, 0, np.sign(angles)).astype(int)

    # ---- systems ----

    def net(self):
        """The spanning tree of panels as a [`origami_jax.net.Net`][] (cut creases open)."""
        return self.host_cache.get(
            "net", lambda: Net.from_geometry(self.geometry.tree, self.name, self.length_scale)
        )

    def mechanism(self, design: HingeDesign | None = None, *, rate: float = 0.0) -> LoopedPanels:
        """The panels (plates of the design's structural film) as a `LoopedPanels` in the design's
        units; `rate`: the closure's Baumgarte rate ``ω`` (1/time)."""
        design = HingeDesign.literature() if design is None else design
        g = self.geometry
        tree = self.net().tree(design)
        position = {int(f): i - 1 for i, f in enumerate(np.asarray(g.tree.order))}
        m_tree = g.n_tree_creases
        cut_bodies, cut_ends = [], []
        for j in range(m_tree, g.n_creases):
            a, b = (position[int(f)] for f in g.crease_faces[j])
            if b < 0:
                a, b = b, a
            start = g.points[j] * self.length_scale
            cut_bodies.append((a, b))
            cut_ends.append((start, start + g.lengths[j] * self.length_scale * g.axes[j]))
        directions, index = self._padded()
        points = np.array(
            [g.vertices_coords[v] * self.length_scale for v in g.loop_vertices], dtype=float
        ).reshape(-1, 3)
        return LoopedPanels(
            tree=tree,
            cut_bodies=tuple(cut_bodies),
            cut_ends=np.array(cut_ends, dtype=float).reshape(-1, 2, 3),
            loop_index=tuple(tuple(int(i) for i in row) for row in index),
            loop_directions=jnp.asarray(directions),
            rate=jnp.asarray(rate, dtype=jnp.result_type(float)),
            loop_points=points,
        )

    def system(
        self,
        design: HingeDesign | None = None,
        *,
        targets: Float[ArrayLike, " m"] | None = None,
        release_times: Float[ArrayLike, " m"] | None = None,
        contact: bool | str | None = None,
        drag: str | None = None,
        hinges: str | None = None,
        check_rigid: bool | None = None,
        rate_factor: float = RATE_FACTOR,
        contact_sampling: tuple[int, int] | None = None,
        added_mass: bool | None = None,
        viscous: bool | None = None,
    ) -> FoldingSystem:
        """The folding system of this pattern with the hinges, films and fluid of `design`.

        **Arguments** (the design's units, `MICRO` by default):
        - `design`: a `HingeDesign` (default `HingeDesign.literature()`, each hinge at most as
          wide as its crease); as for nets, each crease's bilayer folds to its own target (hinge
          length ``ρ |θ_target|``).
        - `targets`: fold target per crease (rad); default the pattern's angles (they must close:
          `check_angles`).
        - `release_times`: per-crease release time (time units); default all at ``t = 0``.
        - `contact`: panels meet (default) or pass through each other (`False`); the model,
          `"plate"` (default) or `"sampled"`, as for nets (`origami_jax.net.Net.system`).
        - `drag`: `"panel"` (each panel's own motion); the paper's per-hinge drag is defined for
          trees only.
        - `hinges`: `"point"` creases. Bending arcs of finite length (the net engine's `"arc"`) do not
          meet at a vertex, so a loop of them is not a rigid-panel mechanism: refused.
        - `check_rigid`: refuse (`NotRigidlyFoldableError`, with the closure residual) a pattern that
          rigid panels cannot fold to its angles.
        - `rate_factor`: the closure's Baumgarte rate in units of the fastest hinge's natural
          frequency ``sqrt(k / I)``.
        - `contact_sampling`: the sampled model's ``(points_per_edge, rim_points_per_edge)``, as for nets
          (`origami_jax.net.Net.system`).
        - `added_mass`, `viscous`: the fluid's inertia on every panel and its viscous drag, as for
          nets (`origami_jax.net.Net.system`; default on in a liquid, off in a gas): strip theory
          across each panel's chord, at the frequency of the panel's own hinge in the spanning
          tree. The loops make the panels move together, so the fluid they carry is each
          panel's own, not a subtree's; the frequency only sets the viscous boundary layer's
          thickness (Sader's function, which varies slowly with it).

        **Raises:** `ValueError` for bad arguments, `FoldFormatError` for target angles that do not
        close or violate Kawasaki/Maekawa at a flat-folded vertex, `NotRigidlyFoldableError`.

        The physics options (`contact`, `drag`, `hinges`, `check_rigid`, `contact_sampling`,
        `added_mass`, `viscous`) left `None` are the pattern's own (its fields; `with_model`).
        """
        contact = self.contact if contact is None else contact
        drag = self.drag if drag is None else drag
        hinges = self.hinges if hinges is None else hinges
        check_rigid = self.check_rigid if check_rigid is None else check_rigid
        added_mass, viscous = self.fluid_inertia(design, added_mass=added_mass, viscous=viscous)
        check_agitation_balanced(self, viscous)
        if contact_sampling is None:
            contact_sampling = self.contact_sampling

        if hinges != "point":
            raise ValueError(
                f"hinges={hinges!r}: a closed loop of bending strips of finite length does not meet "
                "at its vertex (the strips offset the panels), so it is not a rigid-panel mechanism; "
                "closed-loop patterns take point creases (hinges='point')."
            )
        if drag != "panel":
            raise ValueError(
                f"drag={drag!r}: the paper's per-hinge drag is defined for panel trees; closed-loop "
                "patterns take drag='panel' (each panel's own motion)."
            )
        lengths = self.crease_lengths
        if design is None:
            design = default_design(self)
        check_per_crease(design, self.n_creases)
        warn_if_hinges_wider_than_creases(self.name, design, lengths)
        m = self.n_creases
        intended = self.intended_angles
        if not np.all(np.isfinite(intended)) and targets is None:
            raise ValueError(
                "every crease needs a finite target: give edges_foldAngle in the FOLD file or "
                "targets= (rad)."
            )
        # The pattern's own checks, on its own (concrete) angles: evaluated now even when this
        # system is built inside a trace (a sweep kernel's), where JAX would otherwise stage them.
        with jax.ensure_compile_time_eval():

            def check():
                if np.all(np.isfinite(intended)):
                    self.check_angles(intended, "the pattern's fold angles")
                return True  # kept: checked once per pattern and angles

            self.host_cache.get(("checked", intended.tobytes()), check)
            if check_rigid and np.all(np.isfinite(intended)):
                report = self.rigid_foldability()
                if not (report.rigid or report.residual <= self.precision):
                    raise NotRigidlyFoldableError(f"{self.name}: {report.summary()}", report)
        targets = intended if targets is None else targets
        targets = jnp.asarray(targets, dtype=jnp.result_type(float))
        if targets.shape != (m,):
            raise ValueError(
                f"targets must have one fold angle per crease ({m}), got shape {targets.shape}."
            )
        check_hinges_longer_than_film(design, targets, self.name)
        mechanism = self.mechanism(design)
        per_crease = eqx.tree_at(lambda d: d.theta_final, design, jnp.abs(targets) + 0.0)
        stiffness = per_crease.stiffness(m)
        hinges_ = Hinges(stiffness, targets, design.radius(), release_times)
        drag_model = PanelDrag.for_mechanism(
            mechanism,
            coefficient=design.drag_coefficient * design.b_scale,
            density=design.fluid.density,
            scale=0.5 if design.drag_model == "paper" else 1.0,
        )
        mechanism, drag_model = with_fluid_loads(
            mechanism,
            drag_model,
            design,
            stiffness,
            targets,
            added_mass=added_mass,
            viscous=viscous,
        )
        # The closure's rate against the fastest hinge with the inertia it moves (the fluid's
        # too): against the dry panels' it is ~20 times faster than anything in the bath, and the
        # stabilisation alone sets an explicit solver's step (the degree-4 vertex's 5000 µs in
        # KOH: 450 steps against 85, the loops closed to 2e-8 against 6e-8 rad).
        inertia = jnp.diagonal(mechanism.tree.mass_matrix(jnp.zeros(mechanism.n_tree)))
        rate = rate_factor * jnp.sqrt(jnp.max(stiffness) / jnp.min(inertia))
        mechanism = eqx.tree_at(lambda mech: mech.rate, mechanism, rate)
        contact_model = None
        kind = contact_kind(contact)
        check_sampling(kind, contact_sampling)
        if kind is not None:
            # The tables are the flat geometry's, computed on the host: from the design's own
            # panels, or the literature design's when its numbers are traced (a sweep's), as a
            # net's always are (`Net.contact_tables`).
            traced = is_traced(design)
            with jax.ensure_compile_time_eval():
                if traced:
                    geometric = HingeDesign.literature(design.units)
                    host, thickness = self.mechanism(geometric), geometric.t_structural
                else:
                    host, thickness = mechanism, design.t_structural
                # The exact polygons: the plate model's geometry, the sampled model's report.
                tables, plates = _contact_tables(host, thickness, contact_sampling, kind)
            # Stiffness and damping as `for_system` sets them, traceable in the hinges (a sweep
            # over hinge parameters builds contact inside `vmap`).
            extra = {} if kind == "plate" else {"plates": plates}
            model = PlateContact if kind == "plate" else PanelContact
            contact_model = model.for_system(
                mechanism, stiffness, targets, thickness=design.t_structural, tables=tables, **extra
            )
            contact_model = with_surface_physics(self, contact_model, kind, lambda: host)
        else:
            contact_model = with_surface_physics(self, None, None, lambda: None)
        return FoldingSystem(
            mechanism,
            hinges_,
            drag_model,
            contact=contact_model,
            units=design.units,
            agitation=self.agitation,
        )

    # ---- start state ----

    def start_state(
        self,
        system: FoldingSystem | None = None,
        *,
        bias: float = 0.0,
        direction: Float[ArrayLike, " m"] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Where a simulation starts: `(θ0, θ̇0)` (rad, rad/time).

        With `bias` = 0 (default) the flat state at rest, a bifurcation of a closed-loop pattern:
        the inputs pick the branch as the panels leave it. With `bias` > 0, a small pre-fold (a
        membrane is never quite flat): the closed state nearest ``bias · d̂``, ``d`` = `direction`
        (default the hinge targets of `system` weighted by stiffness and by which creases release
        first, or the pattern's angles), so ``|θ0| ≈ bias`` rad along the branch the inputs aim at.
        Where that nearest state falls to flat (a vertex whose branches leave flat far from ``d``:
        the waterbomb base), the state of norm `bias` down the branch from `direction` or, failing
        that, the targets at full fold.
        """
        m = self.n_creases
        if bias == 0.0:
            return np.zeros(m), np.zeros(m)
        if not bias > 0:
            raise ValueError(f"bias must be a small positive angle (rad), got {bias}.")
        folds = [self.intended_angles if system is None else np.asarray(system.hinges.target)]
        if direction is not None:
            folds.insert(0, direction)
        if direction is None:
            if system is None:
                direction = self.intended_angles
            else:
                h = system.hinges
                weight = np.asarray(h.stiffness)
                if h.release_time is not None:
                    times = np.asarray(h.release_time)
                    weight = weight * (times <= np.min(times))
                direction = weight * np.asarray(h.target)
        direction = np.asarray(direction, dtype=float)
        if direction.shape != (m,) or not np.linalg.norm(direction) > 0:
            raise ValueError(f"direction must be a non-zero vector of {m} fold angles.")
        guess = bias * direction / np.linalg.norm(direction)
        theta = self.closest_state(guess, keep_signs=True)
        if np.linalg.norm(theta) < _COLLAPSED * bias:
            # The nearest closed state fell to flat: a vertex whose branches leave flat far from
            # `direction` (the waterbomb base: 4e-9 rad for a 1e-3 pre-fold). Come down the
            # branch from the full fold instead.
            for fold in folds:
                along = self._down_the_branch(np.asarray(fold, dtype=float), bias)
                if along is not None:
                    theta = along
                    break
        directions, index = self._padded()
        if _kinematics.max_residual(directions, index, theta) > 1e-12:
            raise ValueError(
                f"could not place a closed start state {bias} rad along the given direction; use a "
                "smaller bias or another direction."
            )
        return theta, np.zeros(m)

    def _down_the_branch(self, fold: np.ndarray, bias: float) -> np.ndarray | None:
        """A closed state of norm `bias` on the branch through the closed state nearest `fold`
        (the hinges' targets, or a given direction, at the size of the pattern's angles), reached
        by shrinking it a step at a time (each step scaled by at most `_SHRINK` and brought back
        onto the loops, no crease crossing flat); `None` where the path falls to flat or leaves
        the branch's signs."""
        full = np.linalg.norm(self.intended_angles) * fold / np.linalg.norm(fold)
        theta = self.closest_state(full, keep_signs=True)
        signs = np.sign(theta)
        for _ in range(_SHRINK_STEPS):
            size = np.linalg.norm(theta)
            if not size > 0 or np.any(np.sign(theta) != signs):
                return None
            if size <= bias * (1 + 1e-9):
                break
            theta = self.closest_state(theta * max(_SHRINK, bias / size), keep_signs=True)
        else:
            return None
        return theta if np.linalg.norm(theta) >= _COLLAPSED * bias else None

    # ---- verdicts ----

    def panel_size(self, system: FoldingSystem | None = None) -> float:
        """The largest panel's size (design length units): what the verdict's seam tolerance is a
        fraction of (`origami_jax.simulation.VerdictTolerances`); the contact model's
        `tables.scale` when `system` has contact, else the same from its spanning tree's panels."""
        if system is not None and system.contact is not None:
            return float(system.contact.tables.scale)
        return self.net().panel_size()

    def seam_gap_function(self, system: FoldingSystem):
        """A traceable ``q ↦`` gap of each seam (design length units, `(s,)`), as for nets (the cut
        creases are not seams: the closure holds them together): a `SeamGaps`, which also names
        the two bodies each seam joins (for the verdict's seams closed by contact)."""
        return seam_gap_function(
            self.geometry.tree, self.seams, system.mechanism, self.length_scale
        )

    def outcome(self, system: FoldingSystem, trajectory, **kwargs):
        """`assess`'s verdict as arrays, traceable (`origami_jax.simulation.fold_outcome`)."""
        kwargs.setdefault("intended_angles", jnp.asarray(self.intended_angles))
        kwargs.setdefault("panel_size", self.panel_size(system))
        return fold_outcome(system, trajectory, seam_gaps=self.seam_gap_function(system), **kwargs)

    def assess(self, system: FoldingSystem, trajectory, *, bias: float = 0.0, **kwargs):
        """The verdict on a folding of this pattern (`origami_jax.simulation.assess`, keyword arguments
        go there), with the branch it took: a `LoopFoldReport`."""
        kwargs.setdefault("intended_angles", self.intended_angles)
        kwargs.setdefault("panel_size", self.panel_size(system))
        report = assess(system, trajectory, seam_gaps=self.seam_gap_function(system), **kwargs)
        return _with_branch(self, report, trajectory, bias)

    # ---- output ----

    def to_fold(
        self, trajectory=None, *, angles=None, times=None, every: int = 1, extras=None,
        key_extra=None,
    ) -> FoldFile:  # fmt: skip
        """The folding as a FOLD animation: the crease pattern (facets merged), then one frame per kept
        sample with every vertex where the folded panels put it and every crease's fold angle
        (`extras`, `key_extra`: see `Net.to_fold`)."""
        g = self.geometry
        return folding_animation(
            g.frame, g.fold, self.crease_edge_ids, vertex_corners(g.tree), self.name,
            trajectory=trajectory, angles=angles, times=times, every=every, extras=extras,
            key_extra=key_extra,
        )  # fmt: skip


def _with_branch(pattern: CreasePattern, report, trajectory, bias: float):
    return LoopFoldReport.from_report(pattern, report, trajectory, bias)


def _contact_tables(
    mechanism: LoopedPanels,
    thickness: float | Array,
    sampling=CONTACT_SAMPLING,
    kind: str = "sampled",
):
    """The contact geometry of a mechanism whose numbers are known, `(tables, plates)`: the model's
    tables (`PlateTables` for the `"plate"` model, else `ContactTables` for
    `PanelContact.for_system`) and the exact `PlateTables` (the same for the plate model). Panels that share a
    crease (tree or cut) or only a vertex do not meet near what they share; the sampled model's
    rims are inset by twice its edge width at the film `thickness`, `sampling` its
    ``(points_per_edge, rim_points_per_edge)`` (`build_tables`)."""
    n = mechanism.n_bodies
    layout = mechanism.hinge_layout()
    parents, children, ends = [layout.parent], [layout.child], [layout.ends]
    # Panels around an interior vertex that share only the vertex: a degenerate crease there.
    outlines = mechanism.outlines()
    poses = np.asarray(mechanism.body_poses(jnp.zeros(mechanism.n_hinges)))
    world = [o @ p[:3, :3].T + p[:3, 3] for o, p in zip(outlines, poses, strict=True)]
    base = mechanism.base_outline()
    if base is not None:
        world.append(np.asarray(base))
    size = max(float(np.max(np.ptp(w, axis=0))) for w in world)
    for point in np.asarray(mechanism.loop_points, dtype=float).reshape(-1, 3):
        touching = [
            b
            for b, w in enumerate(world)
            if np.min(np.linalg.norm(w - point, axis=-1)) < 1e-9 * size
        ]
        bodies = [b if b < n else -1 for b in touching]
        for i, a in enumerate(bodies):
            for b in bodies[i + 1 :]:
                parents.append(np.array([min(a, b)]))
                children.append(np.array([max(a, b)]))
                ends.append(np.stack([point, point])[None])
    layout_args = (np.concatenate(parents), np.concatenate(children), np.concatenate(ends))
    plates = build_plate_tables(outlines, poses, base, *layout_args)
    if kind == "plate":
        return plates, plates
    thickness = float(np.asarray(thickness))
    points_per_edge, rim_points_per_edge = sampling_pair(sampling)
    probe = PanelContact.from_mechanism(
        mechanism, thickness=thickness, stiffness=1.0, damping=0.0, plates=plates
    )
    return build_tables(
        outlines,
        poses,
        base,
        *layout_args,
        inset=2 * float(probe.edge_width),
        points_per_edge=points_per_edge,
        rim_points_per_edge=rim_points_per_edge,
    ), plates


def load_pattern(
    pattern: str | os.PathLike | FoldFile,
    *,
    root: int | None = None,
    length_scale: float | None = None,
    units=None,
    name: str | None = None,
    flat_creases: str = "panel",
):
    """Read a crease pattern: a catalogue name (`origami_jax.fold.catalogue_names()`), a `.fold` path
    or a `FoldFile`. A pattern whose faces form a tree (a net) gives a `Net` (the panel-tree engine,
    `origami_jax.net.load_net`); one whose creases close loops around interior vertices gives a
    `CreasePattern`. A file that holds a folded form only (3D, no flat frame) is read as the crease
    pattern it unfolds to, each crease's target its dihedral angle in the form
    (`origami_jax.fold.unfold_folded_form`).

    **Arguments:** `root`: the fixed face (default the largest); `length_scale`: design length units
    per FOLD length unit (default from the file's `frame_unit`; a unitless file, such as Origami
    Simulator's export, needs it); `units` (default `MICRO`); `name`; `flat_creases`: `"panel"`
    (faces joined by flat `F` edges, the facet diagonals of a triangulated export, are one rigid
    panel, in a net as in a closed-loop pattern: the net is then read from the merged faces, its
    edges renumbered, `root` still a face of the file; default) or `"hinge"` (every `F` edge is a
    crease with a 0° target).

    **Raises:** `FoldFormatError` for a file that is neither (loops round holes, non-manifold
    edges, ...); `ValueError` for a unitless file without `length_scale`.
    """
    check_loader_arguments(root, length_scale)
    units = MICRO if units is None else units
    label = name
    if isinstance(pattern, FoldFile):
        fold = pattern
    else:
        path, label = source_and_label(pattern, label)
        fold = read_fold(path)
    unfolded = flat_fold(fold, root=root)
    geometry = loop_geometry(unfolded, root=root, flat_creases=flat_creases)
    precision = 0.0
    if unfolded is not fold and geometry.n_loops:
        unfolded, precision = _closed_targets(unfolded, geometry, label)
        geometry = loop_geometry(unfolded, root=root, flat_creases=flat_creases)
    fold = unfolded
    if geometry.n_loops == 0:
        try:
            return load_net(
                fold, root=root, length_scale=length_scale, units=units, name=label,
                flat_creases=flat_creases,
            )  # fmt: skip
        except FoldFormatError:
            if flat_creases == "hinge":
                raise
            # facets merged make it a net of panels without loops: fold it as one
    if length_scale is None:
        length_scale = length_scale_from_unit(geometry.unit, units.metre_per_length)
    return CreasePattern(geometry, label or "pattern", float(length_scale), precision)


def _closed_targets(fold: FoldFile, geometry, label) -> tuple[FoldFile, float]:
    """An unfolded form's fold angles moved onto the nearest state where its loops close, and the
    precision of that closure (rad; 0 when it closes to `RIGID_TOL`). A form's
    coordinates are written to a few digits: its dihedral angles close the loops only to that
    rounding, and its sector angles carry it too, so an overconstrained pattern closes only to
    about it whatever the angles. Twice the residual that is left is the pattern's `precision`.
    Left as they are when the form misses closing by more than `FORM_CLOSURE_TOL` (not a rigid
    state; `check_angles` says so)."""
    pattern = CreasePattern(geometry, label or "pattern", 1.0)
    targets = np.asarray(geometry.targets, dtype=float)
    residual = float(np.max(pattern.closure_residual(targets)))
    if residual > FORM_CLOSURE_TOL:
        return fold, 0.0
    closed = _kinematics.close_nearby(*pattern._padded(), targets)
    left = float(np.max(pattern.closure_residual(closed)))
    frame = fold.key_frame
    degrees = np.array(frame.edges_fold_angle_deg, dtype=float)
    for j, edges in enumerate(geometry.crease_edges):
        degrees[list(edges)] = np.degrees(closed[j])
    frame = frame.replace(edges_fold_angle_deg=degrees)
    closed_fold = FoldFile(
        frames=(frame,), file_spec=fold.file_spec, file_metadata=fold.file_metadata
    )
    return closed_fold, 2.0 * left if left > _kinematics.RIGID_TOL else 0.0


def release_times_from_front(pattern: CreasePattern, direction, speed: float) -> np.ndarray:
    """Release times (time units, `(m,)`) of an etch front sweeping the sheet at `speed` (design length
    units per time unit) along `direction` (2 components in the pattern's plane basis, or 3): it starts
    at the pattern's first point along that direction at ``t = 0`` and releases each crease when it
    reaches the crease's midpoint (as `origami_jax.net.release_times_from_front`)."""
    g = pattern.geometry
    direction = unit_front_direction(direction, g.plane, speed)
    mids = g.points + 0.5 * g.lengths[:, None] * g.axes
    return front_release(g.vertices_coords, mids, direction, pattern.length_scale, float(speed))


def PatternLayout(pattern: CreasePattern, **options) -> CreasePattern:  # noqa: N802 (the former class)
    """`pattern` with the physics options of its systems (`CreasePattern.with_model`): the layout
    that `design` and `sweep` rebuild, ``PatternLayout(pattern, contact=False)(design)`` is
    ``pattern.system(design, contact=False)``. Kept for the former `PatternLayout` class: a
    pattern is its own layout."""
    return pattern.with_model(**options)
