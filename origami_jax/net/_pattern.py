"""`AbstractPanelPattern`: what the two patterns of panels on a panel tree share — a net
([`origami_jax.net.Net`][]) and a crease pattern with closed loops
([`origami_jax.loops.CreasePattern`][]) — and their explicit host cache (`HostCache`).

Both have one hinge per crease of their geometry, the literature hinge each no wider than its
crease as their default design, the same checks of a design against their creases and of their
loaders' arguments, etch fronts that release their creases in turn, the fold kernel
(`origami_jax.net.fold_kernel`) as their sweep kernel, and physics options whose variants
(`with_model`) are kept with the pattern, so that the same options give the same object (and a
compiled fit or sweep of it is reused).
"""

import abc
import dataclasses
import math
import warnings
from collections.abc import Callable, Hashable, Mapping
from typing import Any, ClassVar, final

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._exported import exported_jit, remembered
from .._limits import FOLD_SEGMENT, MAX_FOLD_SEGMENTS, default_t_end
from .._runtime_errors import checks_as_nan
from .._validate import is_traced
from ..contact import Adhesion, Friction, contact_kind
from ..fluid import CombinedDrag, fluid_loads, polygon_added_inertia
from ..simulation import Step, fold_pattern, quasi_static_ramp
from ..system import AbstractPattern, Agitation, HingeDesign, check_known_names
from ._content import value_key
from ._kernel import fold_kernel


@final
class HostCache:
    """Host-side values a pattern computes once and keeps: its contact tables, its variants with
    other physics options (`with_model`), a closed-loop pattern's rigid-folding path... Each value
    depends on the pattern's geometry only (never on a design's numbers), under a key that names
    what else it depends on.

    A pattern is immutable; its cache is the one part that grows, explicitly: a `HostCache` object,
    shared by the variants `with_model` gives (they have the same geometry), never compared or
    printed with the pattern. Not thread-safe: build a pattern's tables before sharing it between
    threads (a sweep does, on the host, before anything runs).
    """

    def __init__(self):
        self._values: dict[Hashable, Any] = {}

    def get(self, key: Hashable, build: Callable[[], Any]) -> Any:
        """The value kept under `key`, built by `build()` (and kept) the first time."""
        if key not in self._values:
            self._values[key] = build()
        return self._values[key]

    def values(self) -> list:
        """Every value kept (a list: the cache may grow while it is read)."""
        return list(self._values.values())

    def items(self) -> list:
        """Every `(key, value)` kept (a list, as `values`)."""
        return list(self._values.items())

    def __contains__(self, key: Hashable) -> bool:
        return key in self._values

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return f"HostCache({len(self._values)} values)"


class AbstractPanelPattern(AbstractPattern):
    """A pattern of panels on a panel tree with one hinge per crease of its `geometry`
    ([`origami_jax.system.AbstractPattern`][]): a net or a crease pattern with closed loops.

    **Members** its implementations give: `geometry` (with `n_creases`), `crease_lengths`,
    `host_cache` (a `HostCache`, a dataclass field shared with its `with_model` variants), and the
    class's physics options `MODEL` (name → default).
    """

    def fold(
        self,
        system,
        inputs=None,
        options=None,
        *,
        t1: float | None = None,
        bias: float = 0.0,
        tolerances=None,
        segment: float | None = None,
        max_segments: int = MAX_FOLD_SEGMENTS,
        on_continue=None,
    ):
        """Fold this pattern with `system` (one it built) from its start state
        (`start_state(system, bias=bias)`: a net starts flat) and judge the run (`assess`).

        With `t1` (time, the system's units: µs for the default units), one run to `t1`. Without
        it, runs of `segment` (default: a first of `fold_segment(system)`, 1000 µs or past a
        release ramp the longer of that and a fifth of the ramp, then continuations of as long
        as that first run lasted past the ramp) continued from the last state while the panels
        still move (the verdict `unfinished`, or `folded` but not at rest), up to `max_segments` (default 8) in all (a
        cube net in the etch bath closes in ~1.4 ms, one in air rings for much longer, and neither
        needs its end time guessed); a closed-loop pattern's run is one segment (its state is more
        than its angles; `continues_from_angles`, `origami_jax.simulation.fold_pattern`).

        **Arguments:** `inputs` (default the pattern's release, `release_input(system)`: the
        paper's step, `origami_jax.simulation.Step()`, or a ramp, `release_ramp_for`);
        `options` (an `origami_jax.simulation.SolveOptions` for every segment: samples, solver —
        explicit Tsit5 suits closed loops: the default's implicit half differentiates through the
        closure —, tolerances, step budget, progress meter; default ``SolveOptions(throw=False)``);
        `bias` (a closed-loop pattern's pre-fold; 0 for a net); `tolerances` (a
        `VerdictTolerances`, for `assess`); `on_continue(end, next_end)`, called before each
        continuation.

        **Returns:** `(trajectory, report)`, the whole run and its fold report.
        """
        ramp = self.release_ramp_for(system) if inputs is None or segment is None else None
        inputs = Step(ramp=ramp) if inputs is None else inputs
        first = None
        if segment is None:
            # The ramp and its settling, then the settling alone at a time.
            first = default_t_end(ramp, FOLD_SEGMENT)
            segment = first - (0.0 if ramp is None else ramp)
        return fold_pattern(
            self, system, inputs, options, t1=t1, bias=bias, tolerances=tolerances,
            segment=segment, max_segments=max_segments, on_continue=on_continue, first=first,
        )  # fmt: skip

    MODEL: ClassVar[Mapping[str, Any]]
    geometry: Any
    host_cache: HostCache
    release_ramp: float | str | None

    @property
    def n_creases(self) -> int:
        return self.geometry.n_creases

    @property
    def n_hinges(self) -> int:
        """One hinge per crease (static)."""
        return self.geometry.n_creases

    def hinge_name(self, j: int) -> str:
        return f"crease {j}"

    @property
    @abc.abstractmethod
    def crease_lengths(self) -> np.ndarray:
        """Each crease's length (design length units, `(n_creases,)`)."""

    def with_model(self, **options) -> "AbstractPanelPattern":
        """This pattern with other physics options (the names of `MODEL`): the same object for the
        same options, kept in this pattern's `host_cache` (shared with the copy), so a compiled fit
        or sweep of it is reused. **Raises:** `ValueError` for an unknown option."""
        check_known_names(
            f"{type(self).__name__}.with_model",
            options,
            sorted(self.MODEL),
            kind="option",
            whose="model's",
        )
        if "contact_sampling" in options:
            options = {
                **options,
                "contact_sampling": tuple(int(x) for x in options["contact_sampling"]),
            }
        values = {name: getattr(self, name) for name in self.MODEL}
        if all(values[name] == value for name, value in options.items()):
            return self
        values.update(options)
        key = ("model", repr(sorted(values.items())))
        return self.host_cache.get(key, lambda: dataclasses.replace(self, **values))

    def fluid_inertia(
        self,
        design: HingeDesign | None = None,
        *,
        added_mass: bool | None = None,
        viscous: bool | None = None,
    ) -> tuple[bool, bool]:
        """Whether this pattern's systems in `design`'s fluid carry the fluid's inertia and its viscous
        drag: `(added_mass, viscous)`, the arguments if given, else the model's (`with_model`),
        else (`None`, the default) whether the fluid is a liquid (`Fluid.liquid`: the etch bath).

        **Raises:** `ValueError` where the default is asked of a fluid whose liquidity is unknown
        (built from a traced density without `liquid=`)."""
        design = self.default_design() if design is None else design
        resolved = []
        for name, value in (("added_mass", added_mass), ("viscous", viscous)):
            value = getattr(self, name) if value is None else value
            if value is None:
                if design.fluid.liquid is None:
                    raise ValueError(
                        f"{name}: whether {design.fluid.name!r} is a liquid is unknown (its "
                        "density is traced): give Fluid(..., liquid=...) or "
                        f"with_model({name}=True/False)."
                    )
                value = design.fluid.liquid
            resolved.append(bool(value))
        return resolved[0], resolved[1]

    def oscillation_state(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Where the quasi-static ramp linearises this pattern's motion
        (`origami_jax.simulation.quasi_static_ramp`'s `about`): `None` (the flat state, every
        crease free), which a pattern with closed loops overrides."""
        return None

    def release_ramp_for(self, system) -> float | None:
        """The release ramp (time units of `system`, µs by default) this pattern's `system` (one
        it built) is released over, or `None` for the paper's step: the model's `release_ramp`,
        or for `"auto"` (the default) a quasi-static release where `system` carries the fluid's
        inertia (`quasi_static_release`: in the etch bath a hinge's own motion takes
        milliseconds, and a real etch frees it over minutes) and the step otherwise (in air the
        panels move in microseconds, the paper's setting)."""
        ramp = self.release_ramp
        if ramp != "auto":
            return None if ramp is None else float(ramp)
        if not system.mechanism.carries_added_inertia:
            return None
        return quasi_static_release(system, self.oscillation_state())

    def kept_system(self, design: HingeDesign, **options):
        """`system(design, **options)`, read from disk where the command line keeps its traced
        programs when an earlier process built it (`origami_jax._exported.remembered`: under
        this pattern's contents, `design` and `options` by value, this package's source and the
        libraries' versions; outside the command line, `system`): a warm `origami-jax fold`
        skips the host geometry and small programs of the build. What the build keeps in the
        `host_cache` (the plate tables) comes back with it. Built each time for a pattern with
        closed loops or bending-arc hinges, whose host-side layouts are kept by identity, not by
        value."""
        if getattr(self, "n_loops", 0) or self.hinges != "point":
            return self.system(design, **options)

        def build():
            before = {key for key, _ in self.host_cache.items()}
            system = self.system(design, **options)
            added = {key: value for key, value in self.host_cache.items() if key not in before}
            return system, added

        inputs = (type(self).__name__, self.content_key(), design, options)
        system, added = remembered("system", build, *inputs, prefetch_after=True)
        for key, value in added.items():
            self.host_cache.get(key, lambda value=value: value)
        return system

    def nominal_release_ramp(self, design: HingeDesign | None = None) -> float | None:
        """`release_ramp_for` the system of `design` (default `default_design()`): the one ramp a
        sweep or yield releases every sample over (the etch is the same for all; time units of
        the design, µs by default). The system is built (compiled, not on the host) only for an
        `"auto"` ramp with the fluid's inertia."""
        if self.release_ramp != "auto":
            return self._ramp(None)
        design = self.default_design() if design is None else design
        if not any(self.fluid_inertia(design)):
            return None
        # Kept per pattern and design (tracing and compiling the system costs seconds for each
        # net), across the pattern objects that load the same net; where the command line keeps
        # its programs, across processes too (`remembered`: a warm yield or sweep neither traces
        # nor runs the ramp's program, 2-3 s of tracing on a 2-core machine).
        key = (self.content_key(), value_key(design))
        if key not in _NOMINAL_RAMPS:
            about = self.oscillation_state()
            # Traced with equinox's checks as NaN, as the sweep that follows traces its kernel:
            # the system's inner programs traced here with callbacks would be reused there, and a
            # program that calls back is never stored (a warm yield compiled its kernel again).
            # The pattern by its contents (a net loaded again shares the program), the design's
            # numbers strongly typed (a weakly typed value would trace the program again).
            strong = jax.tree.map(
                lambda x: jnp.asarray(x, jnp.result_type(x)) if eqx.is_array(x) else x, design
            )

            def ramp() -> float:
                with checks_as_nan():
                    return rounded_up(float(_design_ramp(_ByContent(self, key[0]), strong, about)))

            inputs = (type(self).__name__, key[0], strong, about)
            _NOMINAL_RAMPS[key] = remembered("nominal_release_ramp", ramp, *inputs)
        return _NOMINAL_RAMPS[key]

    def release_input(self, system=None) -> Step:
        """How the etch releases this pattern's hinges, the input `fold`, `kernel` (so `sweep`
        and `yield_estimate`) and the command line drive it with: the paper's step
        (`origami_jax.simulation.Step()`) or each hinge's torque growing over the ramp
        `release_ramp_for(system)` from its release (`Step(ramp=...)`). `system` (one this
        pattern built: the nominal one of a sweep) is needed for the `"auto"` ramp only.

        **Raises:** `ValueError` for an `"auto"` ramp without a system."""
        return Step(ramp=self._ramp(system))

    def fold_segment(self, system=None) -> float:
        """The length of `fold`'s first run (µs): `FOLD_SEGMENT` (1000 µs), or past the release
        ramp where there is one (`release_ramp_for(system)`: a run that ends before the hinges'
        torques are whole would be judged in the middle of the release) the longer of that and a
        fifth of the ramp (`default_t_end`); its continuations last as long as it does past the
        ramp."""
        return default_t_end(self._ramp(system), FOLD_SEGMENT)

    def _ramp(self, system) -> float | None:
        if system is None:
            if self.release_ramp == "auto":
                raise ValueError(
                    f"{self.name}'s release ramp is 'auto' (quasi-static where the system carries "
                    "the fluid's inertia): give the system it releases."
                )
            return None if self.release_ramp is None else float(self.release_ramp)
        return self.release_ramp_for(system)

    def default_design(self, fluid=None) -> HingeDesign:
        """The literature hinge in `fluid` (default air), each hinge no wider than its crease
        (`origami_jax.net.default_design`)."""
        return default_design(self, fluid)

    def content_key(self) -> tuple:
        """A hashable key of everything that decides this pattern's systems: its class, geometry
        (vertices, faces, crease targets, base), length scale and every other field (physics
        options, a drawn layout), not its name. Two loads of one net share it (a pattern compares
        by identity); what is compiled per pattern (a sweep's fold kernel, the nominal release
        ramp) is kept under it, so loading a net again compiles nothing again."""
        g = self.geometry
        root = getattr(g, "tree", g).root  # a crease pattern's spanning tree holds its base
        others = (
            value_key(getattr(self, f.name))
            for f in dataclasses.fields(self)
            if f.name not in _NOT_CONTENT
        )
        return (
            type(self).__name__, float(self.length_scale), root,
            np.asarray(g.vertices_coords).tobytes(), repr(g.faces), np.asarray(g.targets).tobytes(),
            *others,
        )  # fmt: skip

    def kernel(self, **settings):
        """The fold kernel of this pattern for `sweep` (`origami_jax.net.fold_kernel`, `settings`
        its keyword arguments)."""
        return fold_kernel(self, **settings)


# A pattern's fields that `content_key` reads otherwise (the geometry), or that decide nothing
# (its label; its host cache; the FOLD frame and crease edges, which come with the geometry).
_NOT_CONTENT = frozenset(
    {"geometry", "name", "length_scale", "host_cache", "key_frame", "crease_edge_ids"}
)


# Compiled (and so kept in the persistent cache): op by op, the frequency's fixed point costs
# seconds of dispatch each time a system is built outside a trace; outside one, its traced program
# comes from disk where the command line keeps them (tracing it cost a warm `origami-jax fold` ~1 s).
@exported_jit("fluid_loads")
def _fluid_loads(mechanism, unit_added, chord, stiffness, targets, numbers, parts):
    density, viscosity, coefficient = numbers
    added_mass, viscous = parts
    loads = fluid_loads(
        mechanism, unit_added, chord, stiffness, targets, density=density, viscosity=viscosity,
        coefficient=coefficient, added_mass=added_mass, viscous=viscous,
    )  # fmt: skip
    # Not the mechanism: given back as the program's outputs, its host geometry (outlines) would
    # come back as device arrays, or traced ones under an outer trace, where the host reads them.
    return loads._replace(mechanism=None)


def with_fluid_loads(
    mechanism, drag_model, design: HingeDesign, stiffness, targets, *, added_mass, viscous
):
    """`(mechanism, drag_model)` with the fluid's inertia on every panel and its viscous drag added
    to `drag_model` (`origami_jax.fluid.fluid_loads`: strip theory across each panel's chord, the
    fluid and added-mass coefficient of `design`); unchanged where neither is asked. `mechanism`:
    a panel tree, a strip tree or closed loops of panels; `stiffness`, `targets`: its hinges'."""
    if not (added_mass or viscous):
        return mechanism, drag_model
    outlines = mechanism.outlines()
    arguments = (
        mechanism,
        jnp.stack([polygon_added_inertia(o) for o in outlines]),
        # Each body's chord across its hinge: its extent along the body frame's y (the hinge
        # lies along x).
        jnp.asarray([float(np.ptp(o[:, 1])) for o in outlines]),
        stiffness,
        targets,
        (design.fluid.density, design.fluid.viscosity, design.added_mass_coefficient),
        (bool(added_mass), bool(viscous)),
    )
    loads = _fluid_loads(*arguments)
    if loads.viscous is not None:
        drag_model = CombinedDrag((drag_model, loads.viscous))
    if loads.added is not None:
        mechanism = mechanism.with_added_inertias(loads.added)
    return mechanism, drag_model


def check_surface_model(adhesion, friction) -> None:
    """One-line errors for a pattern's `adhesion` and `friction` options (each `None` or the
    `origami_jax.contact` class of that name), before anything is built."""
    for name, value, kind in (("adhesion", adhesion, Adhesion), ("friction", friction, Friction)):
        if value is not None and not isinstance(value, kind):
            raise ValueError(
                f"{name} must be None or an origami_jax.contact.{kind.__name__}, got "
                f"{type(value).__name__}."
            )


def check_agitation(agitation) -> None:
    """A one-line error for a pattern's `agitation` option (`None` or an
    `origami_jax.system.Agitation`), before anything is built."""
    if agitation is not None and not isinstance(agitation, Agitation):
        raise ValueError(
            f"agitation must be None or an origami_jax.system.Agitation (a temperature, kelvin, "
            f"and a seed), got {type(agitation).__name__}."
        )


# A pattern's physics options that name a choice, and the choices (`check_physics_options`).
_CHOICES = {"drag": ("panel", "hinge"), "hinges": ("point", "arc")}


def check_physics_options(pattern) -> None:
    """One-line errors for a pattern's physics options when it is made (`with_model`), not when
    its first system is built: the contact model's name (`contact_kind`), the drag's and hinges'
    (`_CHOICES`), the fluid's switches (`added_mass`, `viscous`: `None`, `True` or `False`), and
    the options that are objects or times (`adhesion`, `friction`, `release_ramp`,
    `agitation`)."""
    contact_kind(pattern.contact)
    for name, choices in _CHOICES.items():
        value = getattr(pattern, name)
        if not (isinstance(value, str) and value in choices):
            raise ValueError(
                f"{name} must be one of {', '.join(map(repr, choices))}, got {value!r}."
            )
    for name in ("added_mass", "viscous"):
        value = getattr(pattern, name)
        if value is not None and not isinstance(value, bool | np.bool_):
            raise ValueError(
                f"{name} must be None (on in a liquid, off in a gas), True or False, got {value!r}."
            )
    check_surface_model(pattern.adhesion, pattern.friction)
    check_release_ramp(pattern.release_ramp)
    check_agitation(pattern.agitation)


# Its traced program comes from disk where the command line keeps them (`exported_jit`): tracing
# the system's mass and stiffness cost a warm `origami-jax fold` ~0.2 s.
@exported_jit("release_ramp")
def _quasi_static_ramp(system, about):
    return quasi_static_ramp(system, about=about)


_NOMINAL_RAMPS: dict = {}
"""`AbstractPanelPattern.nominal_release_ramp`'s values, by geometry, model and design."""


class _ByContent:
    """A pattern as a static argument of a compiled program, compared by its contents
    (`content_key`), not its identity."""

    def __init__(self, pattern, key):
        self.pattern = pattern
        self.key = key  # its `content_key()`

    def __eq__(self, other) -> bool:
        return isinstance(other, _ByContent) and other.key == self.key

    def __hash__(self) -> int:
        return hash(self.key)


@eqx.filter_jit
def _design_ramp(pattern: _ByContent, design, about):
    return quasi_static_ramp(pattern.pattern.system(design), about=about)


def rounded_up(time: float) -> float:
    """`time` rounded up to two significant figures (39.6 → 40, 13.2 → 14)."""
    unit = 10.0 ** (math.floor(math.log10(time)) - 1)
    return math.ceil(time / unit * (1 - 1e-12)) * unit


def quasi_static_release(system, about=None) -> float:
    """The ramp an `"auto"` release gives `system` (time units): `quasi_static_ramp(system,
    about=about)` (three periods of its hinges' slowest mode about flat, or about the state and
    in the motions `about` gives: `AbstractPanelPattern.oscillation_state`) rounded up to two
    significant figures, so that the release recorded with a run reads as a number a person
    would choose (40 ms for a 200 µm cube net in KOH). Where the command line keeps its
    programs, the value itself is kept (`remembered`, under the system's and `about`'s values): a
    warm command neither loads nor runs the ramp's program, nor sets up the LAPACK it calls."""

    def ramp() -> float:
        with checks_as_nan():  # as `nominal_release_ramp`: keeps the solve that follows storable
            return rounded_up(float(_quasi_static_ramp(system, about)))

    return remembered("release_ramp_value", ramp, system, about)


def check_release_ramp(release_ramp) -> None:
    """A one-line error for a pattern's `release_ramp` option (`"auto"`, `None`, or a positive
    finite time in µs), before anything is built."""
    if release_ramp is None or (isinstance(release_ramp, str) and release_ramp == "auto"):
        return
    if (
        isinstance(release_ramp, bool)
        or not isinstance(release_ramp, int | float)
        or not (math.isfinite(release_ramp) and release_ramp > 0)
    ):
        raise ValueError(
            f"release_ramp must be 'auto' (quasi-static where the fluid's inertia is carried), "
            f"None (the paper's step release) or a positive time in µs, got {release_ramp!r}."
        )


def with_surface_physics(
    pattern: "AbstractPanelPattern", contact_model, kind: str | None, host_mechanism: Callable
):
    """`contact_model` with `pattern`'s adhesion and friction attached (itself when it has
    neither). `host_mechanism()` builds, on the host, a mechanism with the geometry the contact
    tables were drawn from (the contact's numbers may be traced: the surface tables are geometry
    only, so a sweep's or a fit's traced design still gets them).

    **Raises:** `ValueError` when the pattern asks for surface physics without the plate contact
    (adhesion and friction act where plates meet)."""
    adhesion, friction = pattern.adhesion, pattern.friction
    if adhesion is None and friction is None:
        return contact_model
    if kind != "plate":
        raise ValueError(
            f"{pattern.name}: adhesion and friction act where plates meet: they need the plate "
            f"contact (contact='plate' or True), not {'no contact' if kind is None else repr(kind)}."
        )
    with jax.ensure_compile_time_eval():
        return contact_model.with_surface(host_mechanism(), adhesion=adhesion, friction=friction)


def hinges_within_creases(design: HingeDesign, lengths) -> HingeDesign:
    """`design` with each hinge no wider than its crease (`lengths`, `(m,)`, the design's length
    units): ``hinge_width = min(design's width, crease length)``, one per crease where some crease
    is shorter, else `design` itself. The default for a net or pattern folded without a design of
    its own: the literature hinge is 200 µm wide, the edge of the catalogue's square panels, and
    no device has a hinge longer than its crease (the waterbombs' 100 and 141 µm creases)."""
    lengths = np.asarray(lengths, dtype=float)
    width = np.asarray(design.hinge_width, dtype=float)
    if not np.any(width > lengths):
        return design
    narrowed = jax.device_put(np.minimum(width, lengths))  # put: `jnp.asarray` compiles per shape
    return eqx.tree_at(lambda d: d.hinge_width, design, narrowed)


def default_design(pattern, fluid=None) -> HingeDesign:
    """The design a net or pattern is folded with when none is given: the literature hinge
    (`HingeDesign.literature`, in `fluid`, default air), each hinge no wider than its crease of
    `pattern` (a `Net` or `CreasePattern`; `hinges_within_creases`)."""
    overrides = {} if fluid is None else {"fluid": fluid}
    return hinges_within_creases(HingeDesign.literature(**overrides), pattern.crease_lengths)


def check_per_crease(design: HingeDesign, m: int) -> None:
    """Every number of `design` one value, or one per crease (`m`): a one-line `ValueError`
    naming the field otherwise (a list of another length broadcast deep inside JAX)."""
    for field in dataclasses.fields(design):
        value = getattr(design, field.name)
        if isinstance(value, str) or value is None or is_traced(value):
            continue
        shape = np.shape(value) if isinstance(value, int | float | np.ndarray | jnp.ndarray) else ()
        if shape not in ((), (1,), (m,)):
            raise ValueError(
                f"design.{field.name} has shape {shape} for {m} creases: give one value, or one per "
                "crease."
            )


def check_hinges_longer_than_film(
    design: HingeDesign, targets, name: str, aim: str = "targets= (rad)"
) -> None:
    """Refuse (one-line `ValueError`) a crease whose hinge would be shorter than its film.

    Each crease's bilayer folds to its own target, so its hinge is ``ρ |θ|`` long (`radius`, the
    design's length units) and its stiffness grows as ``1/|θ|``: a crease aimed at 0 has no hinge
    (infinite stiffness), and one aimed at 1e-9° made the solver take millions of steps. A bending
    strip is only a strip when it is longer than it is thick, so the smallest fold a design can
    make is ``(t₁ + t₂)/ρ``. `targets` (rad, `(m,)`) and the design's fields are skipped when
    traced; `aim` names where the caller's user sets a crease's angle."""
    if is_traced(targets) or any(is_traced(leaf) for leaf in jax.tree_util.tree_leaves(design)):
        return
    with jax.ensure_compile_time_eval():
        thickness = np.asarray(design.t_structural + design.t_hinge, dtype=float)
        radius = np.asarray(design.radius(), dtype=float)
    targets = np.asarray(targets, dtype=float)
    thickness, radius = np.broadcast_arrays(thickness, radius, targets)[:2]
    short = np.flatnonzero(radius * np.abs(targets) < thickness)
    if not short.size:
        return
    j = int(short[0])
    unit = design.units.length_symbol
    smallest = np.degrees(thickness[j] / radius[j])
    raise ValueError(
        f"{name}: crease {j} folds to {np.degrees(targets[j]):.3g}°, so its hinge would be "
        f"{radius[j] * abs(targets[j]):.3g} {unit} long, shorter than its film "
        f"({thickness[j]:.3g} {unit} thick): this design folds a crease by at least "
        f"{smallest:.3g}°: aim it further ({aim}), or mark it flat (F) to join its faces as one "
        "panel (read without flat_creases='hinge')."
    )


def warn_if_hinges_wider_than_creases(name: str, design: HingeDesign, lengths) -> None:
    """A `UserWarning` when a hinge of `design` (its `hinge_width`, scalar or one per crease, when
    not traced) is wider than its crease (`lengths`, `(m,)`, the design's length units). The
    system still models it that wide (its stiffness, and as an arc its strip's mass, grow with the
    width), which no device can be: the literature hinge is 200 µm wide, the edge of the
    catalogue's square panels, and longer than the short creases of some patterns."""
    width = design.hinge_width
    if is_traced(width):
        return
    lengths = np.asarray(lengths, dtype=float)
    width = np.broadcast_to(np.asarray(width, dtype=float), lengths.shape)
    over = np.flatnonzero(width > lengths * (1 + 1e-9))
    if not over.size:
        return
    unit = design.units.length_symbol
    shown = ", ".join(f"{j} ({width[j]:g} on {lengths[j]:.4g} {unit})" for j in over[:6])
    more = f" and {over.size - 6} more" if over.size > 6 else ""
    warnings.warn(
        f"{name}: hinges wider than their creases, modelled that wide all the same: crease "
        f"{shown}{more}. Give hinge_width one value per crease, at most its length "
        "(HingeDesign(..., hinge_width=[...]); origami-jax fold --param hinge_width=W0,W1,...).",
        UserWarning,
        stacklevel=3,
    )


def unit_front_direction(direction, plane: np.ndarray, speed) -> np.ndarray:
    """An etch front's `direction` (2 components in the `plane` basis `(2, 3)`, or 3) as a unit
    world 3-vector, its `speed` checked. **Raises:** `ValueError` for a zero or misshapen direction
    or a speed that is not positive and finite."""
    direction = np.asarray(direction, dtype=float)
    if direction.shape == (2,):
        direction = direction @ plane
    if direction.shape != (3,) or not np.linalg.norm(direction) > 0:
        raise ValueError("the etch front's direction must be a non-zero 2- or 3-vector.")
    if not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"the etch front's speed must be positive, got {speed}.")
    return direction / np.linalg.norm(direction)


def front_release(vertices, midpoints, direction, length_scale: float, speed):
    """Release times of a straight etch front moving along the unit world `direction` at `speed`
    (design length units per time unit), from the pattern's first point along it at ``t = 0`` to
    each crease's midpoint: ``(m · d − min_v v · d) · length_scale / speed``. `vertices` `(n, 3)` and
    `midpoints` `(m, 3)` in the FOLD unit. Host arrays in, host arrays out; traceable in `direction`
    and `speed` (the yield surrogate differentiates it)."""
    start = (vertices @ direction).min()
    return (midpoints @ direction - start) * length_scale / speed


def check_loader_arguments(root, length_scale) -> None:
    """`root` a face index (a whole number) or `None`, `length_scale` a positive finite number or
    `None` (`load_net`, `load_pattern`): one-line `ValueError`s naming the argument."""
    if root is not None and (isinstance(root, bool) or not isinstance(root, int | np.integer)):
        raise ValueError(f"root must be a face index (a whole number), got {root!r}.")
    if root is not None and root < 0:
        raise ValueError(f"root must be a face index >= 0, got {root}.")
    if length_scale is not None:
        if isinstance(length_scale, bool) or not isinstance(length_scale, int | float | np.number):
            raise ValueError(f"length_scale must be a number, got {length_scale!r}.")
        if not (math.isfinite(length_scale) and length_scale > 0):
            raise ValueError(
                "length_scale must be a positive finite number (design length units per FOLD "
                f"length unit), got {length_scale}."
            )
