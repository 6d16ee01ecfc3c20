"""A self-folding net from a FOLD crease pattern: its folding system, its verdict, its FOLD frames.

`load_net("cube_net_01")` (a catalogue name or a `.fold` path) reads the crease pattern's tree of faces
(`origami_jax.fold.net_geometry`); `net.system(design)` builds the [`origami_jax.system.FoldingSystem`][]:

- the root face is the fixed base (it stays on the substrate); every other face is a rigid plate of
  the design's structural film (thickness ``t₁``, its density), hinged to its parent along their crease
  ([`origami_jax.net.PanelTree`][]), point creases or bending arcs;
- each crease's hinge is the design's bilayer, made to fold to that crease's angle: stiffness
  ``k = w (E₁'t₁³ + E₂'t₂³) / (c l)`` with hinge length ``l = ρ |θ_target|`` per crease, bending radius ``ρ``
  from the films (`HingeDesign`, paper Eqs. 7 and 11); the targets are the pattern's fold angles unless
  given;
- drag on every panel from its own motion ([`origami_jax.fluid.PanelDrag`][], ``C_D`` and the fluid of
  the design; the paper's ``/16`` normalisation when the design's `drag_model` is `"paper"`), or the
  paper's per-hinge drag;
- contact between panels and with the base ([`origami_jax.contact.PanelContact`][]), on by default.

`net.assess(system, trajectory)` judges the folding against the *pattern's* fold angles and seams (a net
whose hinges aim at 80° is not a folded cube); `net.to_fold(trajectory)` writes it as FOLD frames.
Lengths: the FOLD file's `frame_unit` is converted into the design's unit system.
"""

import dataclasses
import os
from collections.abc import Sequence
from typing import Any, ClassVar, final

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._limits import CONTACT_SAMPLING
from .._math import safe_norm
from .._validate import is_traced
from ..contact import (
    Adhesion,
    Friction,
    PanelContact,
    PlateContact,
    check_sampling,
    contact_kind,
    sampling_pair,
)
from ..fluid import PanelDrag
from ..fold import (
    FoldFile,
    FoldFrame,
    NetGeometry,
    flat_faces_merged,
    flat_fold,
    length_scale_from_unit,
    net_geometry,
    read_fold,
    source_and_label,
)
from ..simulation import SeamGaps, assess, fold_outcome
from ..system import MICRO, Agitation, FoldingSystem, HingeDesign, HingeDrag, Hinges
from ._fillet import ArcLayout, fillet_layout, fillet_plate_tables, layout_of
from ._kernel import check_agitation_balanced
from ._pattern import (
    AbstractPanelPattern,
    HostCache,
    check_hinges_longer_than_film,
    check_loader_arguments,
    check_per_crease,
    check_physics_options,
    default_design,
    front_release,
    unit_front_direction,
    warn_if_hinges_wider_than_creases,
    with_fluid_loads,
    with_surface_physics,
)
from ._strip import StripTree, strip_tree
from ._strips import check_strip_radius, drawn_layout, strip_drawing
from ._tree import PanelTree, panel_tree

# The physics options of a net (`Net.with_model`) and their defaults: `Net.system`'s.
NET_MODEL = {
    "contact": True,
    "drag": "panel",
    "hinges": "point",
    "added_mass": None,
    "viscous": None,
    "contact_sampling": CONTACT_SAMPLING,
    "adhesion": None,
    "friction": None,
    "release_ramp": "auto",
    "agitation": None,
}


@final
@dataclasses.dataclass(frozen=True, eq=False)
class Net(AbstractPanelPattern):
    """A flat net of panels read from FOLD, ready to become folding systems (module docstring); an
    [`origami_jax.system.AbstractPattern`][].

    **Fields:** `geometry` (the `NetGeometry`, lengths in the FOLD file's unit), `name`,
    `length_scale` (design length units per FOLD length unit), `key_frame` (the crease pattern as a
    FOLD frame) and `crease_edge_ids` (its edges on each crease). `seams`: those that close at the
    pattern's fold angles. The physics model its systems take unless `system` is told otherwise
    (`with_model`): `contact` (default `True`: the plate model), `drag` (`"panel"`), `hinges`
    (`"point"`), `added_mass`, `viscous` (`None`: on in a liquid — the etch bath —, off in a gas;
    `True`/`False` either way), `contact_sampling` (`(4, 2)`), `adhesion` and `friction` (`None`:
    off; an `origami_jax.contact.Adhesion` or `Friction` attaches it to the plate contact), as
    `system` documents them; `release_ramp` (`"auto"`: released quasi-statically where the system
    carries the fluid's inertia, at once otherwise; `None`: the paper's step; a time, µs: each
    hinge's torque grows over it from its release; `release_ramp_for`). `drawn_layout`: for a
    net drawn with its hinge strips (`load_net`, the FOLD face property
    ``faces_origami_jax:hinge``), the strips as drawn (an `ArcLayout`), which its arc systems take
    unless told otherwise; `None` for a net drawn for point creases. `agitation` (`None`: off): an
    `origami_jax.system.Agitation`, the bath's random forcing (Langevin, in balance with the
    fluid's viscous drag, so it needs `viscous` on), which its systems carry; a sweep or yield
    draws each member's noise from its key and the member's `noise_seed`, and folds with the
    fixed-step engine (`ImplicitStep`).

    Hinge ``j`` of the systems it builds is the geometry's crease ``j``; body ``j`` is face
    ``geometry.order[j + 1]``; the root face is the fixed base.
    """

    geometry: NetGeometry
    name: str
    length_scale: float
    key_frame: FoldFrame
    crease_edge_ids: tuple[tuple[int, ...], ...]
    host_cache: HostCache = dataclasses.field(default_factory=HostCache, repr=False)
    contact: bool | str = True
    drag: str = "panel"
    hinges: str = "point"
    added_mass: bool | None = None
    viscous: bool | None = None
    contact_sampling: tuple[int, int] = CONTACT_SAMPLING
    adhesion: Adhesion | None = None
    friction: Friction | None = None
    drawn_layout: ArcLayout | None = None
    release_ramp: float | str | None = "auto"
    agitation: Agitation | None = None

    MODEL: ClassVar[dict[str, Any]] = NET_MODEL

    def __post_init__(self):
        check_physics_options(self)

    @property
    def continues_from_angles(self) -> bool:
        return True  # a panel tree's state is its hinge angles and rates

    @classmethod
    def from_geometry(cls, geometry: NetGeometry, name: str, length_scale: float) -> "Net":
        """The net of a tree of faces (`origami_jax.fold.NetGeometry`, lengths in its FOLD unit,
        `length_scale` design length units per FOLD unit), its crease pattern frame drawn from the
        geometry: a closed-loop pattern's spanning tree (`CreasePattern.net`)."""
        key, edges = key_frame(geometry, name)
        return cls(geometry, name, length_scale, key, edges)

    def start_state(self, system: FoldingSystem | None = None, *, bias: float = 0.0):
        """Where a simulation starts: flat, at rest (`(θ0, θ̇0)`, zeros `(m,)`). A net folds from
        flat: `bias` must be 0. **Raises:** `ValueError` for another `bias`."""
        if bias:
            raise ValueError(
                f"{self.name} is a net (a tree of panels), which starts flat: bias pre-folds "
                "closed-loop patterns only."
            )
        m = self.n_creases
        return np.zeros(m), np.zeros(m)

    def release_times_from_front(self, direction, speed: float) -> np.ndarray:
        """Release times of an etch front (`origami_jax.net.release_times_from_front`)."""
        return release_times_from_front(self, direction, speed)

    def resume_settings(self) -> dict:
        """What a stored sweep of this net records: its name and its closed loops (none)."""
        return {"net": self.name, "closed_loops": 0}

    @property
    def intended_angles(self) -> np.ndarray:
        """The pattern's fold angles (rad, `(m,)`): the shape a correct folding reaches."""
        return np.asarray(self.geometry.targets, dtype=float)

    @property
    def seams(self):
        return self.geometry.target_seams

    @property
    def crease_lengths(self) -> np.ndarray:
        """Each crease's length (the design's length units, µm by default; `(m,)`)."""
        return np.asarray(self.geometry.crease_lengths, dtype=float) * self.length_scale

    def tree(
        self,
        design: HingeDesign,
        *,
        hinges: str = "point",
        targets: Float[ArrayLike, " m"] | None = None,
        arc_layout: "str | ArcLayout | None" = None,
        layout_design: HingeDesign | None = None,
    ) -> PanelTree | StripTree:
        """The panels as a `PanelTree` in the design's units (plates of thickness ``t₁``); with
        `hinges="arc"` a `StripTree`: bending strips carrying their own mass (areal density
        ``ρ₁t₁ + ρ₂t₂``, width the design's `hinge_width`), laid out by `arc_layout`
        (`system`: `"fillet"`, the panels trimmed and moved for their strips, lengths
        ``ρ|θ|`` of `layout_design`'s ``ρ``; an `ArcLayout` drawn before; or `"drawn"`, strips of
        length ``ρ |θ_target|`` at the drawn creases; default the net's `drawn_layout`, else
        `"fillet"`)."""
        arc_layout = self.default_arc_layout if arc_layout is None else arc_layout
        g = self.geometry
        scale = self.length_scale
        order = np.asarray(g.order)
        body_parents = np.asarray(g.body_parents)[1:] - 1  # the root is the fixed base
        outlines = [g.face_coords[f][g.corner_mask[f]] * scale for f in order[1:]]
        base = g.face_coords[order[0]][g.corner_mask[order[0]]] * scale
        points = g.hinge_points * scale
        hinge_lengths = None
        if hinges == "arc":
            angles = self.intended_angles if targets is None else targets
            if isinstance(arc_layout, ArcLayout) or arc_layout == "fillet":
                layout = (
                    arc_layout
                    if isinstance(arc_layout, ArcLayout)
                    else self.arc_layout(layout_design or design, angles)
                )
                base, outlines = layout.outlines(g)
                points, hinge_lengths = layout.hinge_points, layout.lengths
            elif arc_layout == "drawn":
                hinge_lengths = design.radius() * jnp.abs(jnp.asarray(angles))
            else:
                raise ValueError(
                    f"arc_layout must be 'fillet', 'drawn' or an ArcLayout, got {arc_layout!r}."
                )
        elif hinges != "point":
            raise ValueError(f"hinges must be 'point' or 'arc', got {hinges!r}.")
        tree = panel_tree(
            tuple(int(p) for p in body_parents),
            g.hinge_axes,
            points,
            outlines,
            thickness=design.t_structural,
            density=design.structural.density,
            base_outline=base,
            hinge_lengths=hinge_lengths,
        )
        if hinges == "point":
            return tree
        return strip_tree(
            tree,
            areal_density=design.strip_areal_density(),
            width=design.hinge_width,
            thickness=design.t_structural + design.t_hinge,
        )

    @property
    def default_arc_layout(self) -> "str | ArcLayout":
        """Where arc hinges go unless told: the strips as drawn (`drawn_layout`) for a net drawn
        with them, else `"fillet"`."""
        return "fillet" if self.drawn_layout is None else self.drawn_layout

    def arc_layout(self, design: HingeDesign, angles: ArrayLike | None = None) -> ArcLayout:
        """The net laid out for bending strips of `design`'s radius ``ρ`` folding to `angles`
        (rad, default the pattern's): panels trimmed by ``ρ tan(|θ|/2)`` at each crease and
        moved apart by their strips (`origami_jax.net.fillet_layout`); host geometry, computed
        once per radius and angles and kept.

        **Raises:** `ValueError` when the radius or the angles are traced (lithography draws the
        layout once: give the nominal design as `layout_design` to `system`), and as
        `fillet_layout`."""
        angles = self.intended_angles if angles is None else angles
        with jax.ensure_compile_time_eval():  # a concrete design's radius, even under `jit`
            radius = design.radius()
        if is_traced(radius) or is_traced(angles):
            raise ValueError(
                "the fillet layout is drawn once, on the host, for one radius and one set of "
                "angles: give a concrete nominal design as layout_design= (and concrete targets), "
                "or arc_layout='drawn'."
            )
        radius = np.broadcast_to(np.asarray(radius, dtype=float), (self.n_creases,))
        angles = np.asarray(angles, dtype=float)
        key = ("fillet", tuple(radius.tolist()), tuple(angles.tolist()))
        return self.host_cache.get(
            key, lambda: fillet_layout(self.geometry, self.length_scale, radius, angles)
        )

    def system(
        self,
        design: HingeDesign | None = None,
        *,
        targets: Float[ArrayLike, " m"] | None = None,
        release_times: Float[ArrayLike, " m"] | Sequence[float] | None = None,
        contact: bool | str | None = None,
        drag: str | None = None,
        hinges: str | None = None,
        arc_layout: "str | ArcLayout | None" = None,
        layout_design: HingeDesign | None = None,
        added_mass: bool | None = None,
        viscous: bool | None = None,
        contact_sampling: tuple[int, int] | None = None,
    ) -> FoldingSystem:
        """The folding system of this net with the hinges, films and fluid of `design`.

        **Arguments** (the design's units, `MICRO` by default: µm, µs, ng):
        - `design`: a `HingeDesign` (default `HingeDesign.literature()`, each hinge at most as
          wide as its crease: `hinges_within_creases`); its `hinge_width` is each hinge's width
          (scalar or one per crease; a hinge wider than its crease is warned about), its
          `theta_final` is not used: each crease's hinge folds to its own target.
        - `targets`: fold target per crease (rad); default the pattern's angles.
        - `release_times`: per-crease release time (time units); default all at ``t = 0``.
        - `contact`: panels meet instead of passing through each other (default) or not (`False`);
          which model: `"plate"` (the default: exact plate geometry, continuous collision detection,
          `origami_jax.contact.PlateContact`) or `"sampled"` (points sampled on every panel's rings
          and rim, `origami_jax.contact.PanelContact`: cheaper, but corners and the stretches of
          edge between its points are not checked).
        - `contact_sampling`: the `"sampled"` model's ``(points_per_edge, rim_points_per_edge)``, how densely each panel's
          inner ring and rim are sampled for contact (`origami_jax.contact.build_tables`; default
          ``(4, 2)``). Each point carries its share of the ring's or rim's length, so a denser
          sampling resolves the same contact more finely: fold again with, e.g., ``(16, 12)`` to
          check that a verdict decided where edges meet does not depend on it (the contact then
          costs about as many times more as it has points).
        - `drag`: `"panel"` (each panel's own motion, `PanelDrag`; default) or `"hinge"` (the paper's
          ``−b θ̇|θ̇|`` per hinge with ``b`` from the child panel's area and its reach from the crease).
        - `hinges`: `"point"` creases (the paper's model) or bending `"arc"`s of length ``ρ|θ_target|``
          with their strips' own mass (`StripTree`).
        - `arc_layout` (arc hinges only): where the strips go in the flat net. `"fillet"` (default):
          each panel trimmed by ``ρ tan(|θ|/2)`` at each crease and the strips, ``ρ|θ|`` long,
          between the trimmed edges, so that folded to its targets every panel lies where the point
          creases put it and the seams close (`Net.arc_layout`, docs/physics.md "The hinge is a
          bending arc"); `"drawn"`: the strips start at the drawn creases and each child hangs
          at its strip's end, displaced from the point-crease shape (a cube's seams stay open by
          ~ρ√2); or an `ArcLayout`. A net read from a file drawn with its hinge strips
          (`drawn_layout`) takes them as drawn by default: the panels where the file puts them,
          each strip as long as it is wide in the file (`"fillet"` and `"drawn"` then lay out the
          point-crease net the strips fillet).
        - `layout_design`: the design whose radius ``ρ`` draws the fillet layout (lithography: the
          nominal one), with `targets` (the pattern's angles when `targets` is traced); default
          `design`. A sample whose films bend more or less then folds off the layout's shape. For
          strips drawn in the file, the design they must be drawn for: a radius ``ρ`` off their
          ``w/|θ|`` by more than 1 % is refused (`ValueError`).
        - `added_mass`, `viscous`: the fluid's inertia on every panel and its viscous drag (strip
          theory across each crease, Sader's hydrodynamic function at each hinge's frequency;
          `origami_jax.fluid.fluid_loads`, docs/physics.md "The fluid moves with the flap"). By
          default (`None`) on in a liquid (`design.fluid.liquid`: the etch bath, where the
          fluid's inertia is hundreds of times the panels' and makes their motion milliseconds
          slow) and off in a gas (air's is a few tenths of the panels' and the paper leaves it
          out); `False` is the paper's model in the bath. A net that carries the fluid's inertia
          is released quasi-statically by default (`release_ramp_for`): released at once, its
          panels would be flung past their targets by the torque they cannot yet feel resisted.

        The physics options (`contact` to `contact_sampling`) left `None` are the net's own
        (its fields; `with_model`). Adhesion and friction are the net's only (`with_model(adhesion=
        Adhesion(...), friction=Friction(...))`, off by default): they act at the plate contact
        (`PlateContact.with_surface`); so is agitation (`with_model(agitation=Agitation(...))`,
        carried by the system: `simulate` then solves a stochastic equation, which needs the
        fluid's viscous drag, `viscous`).
        """
        contact = self.contact if contact is None else contact
        arc_layout = self.default_arc_layout if arc_layout is None else arc_layout
        drag = self.drag if drag is None else drag
        hinges = self.hinges if hinges is None else hinges
        if contact_sampling is None:
            contact_sampling = self.contact_sampling
        lengths = self.crease_lengths
        if design is None:
            design = default_design(self)
        added_mass, viscous = self.fluid_inertia(design, added_mass=added_mass, viscous=viscous)
        check_agitation_balanced(self, viscous)
        m = self.n_creases
        targets = self.intended_angles if targets is None else targets
        targets = jnp.asarray(targets, dtype=jnp.result_type(float))
        if targets.shape != (m,):
            raise ValueError(
                f"targets must have one fold angle per crease ({m}), got shape {targets.shape}."
            )
        if not np.all(np.isfinite(np.asarray(targets))) if not is_traced(targets) else False:
            raise ValueError(
                "every crease needs a finite target: give edges_foldAngle in the FOLD file or "
                "targets= (rad)."
            )
        check_per_crease(design, m)
        warn_if_hinges_wider_than_creases(self.name, design, lengths)
        check_hinges_longer_than_film(design, targets, self.name)
        if not isinstance(arc_layout, ArcLayout) and arc_layout not in ("fillet", "drawn"):
            raise ValueError(
                f"arc_layout must be 'fillet', 'drawn' or an ArcLayout, got {arc_layout!r}."
            )
        layout = "drawn"
        if hinges == "arc" and arc_layout != "drawn":
            layout = (
                arc_layout
                if isinstance(arc_layout, ArcLayout)
                else self.arc_layout(
                    layout_design or design, None if is_traced(targets) else targets
                )
            )
        if hinges == "arc" and layout is self.drawn_layout:
            # The strips' widths are the file's: the (nominal) design must bend to their radius.
            check_strip_radius(layout, layout_design or design, self.name)
        if isinstance(layout, ArcLayout):  # kept: the seam gaps find it (`_layout_of`)
            self.host_cache.get(("kept", id(layout)), lambda: layout)
        tree = self.tree(design, hinges=hinges, targets=targets, arc_layout=layout)
        # Each crease's bilayer folds to its own target: hinge length ρ |θ_target|.
        per_crease = eqx.tree_at(lambda d: d.theta_final, design, jnp.abs(targets) + 0.0)
        stiffness = per_crease.stiffness(m)
        hinges_ = Hinges(stiffness, targets, design.radius(), release_times)
        if drag == "panel":
            drag_model = PanelDrag.for_mechanism(
                tree,
                coefficient=design.drag_coefficient * design.b_scale,
                density=design.fluid.density,
                scale=0.5 if design.drag_model == "paper" else 1.0,
            )
        elif drag == "hinge":
            drag_model = HingeDrag(_hinge_drag(tree, design))
        else:
            raise ValueError(f"drag must be 'panel' or 'hinge', got {drag!r}.")
        tree, drag_model = with_fluid_loads(
            tree, drag_model, design, stiffness, targets, added_mass=added_mass, viscous=viscous
        )
        contact_model = None
        kind = contact_kind(contact)
        check_sampling(kind, contact_sampling)
        if kind is not None:
            geometry = (
                {"tables": self.plate_tables(hinges, arc_layout=layout)}
                if kind == "plate"
                else {
                    "tables": self.contact_tables(
                        hinges, sampling=contact_sampling, arc_layout=layout
                    ),
                    "plates": self.plate_tables(hinges, arc_layout=layout),
                }
            )
            model = PlateContact if kind == "plate" else PanelContact
            contact_model = model.for_system(
                tree,
                stiffness,
                targets,
                thickness=design.t_structural,
                base_thickness=design.t_structural,
                **geometry,
            )
        contact_model = with_surface_physics(
            self,
            contact_model,
            kind,
            lambda: self.tree(HingeDesign.literature(), hinges=hinges, arc_layout=layout),
        )
        return FoldingSystem(
            tree,
            hinges_,
            drag_model,
            contact=contact_model,
            units=design.units,
            agitation=self.agitation,
        )

    def contact_tables(
        self,
        hinges: str = "point",
        *,
        sampling: tuple[int, int] = CONTACT_SAMPLING,
        arc_layout: "str | ArcLayout" = "drawn",
    ):
        """The panels' contact geometry (`origami_jax.contact.ContactTables`), computed once on the
        host from the pattern (it depends on the geometry only, not on the design's numbers).
        `sampling`: ``(points_per_edge, rim_points_per_edge)``, as `system`'s `contact_sampling`;
        `arc_layout`: the panels of an `ArcLayout` (`arc_layout`) or as drawn."""
        points_per_edge, rim_points_per_edge = sampling_pair(sampling)
        return self._host_tables(
            (hinges, points_per_edge, rim_points_per_edge),
            lambda tree: PanelContact.tables_for(
                tree, points_per_edge=points_per_edge, rim_points_per_edge=rim_points_per_edge
            ),
            arc_layout,
        )

    def plate_tables(self, hinges: str = "point", *, arc_layout: "str | ArcLayout" = "drawn"):
        """The panels' exact plate geometry (`origami_jax.contact.PlateTables`), computed once on
        the host from the pattern (geometry only, not the design's numbers); `arc_layout`: the
        panels of an `ArcLayout` (`arc_layout`) or as drawn."""
        build = PlateContact.tables_for
        if hinges == "arc" and isinstance(arc_layout, ArcLayout):

            def build(tree):
                return fillet_plate_tables(tree, arc_layout, self.geometry, self.seams)

        return self._host_tables((hinges, "plate"), build, arc_layout)

    def _host_tables(self, key: tuple, build, arc_layout: "str | ArcLayout" = "drawn"):
        """`build(tree)` of the literature design's tree with `key[0]`'s hinges (an arc tree's
        panels where `arc_layout` puts them), computed once per `key` and layout and kept in the
        `host_cache` (host geometry, whatever the design's numbers)."""
        fillet = key[0] == "arc" and isinstance(arc_layout, ArcLayout)
        if fillet:  # keyed by identity, and kept alive with its tables
            self.host_cache.get(("kept", id(arc_layout)), lambda: arc_layout)
            key = (*key, id(arc_layout))

        def tables():
            with jax.ensure_compile_time_eval():
                tree = self.tree(
                    HingeDesign.literature(),
                    hinges=key[0],
                    arc_layout=arc_layout if fillet else "drawn",
                )
                return build(tree)

        return self.host_cache.get(("tables", *key), tables)

    def seam_gaps(self, angles: ArrayLike | Sequence[float]) -> np.ndarray:
        """Largest end-to-end gap of each seam with the creases at `angles` (rad), in design length
        units (host, rigid folding of the flat pattern).

        **Raises:** `ValueError` unless `angles` holds one finite angle per crease."""
        angles = np.asarray(angles, dtype=float)
        if angles.shape != (self.n_creases,):
            raise ValueError(
                f"angles must hold one fold angle per crease, shape ({self.n_creases},), got "
                f"{angles.shape}."
            )
        if not np.all(np.isfinite(angles)):
            raise ValueError(f"angles must be finite (rad), got {angles.tolist()}.")
        positions = self.geometry.fold(angles)
        return self.geometry.seam_gaps(positions, self.seams) * self.length_scale

    def panel_size(self, system: FoldingSystem | None = None) -> float:
        """The largest panel's size (design length units): what the verdict's seam tolerance is a
        fraction of (`origami_jax.simulation.VerdictTolerances`); the contact model's
        `tables.scale` when `system` has contact, else the same from the net's geometry."""
        if system is not None and system.contact is not None:
            return float(system.contact.tables.scale)
        return float(self.plate_tables().scale)

    def seam_gap_function(self, system: FoldingSystem) -> "SeamGaps":
        """A traceable ``q ↦`` gap of each seam (design length units, `(s,)`) for a system this net
        built: the larger distance between the two sides' corners at either end of the seam, from
        the mechanism's body poses; a `SeamGaps`, which also names the two bodies each seam joins
        (for the verdict's seams closed by contact)."""
        mechanism = system.mechanism
        layout = self._layout_of(mechanism)
        points = None if layout is None else layout.seam_points
        return seam_gap_function(
            self.geometry, self.seams, mechanism, self.length_scale, points=points
        )

    def _layout_of(self, mechanism) -> ArcLayout | None:
        """The kept `ArcLayout` whose panels `mechanism` has, or `None` (`layout_of`)."""
        kept = [x for x in self.host_cache.values() if isinstance(x, ArcLayout)]
        return layout_of(kept, self.geometry, mechanism)

    def assess(self, system: FoldingSystem, trajectory, *, bias: float = 0.0, **kwargs):
        """The verdict on a folding of this net against the pattern's angles and seams
        (`origami_jax.simulation.assess`; keyword arguments go there). `bias`: the start's
        pre-fold, 0 for a net (`start_state`)."""
        self.start_state(bias=bias)  # a net starts flat: refuses another bias
        kwargs.setdefault("intended_angles", self.intended_angles)
        kwargs.setdefault("panel_size", self.panel_size(system))
        return assess(system, trajectory, seam_gaps=self.seam_gap_function(system), **kwargs)

    def outcome(self, system: FoldingSystem, trajectory, **kwargs):
        """`assess`'s verdict as arrays, traceable (`origami_jax.simulation.fold_outcome`); called
        on one concrete run it runs as one compiled program per model structure and power of two
        of samples, whatever the run and the tolerances."""
        kwargs.setdefault("intended_angles", jnp.asarray(self.intended_angles))
        kwargs.setdefault("panel_size", self.panel_size(system))
        return fold_outcome(system, trajectory, seam_gaps=self.seam_gap_function(system), **kwargs)

    def to_fold(
        self, trajectory=None, *, angles=None, times=None, every: int = 1, extras=None,
        key_extra=None,
    ) -> FoldFile:  # fmt: skip
        """The folding as a FOLD animation: the crease pattern, then one frame per kept sample with
        every vertex where the folded panels put it (in the FOLD file's unit) and the fold angles.

        Give a `Trajectory` (its `theta`, `times`) or `angles` `(k, m)` (rad) and optional `times`;
        `extras` (one dict per sample) and `key_extra` add `origami_jax:` properties to the frames
        and to the crease pattern (`folding_animation`).
        """
        corners = vertex_corners(self.geometry)
        return folding_animation(
            self.key_frame, self.geometry.fold, self.crease_edge_ids, corners, self.name,
            trajectory=trajectory, angles=angles, times=times, every=every, extras=extras,
            key_extra=key_extra,
        )  # fmt: skip


def frame_assignment(key_assignment, degrees: np.ndarray, crease_edges) -> tuple[str, ...]:
    """Each edge's assignment in a frame of a folding: a crease folded to the other side of flat than
    the pattern assigns it (a valley that dips below flat while its neighbours swing, an overshoot
    past 180° wrapped to the mountain side) is written as what it is in that frame, `M` or `V`, so
    that the frame's fold angles and assignments agree (FOLD: valley +, mountain −)."""
    out = list(key_assignment)
    for edges in crease_edges:
        for e in edges:
            if degrees[e] > 0:
                out[e] = "V"
            elif degrees[e] < 0:
                out[e] = "M"
    return tuple(out)


def vertex_corners(g: NetGeometry) -> tuple[np.ndarray, np.ndarray]:
    """For every FOLD vertex, a (face, corner) that holds it (folded positions agree across a
    crease, and a vertex on a seam only belongs to one face's side of it)."""
    n = len(g.vertices_coords)
    face_of = np.full(n, -1)
    corner_of = np.full(n, -1)
    for f, vertices in enumerate(g.faces):
        for k, v in enumerate(vertices):
            if face_of[v] < 0:
                face_of[v], corner_of[v] = f, k
    return np.maximum(face_of, 0), np.maximum(corner_of, 0)


def key_frame(g: NetGeometry, name: str) -> tuple[FoldFrame, tuple[tuple[int, ...], ...]]:
    """A crease-pattern frame built from the faces (when no FOLD file is at hand), and the edges on
    each crease: a side shared by a crease's two faces."""
    sides: dict[tuple[int, int], set[int]] = {}
    for f, vertices in enumerate(g.faces):
        for a, b in zip(vertices, vertices[1:] + vertices[:1], strict=True):
            sides.setdefault((min(a, b), max(a, b)), set()).add(f)
    edges = sorted(sides)
    crease_of = {}
    for j, (child, parent) in enumerate(zip(g.crease_child, g.crease_parent, strict=True)):
        crease_of[frozenset((int(child), int(parent)))] = j
    on_crease: list[list[int]] = [[] for _ in range(g.n_creases)]
    assignment, degrees = [], []
    for e, pair in enumerate(edges):
        j = crease_of.get(frozenset(sides[pair])) if len(sides[pair]) == 2 else None
        if j is None:
            assignment.append("B")
            degrees.append(0.0)
        else:
            on_crease[j].append(e)
            angle = float(np.degrees(g.targets[j]))
            assignment.append("V" if angle > 0 else "M" if angle < 0 else "F")
            degrees.append(angle)
    frame = FoldFrame(
        vertices_coords=g.vertices_coords,
        edges_vertices=np.array(edges),
        edges_assignment=tuple(assignment),
        edges_fold_angle_deg=np.array(degrees),
        faces_vertices=tuple(tuple(int(v) for v in f) for f in g.faces),
        frame_unit=g.unit,
        frame_classes=("creasePattern",),
        frame_attributes=("2D",),
        extra={"frame_title": name},
    )
    return frame, tuple(tuple(e) for e in on_crease)


def _hinge_drag(tree: PanelTree | StripTree, design: HingeDesign) -> Array:
    """The paper's ``b = C_D ν A L³ / c`` per hinge, for a polygonal child panel: ``A`` its area and
    ``L`` its farthest reach from the crease."""
    if isinstance(tree, StripTree):
        tree = tree.panels
    layout = tree.hinge_layout()
    b = []
    for i, outline in enumerate(tree.outlines()):
        frame = np.asarray(tree.frames[i])
        world = outline @ frame[:3, :3].T + frame[:3, 3]
        axis, point = layout.axis[i], layout.ends[i, 0]
        rel = world - point
        reach = float(np.max(np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=-1)))
        xy = outline[:, :2]
        area = 0.5 * abs(
            float(np.dot(xy[:, 0], np.roll(xy[:, 1], -1)) - np.dot(xy[:, 1], np.roll(xy[:, 0], -1)))
        )
        b.append(area * reach**3)
    denominator = 16.0 if design.drag_model == "paper" else 8.0
    factor = design.b_scale * design.drag_coefficient * design.fluid.density / denominator
    return factor * jnp.asarray(b)


def release_times_from_front(net: Net, direction, speed: float) -> np.ndarray:
    """Release times (time units) of an etch front that sweeps the die at `speed` (design length units
    per time unit) along `direction` (2 components in the pattern's plane basis `geometry.plane`, or 3
    in the world): it starts at the pattern's first point along that direction at ``t = 0`` and
    releases each crease when it reaches the crease's midpoint. Shape `(m,)`."""
    g = net.geometry
    direction = unit_front_direction(direction, g.plane, speed)
    return front_release(
        g.vertices_coords, g.crease_midpoints, direction, net.length_scale, float(speed)
    )


def load_net(
    net: str | os.PathLike | FoldFile | NetGeometry,
    *,
    root: int | None = None,
    length_scale: float | None = None,
    units=None,
    name: str | None = None,
    flat_creases: str = "panel",
) -> Net:
    """Read a net: a catalogue name (`origami_jax.fold.catalogue_names()`, e.g. ``"cube_net_01"``), a
    `.fold` path, a `FoldFile` or a `NetGeometry`.

    **Arguments:** `root`: the fixed face (default: the largest); `length_scale`: design length units
    per FOLD length unit (default from the file's `frame_unit` and `units`, `MICRO` by default);
    `name`: a label (default the catalogue name or file stem); `flat_creases`: `"panel"` (faces
    joined by flat `F` edges, a triangulated export's facet diagonals, are one rigid panel,
    `origami_jax.fold.flat_faces_merged`: the net, its key frame and outputs are the merged
    faces', its edges renumbered; `root` still a face of the file; default) or `"hinge"` (every
    `F` edge a crease aimed at 0°, which no stressed hinge folds: `Net.system` refuses it). A
    folded form (a file without its flat frame) is read as the net it unfolds to
    (`origami_jax.fold.unfold_folded_form`).

    A file drawn with its hinge strips (faces marked by the FOLD face property
    ``faces_origami_jax:hinge``: docs, "FOLD files in and out") is read as the panels joined by
    arc hinges of the strips' widths (`origami_jax.net.strip_fold` writes one): its geometry is the
    point-crease net the strips fillet, its `drawn_layout` the strips as drawn, `root` a face id
    of the file.

    **Raises:** `FoldFormatError` for a file that is not a net (closed loops, disconnected or
    overlapping faces, a crease without a target) or whose hinge strips are malformed (a strip
    between other than two panels, bending both ways, panels that do not meet across it);
    `ValueError` for a unitless file without `length_scale`.
    """
    check_loader_arguments(root, length_scale)
    if flat_creases not in ("panel", "hinge"):
        raise ValueError(f"flat_creases must be 'panel' or 'hinge', got {flat_creases!r}.")
    units = MICRO if units is None else units
    label = name
    key = None
    drawing = None
    if isinstance(net, NetGeometry):
        geometry = net
    else:
        if isinstance(net, FoldFile):
            fold = net
        else:
            path, label = source_and_label(net, label)
            fold = read_fold(path)
        drawing = strip_drawing(fold, root=root)
        if drawing is not None:
            fold, root = FoldFile(frames=(drawing.key_frame,)), drawing.geometry.root
        fold = flat_fold(fold, root=root)
        if flat_creases == "panel":
            fold, root = flat_faces_merged(fold, root)
        geometry = net_geometry(fold, root=root)
        key = fold.frame(0)
        if key.faces_vertices is None:
            # Traced from the planar graph by the geometry: written with the folding (a FOLD file
            # without faces was simulated, then refused when its animation was written).
            key = key.replace(faces_vertices=tuple(tuple(map(int, f)) for f in geometry.faces))
    if length_scale is None:
        length_scale = length_scale_from_unit(geometry.unit, units.metre_per_length)
    label = label or "net"
    if key is None or key.edges_vertices is None:
        key, crease_edges = key_frame(geometry, label)
    else:
        crease_edges = tuple(tuple(int(e) for e in edges) for edges in geometry.crease_edges)
    layout = None if drawing is None else drawn_layout(drawing, float(length_scale))
    return Net(geometry, label, float(length_scale), key, crease_edges, drawn_layout=layout)


def NetLayout(net: Net, **options) -> Net:  # noqa: N802 (the former layout class)
    """`net` with the physics options of its systems (`Net.with_model`): the layout that `design`
    and `sweep` rebuild, ``NetLayout(net, contact=False)(design)`` is ``net.system(design,
    contact=False)``. Kept for the former `NetLayout` class: a net is its own layout."""
    return net.with_model(**options)


def folding_animation(
    base: FoldFrame,
    fold,
    crease_edges,
    vertex_corners: tuple[np.ndarray, np.ndarray],
    name: str,
    *,
    trajectory=None,
    angles=None,
    times=None,
    every: int = 1,
    extras=None,
    key_extra=None,
) -> FoldFile:
    """A folding as a FOLD animation (`Net.to_fold`, `CreasePattern.to_fold`): `base`, then one frame
    per kept sample with every vertex where `fold(angles)` (per face, per corner) puts it, picked by
    `vertex_corners`, and each crease's fold angle on its FOLD edges `crease_edges`.

    `extras`: one dict of `origami_jax:` properties per sample (all samples, not only the kept
    ones), added to that sample's frame; `key_extra`: properties added to the crease-pattern frame
    (e.g. the verdict)."""
    if trajectory is not None:
        angles, times = np.asarray(trajectory.theta), np.asarray(trajectory.times)
    if angles is None:
        raise ValueError("to_fold needs a trajectory or angles=(k, m).")
    angles = np.atleast_2d(np.asarray(angles, dtype=float))
    if extras is not None and len(extras) != len(angles):
        raise ValueError(
            f"extras must have one dict per sample ({len(angles)}), got {len(extras)}."
        )
    if key_extra:
        base = dataclasses.replace(base, extra={**base.extra, **key_extra})
    keep = kept_samples(angles, every)
    first_face, first_corner = vertex_corners
    n_edges = int(np.asarray(base.edges_vertices).shape[0])
    frames = [base]
    for s in keep:
        corners = fold(angles[s])
        degrees = np.zeros(n_edges)
        for j, edges in enumerate(crease_edges):
            degrees[list(edges)] = np.degrees(
                np.arctan2(np.sin(angles[s, j]), np.cos(angles[s, j]))
            )
        extra = {"origami_jax:hinge_angles": [float(x) for x in angles[s]]}
        if times is not None:
            extra["origami_jax:time"] = float(np.asarray(times)[s])
        if extras is not None:
            extra.update(extras[s])
        frames.append(
            FoldFrame(
                vertices_coords=corners[first_face, first_corner],
                edges_assignment=frame_assignment(base.edges_assignment, degrees, crease_edges),
                edges_fold_angle_deg=degrees,
                frame_classes=("foldedForm",),
                frame_attributes=("3D",),
                frame_parent=0,
                frame_inherit=True,
                extra=extra,
            )
        )
    return FoldFile(
        frames=tuple(frames),
        file_metadata={
            "file_creator": "origami_jax",
            "file_classes": ["singleModel", "animation"],
            "file_title": name,
        },
    )


def kept_samples(angles: np.ndarray, every: int) -> np.ndarray:
    """The samples of `angles` `(k, m)` a FOLD animation keeps: every `every`-th and the last,
    finite ones only (indices, increasing)."""
    angles = np.atleast_2d(np.asarray(angles, dtype=float))
    keep = np.arange(0, len(angles), max(int(every), 1))
    if keep[-1] != len(angles) - 1:
        keep = np.append(keep, len(angles) - 1)
    return keep[np.all(np.isfinite(angles[keep]), axis=1)]


class _CornerGaps(eqx.Module):
    """Each seam's gap from its corners: the larger distance between the two sides' corners at
    either end, the corners placed by the mechanism's body poses."""

    mechanism: Any
    corner_bodies: np.ndarray  # (s, 2, 2) int: each end's two sides' bodies, −1 the base
    corner_points: np.ndarray  # (s, 2, 2, 3): those corners in their bodies' frames, length

    def __call__(self, q):
        body, local = self.corner_bodies, self.corner_points
        if not body.shape[0]:
            return jnp.zeros((0,), jnp.asarray(q).dtype)
        poses = self.mechanism.body_poses(q)
        base = jnp.eye(4, dtype=poses.dtype)[None]
        poses = jnp.concatenate([poses, base], axis=0)  # body −1 is the base (world frame)
        chosen = poses[jnp.asarray(body)]
        corners = jnp.asarray(local, poses.dtype)
        points = jnp.einsum("seaij,seaj->seai", chosen[..., :3, :3], corners)
        points = points + chosen[..., :3, 3]
        # A seam's end on a vertex the two faces share stays at distance 0: a norm with a finite
        # gradient there (yield surrogates differentiate through the gaps).
        distance = safe_norm(points[:, :, 0] - points[:, :, 1])
        return jnp.max(distance, axis=-1)


def seam_gap_function(
    tree_geometry, seams, mechanism, length_scale: float, *, points=None
) -> SeamGaps:
    """A traceable ``q ↦`` gap of each seam (design length units, `(s,)`): the larger distance
    between the two sides' corners at either end of the seam, from `mechanism`'s body poses, as a
    `SeamGaps` (also the two bodies each seam joins, the base as ``mechanism.n_bodies``).
    `tree_geometry` is the panel tree's `NetGeometry` (faces in body order), `seams` its seams;
    `points` `(s, 2, 2, 3)`: the seams' ends on each side in the flat net (an `ArcLayout`'s
    `seam_points`: where both sides have material) instead of the outlines' corners."""
    g = tree_geometry
    width = g.face_coords.shape[1]
    position = {int(f): i - 1 for i, f in enumerate(np.asarray(g.order))}
    body = np.zeros((len(seams), 2, 2), dtype=np.int64)
    local = np.zeros((len(seams), 2, 2, 3))
    outlines = mechanism.outlines()
    if points is not None:
        # The bodies' rest poses (at q = 0, the body frames), host geometry.
        rest = np.asarray(getattr(mechanism, "panels", mechanism).frames)
    for s_ in range(len(seams)):
        for e in range(2):
            for side in range(2):
                f, k = divmod(int(seams.corners[s_, e, side]), width)
                b = position[f]
                body[s_, e, side] = b
                if points is not None:
                    # The flat net's point in body b's frame (the base's is the world).
                    x = np.asarray(points[s_, e, side], dtype=float)
                    local[s_, e, side] = x if b < 0 else (x - rest[b, :3, 3]) @ rest[b, :3, :3]
                else:
                    local[s_, e, side] = (
                        g.face_coords[f, k] * length_scale if b < 0 else outlines[b][k]
                    )
    # A seam joins one side of one face to one side of another: both ends name the same two faces.
    assert np.array_equal(body[:, 0], body[:, 1]), "a seam's ends on different faces"
    # Body −1 (the root face, posed by the world frame below) is the contact tables' base, n_bodies.
    bodies = np.where(body[:, 0] < 0, mechanism.n_bodies, body[:, 0])

    return SeamGaps(_CornerGaps(mechanism, body, local), bodies)
