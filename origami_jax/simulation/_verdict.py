"""Did it fold? A verdict on a simulated folding, with the numbers behind it.

`assess(system, trajectory)` compares the end of a simulation with the shape the device is meant to take:

- **folded**: every crease within the angle tolerance of its intended angle and every seam closed
  (both tolerances in `VerdictTolerances`: 3°, and each seam's tolerance derived from the 3° and
  the geometry, by default);
  `time_to_fold` is when it got there for good. A seam is closed when its gap is below the seam
  tolerance, or when its two panels touch: some sample point of one lies within 1.1 ``ĝ`` of the
  other's plate, its face or its rounded rim (`PanelContact.report`'s `touching`; a resting panel
  hovers at the edge of the activation layer, and 1.1 ``ĝ`` is also what `contacts` counts as
  engaged). The last panel of a cube can land its edge on its neighbour's face or rim instead of
  meeting it edge on edge: that
  seam cannot open without the panels separating, and with every crease within the angle
  tolerance the two can only touch near that seam, so it is closed although its corners may be a
  few µm apart. The rule needs the two bodies each seam joins (`seam_gaps` with a `bodies` table,
  as `origami_jax.net.Net.seam_gap_function` gives); a plain function of ``q`` keeps the gap-only
  rule. A touching seam does not close the others.
- **jammed**: the device came to rest short of that, with panels in contact: a crease stopped short
  of its intended angle (same sign, smaller magnitude) while contact holds it (panels touch, and
  that crease rests more than the angle tolerance away from its own hinge's target, where it would
  rest without contact). A crease short because its hinge is drawn or bends to a smaller angle (a
  fabricated film off its stress), with nothing holding it there, is misfolded, whether or not
  panels happen to touch (or hold another crease, one that would fold past its angle, at it).
- **misfolded**: it came to rest in another state (a crease on the wrong side or past its angle, seams
  open without contact to explain it, a different stacking).
- **unfinished**: time ran out (the solver's step budget, or still moving at the end of the run).
- **invalid**: the simulation failed (non-finite state or another solver failure): see `reason`.

"Intended" angles default to the system's hinge targets; for a net they are the crease pattern's fold
angles (a net whose hinges aim elsewhere, 80° instead of 90° say, is judged against the shape it should
take, not against its hinges). `fold_outcome` is the traceable core (batches, sweeps and yield
estimates run it under `vmap`); `assess` wraps it with the reasons and numbers for people.
"""

import abc
import dataclasses
import enum
from collections.abc import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Bool, Float, Int

from .._exported import exported_jit
from .._result_codes import message
from .._validate import is_traced
from ._results import RESULTS
from ._simulate import Trajectory, on_one_device, padded_sample_count


class FoldVerdict(enum.StrEnum):
    """Outcome of a folding (a `str`: `report.verdict == "folded"` works). `VERDICT_CODES` gives the
    integer `fold_outcome` returns for each."""

    FOLDED = "folded"
    JAMMED = "jammed"
    MISFOLDED = "misfolded"
    UNFINISHED = "unfinished"
    INVALID = "invalid"


VERDICT_CODES = {v: i for i, v in enumerate(FoldVerdict)}
"""`FoldVerdict` → the integer code of `FoldOutcome.code` (folded 0, jammed 1, misfolded 2,
unfinished 3, invalid 4)."""


@dataclasses.dataclass(frozen=True)
class VerdictTolerances:
    """How close to the intended shape counts as folded: the verdict's two tolerances.

    **Fields:**
    - `angle`: rad (default 3°, ``0.0524``): every crease within this of its intended angle.
    - `seam`: `None` (the default): each seam's tolerance *derived* from the angle tolerance and
      the geometry (`derived_seam_tolerances`): the gap the seam has at the intended angles plus
      the root-sum-square of the gaps that each crease alone, off by the angle tolerance either
      way, opens. In plain words: a seam is closed when its gap is no larger than what creases
      that are each just within the angle tolerance would leave, so the two tolerances say the
      same thing and no seam is judged stricter than the creases that place it (for a cube of
      200 µm panels at 3°: 10–20 µm per seam). Needs a device whose coordinates are its hinge
      angles (nets and crease patterns are).
    - `seam` a number: a fixed fraction of the panel size ``L``: every seam's gap below
      ``seam · L``, with ``L`` the largest panel's size
      (`origami_jax.contact.ContactTables.scale`: the largest extent of any panel's outline along
      the axes; 200 µm for the catalogue's nets of 200 µm squares, so ``seam=0.01``, the default
      before the derived one, is 2 µm).

    A seam whose two panels touch (a sample point of one within 1.1 ``ĝ``, the contact's activation
    gap, of the other's face or rim) counts as closed whatever its gap (module
    docstring); `seam` judges the seams whose panels do not touch.

    A fixed fraction and the angle tolerance are not equally strict: a crease off by ``δθ`` opens a
    seam along a panel of size ``L`` by about ``L δθ``, so ``seam=0.01`` corresponds to about 0.6°
    of crease error, five times stricter than the 3° angle tolerance, and decides most verdicts of
    a net with seams (under the yield's default scatter about 3 cube nets in 10,000 passed it: the
    yield measured the tolerance). `seam_equivalent_angle` gives that angle.

    **Raises:** `ValueError` (one line, before anything compiles) for a tolerance that is not a
    finite number, not positive, an angle of π or more, or a seam fraction of 1 or more.
    """

    angle: float = float(np.radians(3.0))
    seam: float | None = None

    def __post_init__(self):
        for name, limit, unit in (("angle", np.pi, "rad"), ("seam", 1.0, "of the panel size")):
            value = getattr(self, name)
            if name == "seam" and value is None:
                continue  # derived from the angle tolerance and the geometry
            if isinstance(value, bool) or not isinstance(value, int | float | np.floating):
                raise ValueError(f"the {name} tolerance must be a number ({unit}), got {value!r}.")
            if not (np.isfinite(value) and 0 < value < limit):
                raise ValueError(
                    f"the {name} tolerance must lie in (0, {limit:.4g}) ({unit}), got {value!r}."
                )
            object.__setattr__(self, name, float(value))

    @classmethod
    def from_degrees(cls, angle_deg: float = 3.0, seam: float | None = None) -> "VerdictTolerances":
        """The tolerances with the angle in degrees (what the CLI takes); `seam` as the field
        (default `None`: derived)."""
        if isinstance(angle_deg, bool) or not isinstance(angle_deg, int | float | np.floating):
            raise ValueError(f"the angle tolerance must be a number (degrees), got {angle_deg!r}.")
        if not (np.isfinite(angle_deg) and 0 < angle_deg < 180):
            raise ValueError(
                f"the angle tolerance must lie in (0, 180) degrees, got {angle_deg!r}."
            )
        return cls(angle=float(np.radians(angle_deg)), seam=seam)

    @property
    def angle_deg(self) -> float:
        return float(f"{np.degrees(self.angle):.12g}")  # 3.0, not 3.0000000000000004

    @property
    def seam_equivalent_angle(self) -> float:
        """The crease error (rad) that opens a seam by the seam tolerance, ``seam`` (small angles;
        the angle tolerance itself when the seam tolerance is derived from it)."""
        return self.angle if self.seam is None else self.seam

    def seam_length(self, panel_size: float) -> float:
        """The seam tolerance in length units for panels of size `panel_size`.

        **Raises:** `ValueError` for a derived seam tolerance (it is one length per seam, from the
        geometry: `derived_seam_tolerances`)."""
        if self.seam is None:
            raise ValueError(
                "the seam tolerance is derived per seam from the geometry (seam=None), not a "
                "fraction of the panel size: give a fraction (e.g. seam=0.01) here."
            )
        return self.seam * float(panel_size)

    def to_dict(self) -> dict[str, float | str]:
        return {
            "angle_deg": self.angle_deg,
            "seam_fraction": "derived" if self.seam is None else self.seam,
        }


DEFAULT_TOLERANCES = VerdictTolerances()
"""The verdict's default tolerances: 3° per crease, each seam's tolerance derived from the 3° and
the geometry (`derived_seam_tolerances`)."""

LEGACY_SEAM_FRACTION = 0.01
"""The fixed seam tolerance that was the default before the derived one (1 % of the largest panel's
size): what a stored sweep or yield run whose settings name no seam tolerance was judged with."""


def derived_seam_tolerances(
    seam_gaps: Callable, intended_angles: Float[ArrayLike, " h"], angle: Float[ArrayLike, ""]
) -> Float[Array, " s"]:
    """Each seam's tolerance derived from the angle tolerance and the geometry (length, `(s,)`):

        tol_s = g_s(θ*) + sqrt(Σ_j max(|g_s(θ* + α e_j) − g_s(θ*)|, |g_s(θ* − α e_j) − g_s(θ*)|)²),

    with ``θ*`` the intended angles, ``α`` the angle tolerance (rad) and ``g`` the seam gaps as a
    function of the hinge angles (`seam_gaps`, e.g. `Net.seam_gap_function`; the mechanism's
    coordinates must be its hinge angles): the seam's own gap in the intended shape plus the
    root-sum-square of what each crease alone, off by the tolerance, opens (independent crease
    errors). ``2h + 1`` evaluations of the gaps; traceable."""
    intended = jnp.asarray(intended_angles, dtype=jnp.result_type(float))
    # A `SeamGaps` is a plain object, static to the compiled program by its identity: its gap
    # function (a net's, an `equinox.Module` whose numbers are arrays) is data, so the program
    # compiled for one folding serves the next.
    function = seam_gaps.function if isinstance(seam_gaps, SeamGaps) else seam_gaps
    return _derived_seam_tolerances(function, intended, jnp.asarray(angle, intended.dtype))


# One compiled program (op by op, the gaps' many small operations cost more than a verdict's run,
# and every verdict of a fold asks again); under an outer trace it is traced inline.
@exported_jit("seam_tolerances", by_value=True)
def _derived_seam_tolerances(seam_gaps, intended, angle):
    steps = angle * jnp.eye(intended.shape[0], dtype=intended.dtype)
    base = seam_gaps(intended)
    up = jax.vmap(seam_gaps)(intended + steps)
    down = jax.vmap(seam_gaps)(intended - steps)
    spread = jnp.maximum(jnp.abs(up - base), jnp.abs(down - base))
    return base + jnp.sqrt(jnp.sum(spread**2, axis=0))


def _tolerances(
    system, tolerances, angle_tolerance, seam_tolerance, panel_size, seam_gaps=None, intended=None
):
    """The angle (rad) and seam (length; one per seam when derived) tolerances of a verdict from
    its arguments."""
    if tolerances is None:
        tolerances = DEFAULT_TOLERANCES
    elif not isinstance(tolerances, VerdictTolerances):
        raise ValueError(
            f"tolerances must be a VerdictTolerances, got {type(tolerances).__name__}."
        )
    elif angle_tolerance is not None or seam_tolerance is not None:
        raise ValueError("give tolerances= or angle_tolerance=/seam_tolerance=, not both.")
    if angle_tolerance is None:
        angle_tolerance = tolerances.angle
    elif isinstance(angle_tolerance, int | float | np.floating) and not (
        np.isfinite(angle_tolerance) and 0 < angle_tolerance < np.pi
    ):
        raise ValueError(f"angle_tolerance must lie in (0, π) rad, got {angle_tolerance!r}.")
    if seam_tolerance is None and tolerances.seam is None:
        if seam_gaps is None:
            seam_tolerance = 1.0  # no seams: nothing to judge
        elif not system.mechanism.coordinates_are_hinge_angles:
            raise ValueError(
                "a derived seam tolerance (seam=None) needs a device whose coordinates are its "
                "hinge angles (a net); give this one a fraction of the panel size (seam=0.01)."
            )
        else:
            target = system.hinges.target if intended is None else intended
            seam_tolerance = derived_seam_tolerances(seam_gaps, target, angle_tolerance)
    if seam_tolerance is None:
        if panel_size is None and system.contact is not None:
            panel_size = system.contact.tables.scale
        # Without panel geometry: 1 length unit (the seams' scale is unknown).
        seam_tolerance = 1.0 if panel_size is None else tolerances.seam_length(panel_size)
    if isinstance(angle_tolerance, int | float | np.floating):
        angle_tolerance = float(angle_tolerance)
    return angle_tolerance, seam_tolerance


@dataclasses.dataclass(frozen=True)
class AbstractFoldReport(abc.ABC):
    """What every fold report holds: the verdict and the numbers behind it (host values; angles rad,
    lengths and times in the system's units). `FoldReport` is the plain one; a kind of pattern
    whose folding says more adds its own (`origami_jax.loops.LoopFoldReport`).

    **Fields:**
    - `verdict`: a `FoldVerdict`; `reason`: one line why.
    - `final_angles`, `intended_angles`, `angle_errors`: per crease `(h,)`.
    - `seam_gaps`: largest gap of each seam at the end `(s,)` (empty without seams);
      `seam_tolerance`, `angle_tolerance`.
    - `seams_touching`: per seam `(s,)`, whether its two panels touch at the end (a rim point of
      one over the other's face, coverage > 0, within 1.1 ``ĝ``): closed whatever its gap
      (empty without seams, all `False` without contact or when the seams' bodies are not known);
      `seams_closed_by_contact` lists those whose gap is above the tolerance.
    - `time_to_fold`: first time from which every crease stays within tolerance (and every seam
      closed) to the end, or `None`.
    - `settled`: the run came to rest: over its last tenth every crease stayed within half the
      tolerance of its final angle, and its drift there, carried on, would not move it further
      (`fold_outcome`); under agitation, in the statistical sense (`thermal_wobble`).
    - `contacts`: engaged (point, face) pairs at the end; `min_gap`: the smallest contact gap over the
      run (`inf` without contact); `max_penetration`: the largest penetration over the run (length)
      and `penetration_fraction` of the panel thickness (0 is the model's aim; both 0 without
      contact).
    - `result`: the solver's result message.
    - `length_unit`, `time_unit`: the system's length and time units, for printing ("µm", "µs").
    """

    verdict: FoldVerdict
    reason: str
    final_angles: np.ndarray
    intended_angles: np.ndarray
    angle_errors: np.ndarray
    seam_gaps: np.ndarray
    angle_tolerance: float
    seam_tolerance: float | np.ndarray
    time_to_fold: float | None
    settled: bool
    contacts: int
    min_gap: float
    max_penetration: float
    penetration_fraction: float
    result: str
    seams_touching: np.ndarray = dataclasses.field(
        default_factory=lambda: np.zeros(0, dtype=bool), kw_only=True
    )
    length_unit: str = dataclasses.field(default="µm", kw_only=True)
    time_unit: str = dataclasses.field(default="µs", kw_only=True)

    @property
    def seams_closed_by_contact(self) -> np.ndarray:
        """The seams whose gap is above the tolerance but whose panels touch (indices, `(k,)`)."""
        touching = np.asarray(self.seams_touching, dtype=bool)
        if touching.shape != np.shape(self.seam_gaps):
            return np.zeros(0, dtype=np.int64)
        return np.flatnonzero(touching & (np.asarray(self.seam_gaps) >= self.seam_tolerance))

    @property
    def off_target(self) -> np.ndarray:
        """Which creases end outside the angle tolerance, `(h,)` bool."""
        return np.abs(np.asarray(self.angle_errors, dtype=float)) > self.angle_tolerance

    def to_dict(self) -> dict:
        """JSON-ready dictionary (non-finite numbers as `None`)."""

        def clean(x):
            if isinstance(x, np.ndarray):
                return [clean(v) for v in x.tolist()]
            if isinstance(x, list):
                return [clean(v) for v in x]
            if isinstance(x, float):
                return x if np.isfinite(x) else None
            return x

        out = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        out["verdict"] = str(self.verdict)
        return {k: clean(v) for k, v in out.items()}

    def summary(self) -> str:
        """A few lines for people (angles in degrees, lengths and times in the system's units)."""
        length, time = self.length_unit, self.time_unit
        lines = [f"verdict: {self.verdict} ({self.reason})"]
        errors = np.degrees(self.angle_errors)
        lines.append(
            f"creases: {len(errors)}, largest error {np.max(np.abs(errors)):.3g}° "
            f"(tolerance {np.degrees(self.angle_tolerance):.3g}°)"
        )
        if len(self.seam_gaps):
            by_contact = self.seams_closed_by_contact
            touch = (
                f"; closed by contact (panels touching): seam {', '.join(map(str, by_contact))}"
                if len(by_contact)
                else ""
            )
            lines.append(
                f"seams: {len(self.seam_gaps)}, largest gap {np.max(self.seam_gaps):.3g} {length} "
                f"(tolerance {_length_text(self.seam_tolerance)} {length}){touch}"
            )
        if self.time_to_fold is not None:
            lines.append(f"time to fold: {self.time_to_fold:.4g} {time}")
        if np.isfinite(self.min_gap):
            lines.append(
                f"contact: {self.contacts} pairs engaged at the end, smallest gap "
                f"{self.min_gap:.3g} {length}, max penetration {self.max_penetration:.3g} {length} "
                f"({100 * self.penetration_fraction:.3g} % of the thickness)"
            )
        return "\n".join(lines)


@dataclasses.dataclass(frozen=True)
class FoldReport(AbstractFoldReport):
    """The verdict on a folding run and the numbers behind it (`fold_outcome`; the fields of
    `AbstractFoldReport`)."""


class FoldOutcome(eqx.Module):
    """The traceable verdict of one folding (arrays; a batch under `vmap` gives one per member).

    **Fields:** `code` (`VERDICT_CODES`); `time_to_fold` (time units, `inf` if it never got there);
    `settled`; `short` per crease (stopped short of its angle, same sign); `held` per crease (short,
    and more than the angle tolerance from its hinge's target: what contact must explain for
    `jammed`); `max_seam_gap` at the end
    (length, 0 without seams; a seam above the tolerance may still be closed by contact);
    `seam_gaps` per seam `(s,)`, its gap at the end (length; empty without seams);
    `seams_touching` per seam `(s,)`, its two panels touch at the end (closed whatever its gap;
    `False` without contact or without the seams' bodies); `max_open_seam_gap`, the largest final
    gap among the seams whose panels do not touch (length, 0 if none): what the rule compares with
    the seam tolerance; `engaged` contact pairs at the end;
    `min_gap` over the run (`inf` without contact); `penetration`, the largest over the run
    (length).

    The margins, what the folded test (the last state's) is at other tolerances:
    `angle_margin`, the largest crease error at the end over the angle tolerance (`inf` for a
    non-finite state); `seam_margin`, the largest gap over its seam's tolerance at the end among
    the seams whose panels do not touch (0 if none). With the angle tolerance multiplied by ``a``
    and every seam's tolerance by ``s``, the last state passes iff ``angle_margin < a`` and
    ``seam_margin < s`` (for ``a = s = 1``: iff the verdict is folded, for a run that succeeded):
    the yield at any tolerance is a count of the stored margins
    (`origami_jax.fab_yield.tolerance_sensitivity`).
    """

    code: Int[Array, ""]
    time_to_fold: Float[Array, ""]
    settled: Bool[Array, ""]
    short: Bool[Array, " h"]
    held: Bool[Array, " h"]
    max_seam_gap: Float[Array, ""]
    seam_gaps: Float[Array, " s"]
    seams_touching: Bool[Array, " s"]
    max_open_seam_gap: Float[Array, ""]
    engaged: Int[Array, ""]
    min_gap: Float[Array, ""]
    penetration: Float[Array, ""]
    angle_margin: Float[Array, ""]
    seam_margin: Float[Array, ""]


# The verdict's contact report holds at most about this many float64 intermediates at once
# (1 GB): a run's samples are judged together under `vmap` up to it, in batches past it.
_REPORT_ELEMENTS = 1 << 27


def _report_size(contact) -> int:
    """About how many intermediates one state's contact report holds (`PlateContact.report`: every
    primitive pair's gap, every pair of plates' exact overlap over ``v²`` separating axes), an
    upper estimate; 0 for contacts without plate tables."""
    tables = getattr(contact, "tables", None)
    if not hasattr(tables, "n_primitives") or not hasattr(tables, "plate_pairs"):
        return 0
    v = tables.vertices.shape[1]
    return 32 * (tables.n_primitives + len(tables.plate_pairs[0]) * v * v)


def _each_sample(f, states, size: int):
    """``vmap(f)(states)`` over the samples `(t, ...)`, in batches of samples whose intermediates
    (`size` per sample) stay within `_REPORT_ELEMENTS` (`jax.lax.map`): a large pattern's report of
    a thousand samples at once would need tens of GB."""
    batch = _REPORT_ELEMENTS // max(size, 1)
    if batch >= states.shape[0]:
        return jax.vmap(f)(states)
    return jax.lax.map(f, states, batch_size=max(batch, 1))


def fold_outcome(
    system,
    trajectory: Trajectory,
    *,
    intended_angles=None,
    seam_gaps: Callable | None = None,
    tolerances: VerdictTolerances | None = None,
    angle_tolerance: float | Array | None = None,
    seam_tolerance=None,
    panel_size: float | None = None,
) -> FoldOutcome:
    """The verdict of `assess` as arrays, traceable (`jit`, `vmap`): see `assess` for the arguments;
    `seam_gaps` must be traceable here (a function of the mechanism's coordinates ``q``).

    Every saved state is judged (so `time_to_fold` is when the rule held for good): creases within
    the angle tolerance and every seam closed, its gap below the seam tolerance or, when
    `seam_gaps` names the seams' bodies (its `bodies`, `(s, 2)`, numbered as the contact tables:
    the base last), its two bodies touching in the contact's `report` (`touching`, either way
    round), from the one contact evaluation per state that also gives `min_gap`, `engaged` and
    `penetration`.

    Called on one concrete run (outside any transformation) it runs as `assess` does, one
    compiled program per model structure and power of two of samples, with the tolerances as its
    data: judging another run of the model, or with other tolerances, compiles nothing."""
    arguments = (system, trajectory, intended_angles, angle_tolerance, seam_tolerance, panel_size)
    if not is_traced(*arguments) and np.ndim(trajectory.theta) == 2:
        return _judged(
            system, trajectory, intended_angles, seam_gaps, tolerances, angle_tolerance,
            seam_tolerance, panel_size,
        )[0]  # fmt: skip
    angle_tolerance, seam_tolerance = _tolerances(
        system, tolerances, angle_tolerance, seam_tolerance, panel_size, seam_gaps, intended_angles
    )
    times, theta = trajectory.times, trajectory.theta
    q = theta if trajectory.state is None else trajectory.state[0]
    if seam_gaps is not None and getattr(seam_gaps, "bodies", None) is not None:
        # Before any work: the seams' count from the function's output shape alone.
        _checked_bodies(seam_gaps.bodies, jax.eval_shape(seam_gaps, q[0]).shape[-1])
    intended = system.hinges.target if intended_angles is None else jnp.asarray(intended_angles)
    dtype = theta.dtype
    finite = jnp.all(jnp.isfinite(theta), axis=-1)
    q_safe = jnp.where(finite[:, None], q, 0.0)
    contact = system.contact
    touching = None  # (t, n, n): some point of body a rests on the face of body b
    if contact is not None:
        report = _each_sample(
            lambda q: contact.report(system.mechanism, q), q_safe, _report_size(contact)
        )
        min_gap = jnp.min(jnp.where(finite, report["min_gap"], jnp.inf))
        penetration = jnp.max(jnp.where(finite, report["penetration"], 0.0))
        engaged = jnp.where(finite[-1], report["engaged"][-1], 0).astype(jnp.int32)
        touching = report.get("touching")
    else:
        min_gap = jnp.asarray(jnp.inf, dtype)
        penetration = jnp.zeros((), dtype)
        engaged = jnp.zeros((), jnp.int32)
    within = jnp.all(jnp.abs(theta - intended) < angle_tolerance, axis=-1) & finite
    max_gap = open_gap = seam_margin = jnp.zeros((), dtype)
    final_gaps = jnp.zeros((0,), dtype)
    seams_touching = jnp.zeros((0,), bool)
    if seam_gaps is not None:
        gaps = jax.vmap(seam_gaps)(q_safe)  # (t, s)
        touch = _seams_touching(touching, getattr(seam_gaps, "bodies", None), gaps.shape)
        if gaps.shape[-1]:
            # Closed: within the tolerance, or held shut by its two panels touching.
            within = within & jnp.all((gaps < seam_tolerance) | touch, axis=-1)
            max_gap = jnp.max(gaps[-1])
            open_gap = jnp.max(jnp.where(touch[-1], 0.0, gaps[-1]))
            # gap < tolerance · s  ⇔  gap / tolerance < s (the tolerances are positive).
            seam_margin = jnp.max(jnp.where(touch[-1], 0.0, gaps[-1] / seam_tolerance))
        seams_touching = touch[-1] & finite[-1]
        final_gaps = gaps[-1]
    final = theta[-1]
    angle_margin = jnp.where(
        finite[-1], jnp.max(jnp.abs(final - intended), initial=0.0) / angle_tolerance, jnp.inf
    )
    # A crease released in the run's last tenth (or after its end) has had no time to come to
    # rest: the run is unfinished, not misfolded, whatever its angles.
    settled = _settled(times, theta, angle_tolerance, thermal_wobble(system)) & ~jnp.any(
        _released_late(system, times)
    )
    # Stays within from sample k on: a reversed cumulative AND.
    stays = jnp.flip(jnp.cumprod(jnp.flip(within).astype(jnp.int32))).astype(bool)
    first = jnp.argmax(stays)
    time_to_fold = jnp.where(within[-1], times[first], jnp.inf)
    short = (jnp.abs(final) < jnp.abs(intended) - angle_tolerance) & (
        jnp.sign(final) * jnp.sign(intended) >= 0
    )
    # Contact holds a crease short: it rests more than the angle tolerance away from where its
    # own hinge would put it (every hinge of a tree of panels without contact rests at its
    # target). A crease whose film bends it short of the intended angle, with panels merely near
    # each other (or holding another crease, one that would overfold, at its angle), is
    # misfolded, whatever contact pairs happen to lie within the activation layer.
    held = short & (jnp.abs(final - system.hinges.target) > angle_tolerance)
    codes = VERDICT_CODES
    code = jnp.where(
        within[-1],
        codes[FoldVerdict.FOLDED],
        jnp.where(
            ~settled,
            codes[FoldVerdict.UNFINISHED],
            jnp.where(
                jnp.any(held) & (engaged > 0),
                codes[FoldVerdict.JAMMED],
                codes[FoldVerdict.MISFOLDED],
            ),
        ),
    )
    ok = trajectory.result == RESULTS.successful
    out_of_steps = trajectory.result == RESULTS.max_steps_reached
    code = jnp.where(
        ok, code, jnp.where(out_of_steps, codes[FoldVerdict.UNFINISHED], codes[FoldVerdict.INVALID])
    )
    return FoldOutcome(
        code=code.astype(jnp.int32),
        time_to_fold=time_to_fold,
        settled=settled,
        short=short,
        held=held,
        max_seam_gap=max_gap,
        seam_gaps=final_gaps,
        seams_touching=seams_touching,
        max_open_seam_gap=open_gap,
        engaged=engaged,
        min_gap=min_gap,
        penetration=penetration,
        angle_margin=angle_margin,
        seam_margin=seam_margin,
    )


# How many thermal wobbles an agitated crease may move over the tail and still be at rest: the
# largest of ~30 differences (the tail of 301 samples) of two independent samples of a spread σ
# stays below 6σ (4.2 standard deviations of a difference) but for ~7e-4 per crease.
_WOBBLES_AT_REST = 6.0


def thermal_wobble(system) -> Float[Array, " h"] | float:
    """Each crease's equilibrium wobble under the system's agitation, ``sqrt(k_B T / k)`` (rad,
    `(h,)`), from its hinge's stiffness ``k``: the rms angle of a harmonic hinge at the bath's
    temperature (exact without contact whatever the masses and drag; contact only confines it);
    0.0 without agitation."""
    agitation = getattr(system, "agitation", None)
    if agitation is None:
        return 0.0
    return jnp.sqrt(agitation.thermal_energy(system.units) / system.hinges.stiffness)


def _settled(times, theta, angle_tolerance, wobble=0.0):
    """Whether the run has come to rest: over its last tenth of samples (at least three) every
    crease stayed within half the angle tolerance of its final angle, and where a crease moved the
    same way throughout that tail, its drift, carried on, would not take it further than that.

    Under agitation a crease at rest still wobbles: each crease's bound grows by
    `_WOBBLES_AT_REST` times its thermal `wobble` (rad, scalar or `(h,)`; `thermal_wobble`), so
    the run is judged at rest in the statistical sense (its noise stationary) rather than
    `unfinished` for its noise; and a drift is judged from the part means below when they move one
    way by more than ``4 √2`` wobbles (no noisy tail moves one way at every sample; two means of a
    stationary wobble differ by ``σ √2`` rms at most, however correlated its samples), so a drift
    that the noise could hide over the tail goes unseen.

    The drift: the mean angle over three equal parts ending the tail, ``m₁, m₂, m₃``, ``d₂ = m₂ − m₁``,
    ``d₁ = m₃ − m₂``. A decaying drift (``|d₁| < |d₂|``, ratio ``r``) has ``|d₁| r/(1 − r)`` still to
    go (a geometric series, as an exponential approach gives); one that does not decay is carried
    on for as long as the run has lasted so far (``d₁`` per part), which also bounds the series. A
    crease that turned within the tail is ringing (or at rest, within rounding), bounded by the
    first condition. Without the drift, an overdamped crease still creeping towards its angle, or
    one only starting to move, could move less than the bound in the tail and be judged at rest.
    A crease speeding up one way over the whole tail (each step at least as long as the one before)
    is never at rest: a run too short to see it move far (a tiny end time) is unfinished.

    Rows with a NaN time are padding (`assess` pads runs of nearby lengths to one shape) and are not
    counted; a run of one or two samples is its own tail, without a drift to judge."""
    total = theta.shape[0]
    count = jnp.sum(jnp.isfinite(times))
    tail = jnp.minimum(jnp.maximum(3, count // 10), count)  # a run of 1 or 2 samples: all of it
    position = jnp.arange(total) - (total - tail)  # 0 … tail − 1 over the tail
    recent = (position >= 0)[:, None]
    final = theta[-1]
    moved_each = jnp.max(jnp.where(recent, jnp.abs(theta - final), 0.0), axis=0)
    # Safe against non-finite rows before the tail (front padding; an invalid run is judged
    # elsewhere).
    tail_theta = jnp.where(recent, theta, final)
    steps = jnp.diff(tail_theta, axis=0)
    outside = ~recent[:-1]  # steps from a row before the tail
    one_way = jnp.all((steps >= 0) | outside, axis=0) | jnp.all((steps <= 0) | outside, axis=0)
    # Three parts of equal length ending at the last sample (their means equally spaced in time, so
    # that the ratio of successive drifts is an exponential's decay factor).
    length = jnp.maximum(tail // 3, 1)
    part = jnp.where(position >= tail - 3 * length, (position - (tail - 3 * length)) // length, -1)
    means = []
    for k in range(3):
        weight = (part == k).astype(theta.dtype)[:, None]
        means.append(jnp.sum(tail_theta * weight, axis=0) / length)
    late, early = means[2] - means[1], means[1] - means[0]
    # Under agitation no tail is monotone: a drift counts where the part means move one way by
    # more than four times the spread of a difference of two means of the stationary wobble,
    # ``σ √2`` whatever its correlation time (a slow mode's samples are far from independent: in
    # the bath a crease's wobble wanders over milliseconds, longer than a tail).
    wobble = jnp.asarray(wobble, theta.dtype)
    one_way = one_way | (
        (wobble > 0) & (late * early > 0) & (jnp.abs(late + early) > 4 * np.sqrt(2) * wobble)
    )
    horizon = count / length  # the run's length in parts
    decaying = jnp.abs(late) < jnp.abs(early)
    ratio = jnp.abs(late) / jnp.where(decaying, jnp.abs(early), 1.0)
    carried = jnp.where(decaying, jnp.minimum(ratio / (1 - ratio), horizon), horizon)
    # Speeding up one way over the whole tail (every step at least as long as the one before, the
    # last not zero): a crease starting to move, as at the start of a run too short to see it go
    # far (a tiny end time), is not at rest however little it has moved.
    speeding = False
    if total >= 3:
        sizes = jnp.abs(steps)
        growing = jnp.all((sizes[1:] >= sizes[:-1]) | outside[:-1], axis=0) & (sizes[-1] > 0)
        speeding = jnp.any(one_way & growing & (tail >= 3))
    bound = angle_tolerance / 2 + _WOBBLES_AT_REST * wobble
    moved = jnp.all(moved_each < bound)
    to_go = jnp.all(jnp.where(one_way & (tail >= 3), jnp.abs(late) * carried, 0.0) < bound)
    return moved & to_go & ~speeding


def _released_late(system, times):
    """Per crease `(h,)`, whether it is released after the first sample of the run's last tenth
    (the tail `_settled` judges; padding rows of NaN time not counted); all `False` without release
    times. Works on host and traced arrays alike."""
    release = system.hinges.release_time
    xp = jnp if is_traced(times, release) else np
    if release is None:
        return xp.zeros(system.hinges.target.shape, dtype=bool)
    total = times.shape[0]
    count = xp.sum(xp.isfinite(times))
    tail = xp.minimum(xp.maximum(3, count // 10), count)
    return release > times[total - tail]


@exported_jit("fold_outcome")
def _outcome_compiled(
    system, trajectory, intended, function, bodies, angle_tolerance, seam_tolerance
):
    """`assess`'s `fold_outcome` in one compiled program (op by op, a first verdict compiled one per
    operation: seconds), shared by every verdict on a model of the same structure: the tolerances
    are traced, and a net's seam function (`function`, an `equinox.Module`) is data; `bodies`, the
    seams' bodies, a static tuple (`None` when not known). In a command its traced program is
    read from disk (`exported_jit`)."""
    seam_gaps = None
    if function is not None:
        seam_gaps = function if bodies is None else SeamGaps(function, bodies)
    return fold_outcome(
        system,
        trajectory,
        intended_angles=intended,
        seam_gaps=seam_gaps,
        angle_tolerance=angle_tolerance,
        seam_tolerance=seam_tolerance,
    )


class SeamGaps:
    """The gaps of a device's seams as a traceable function of the mechanism's coordinates, and
    which two bodies each seam joins (what the verdict needs to call a seam closed by contact).

    Call it: ``seam_gaps(q)`` gives each seam's gap (length, `(s,)`): the larger distance between
    the two sides' corners at either end of the seam.

    **Fields:**
    - `function`: ``q ↦`` the gaps; for a net's seams an `equinox.Module` (its numbers are arrays,
      so the verdict compiled for one folding serves the next).
    - `bodies`: `(s, 2)` int (host), the bodies on the two sides of each seam, numbered as in the
      contact tables (`origami_jax.contact.ContactTables`): moving bodies ``0 … b−1``, the fixed
      base (the net's root face) ``b`` = the mechanism's `n_bodies`.
      `origami_jax.simulation.fold_outcome` reads it: a seam counts as closed when its gap is
      within the tolerance or these two bodies touch (`origami_jax.simulation.VerdictTolerances`).
    """

    def __init__(self, function, bodies):
        self.function = function
        self.bodies = np.asarray(bodies, dtype=np.int64).reshape(-1, 2)

    def __call__(self, q: Float[ArrayLike, " nq"]) -> Float[Array, " s"]:
        return self.function(q)

    def __repr__(self) -> str:
        return f"SeamGaps({len(self.bodies)} seams, bodies={self.bodies.tolist()})"


def _length_text(tolerance) -> str:
    """A seam tolerance for people: one length, or the range of the per-seam (derived) ones."""
    values = np.atleast_1d(np.asarray(tolerance, dtype=float))
    if values.size == 1 or np.ptp(values) == 0:
        return f"{values[0]:.3g}"
    return f"{values.min():.3g}–{values.max():.3g} per seam"


def _checked_bodies(bodies, n_seams: int) -> np.ndarray:
    """`seam_gaps.bodies` as a host `(n_seams, 2)` int array, or `ValueError`."""
    bodies = np.asarray(bodies)
    if bodies.shape != (n_seams, 2) or not np.issubdtype(bodies.dtype, np.integer):
        raise ValueError(
            f"seam_gaps.bodies must be {n_seams} pairs of body indices (int, shape "
            f"({n_seams}, 2)), got {bodies.dtype} {bodies.shape}."
        )
    return bodies


def _seams_touching(touching, bodies, shape):
    """Whether each seam's two bodies touch, `(t, s)` bool, from the contact's `touching`
    `(t, n, n)` (`None` without contact) and the seams' bodies `(s, 2)` (host; `None`: unknown,
    nothing touches). A body outside the contact's tables (a base the contact does not model)
    touches nothing."""
    if touching is None or bodies is None:
        return jnp.zeros(shape, bool)
    bodies = np.asarray(bodies)  # checked by `fold_outcome` before any work
    n = touching.shape[-1]
    known = np.all((bodies >= 0) & (bodies < n), axis=1)
    a, b = np.where(known[:, None], bodies, 0).T
    return (touching[:, a, b] | touching[:, b, a]) & known


# The fewest samples a verdict is compiled for: a run folded in segments of up to 512 samples (the
# fold command's are 501) and its first continuation share one program; the padding costs
# milliseconds (a cube net's verdict: 16 ms at 1024 samples against 13.5 at 512).
_MIN_VERDICT_SAMPLES = 1024


def _front_padded(trajectory: Trajectory) -> Trajectory:
    """`trajectory` with rows of NaN put in front of its samples up to `padded_sample_count` of them
    (at least `_MIN_VERDICT_SAMPLES`; and without its dense solution), so that runs of nearby
    lengths (a run continued segment by segment) share one compiled verdict: `fold_outcome` judges
    the padded run as the run itself (a NaN time marks padding; a NaN state is not within any
    tolerance)."""
    count = trajectory.times.shape[0]
    extra = max(padded_sample_count(count), _MIN_VERDICT_SAMPLES) - count

    def pad(x):
        # On the host: an eager concatenation would compile a program per shape.
        if extra == 0 or jnp.ndim(x) == 0 or jnp.shape(x)[0] != count:
            return x
        x = np.asarray(x)
        return jax.device_put(np.concatenate([np.full((extra, *x.shape[1:]), np.nan, x.dtype), x]))

    return Trajectory(
        times=pad(trajectory.times),
        theta=pad(trajectory.theta),
        theta_dot=pad(trajectory.theta_dot),
        theta_ddot=pad(trajectory.theta_ddot),
        tau=pad(trajectory.tau),
        target=trajectory.target,
        stats=trajectory.stats,
        result=trajectory.result,
        state=None if trajectory.state is None else jax.tree.map(pad, trajectory.state),
    )


def _judged(
    system, trajectory, intended_angles, seam_gaps, tolerances, angle_tolerance, seam_tolerance,
    panel_size,
):  # fmt: skip
    """`fold_outcome` of one concrete run through its compiled program (`_outcome_compiled`, the
    run padded in front), and the angle tolerance, seam tolerance(s) and intended angles it was
    judged with (host values)."""
    angle_tolerance, seam_tolerance = _tolerances(
        system, tolerances, angle_tolerance, seam_tolerance, panel_size, seam_gaps, intended_angles
    )
    seam_tolerance = np.asarray(seam_tolerance, dtype=float)
    if seam_tolerance.ndim == 0:
        seam_tolerance = float(seam_tolerance)
    if trajectory.theta.ndim != 2:
        raise ValueError(
            "assess takes one trajectory; for a batch, use fold_outcome under jax.vmap (or the "
            "sweep's verdict outputs)."
        )
    intended = np.asarray(
        system.hinges.target if intended_angles is None else intended_angles, dtype=float
    )
    if intended.shape != trajectory.theta.shape[-1:]:
        raise ValueError(
            f"intended_angles must have shape {trajectory.theta.shape[-1:]}, got {intended.shape}."
        )
    bodies = getattr(seam_gaps, "bodies", None)
    if seam_gaps is not None:
        # One tolerance per seam whether derived or fixed: one compiled verdict serves both.
        if bodies is not None:
            n_seams = len(bodies)  # checked against the function's output when it is traced
        else:
            q0 = trajectory.theta[0] if trajectory.state is None else trajectory.state[0][0]
            n_seams = jax.eval_shape(seam_gaps, q0).shape[-1]
        judged_tolerance = np.broadcast_to(seam_tolerance, (n_seams,))
    else:
        judged_tolerance = seam_tolerance
    # On one device: a run's arrays are committed to a device or not depending on how they were
    # computed (the command line's exported solve returns committed ones), and each pattern of
    # committed arguments would compile the verdict again.
    arguments = on_one_device(
        (
            system,
            _front_padded(trajectory),
            intended,
            getattr(seam_gaps, "function", seam_gaps),
            None if bodies is None else tuple(map(tuple, np.asarray(bodies).tolist())),
            # Put, not converted: `jnp.asarray` compiles a program per new shape (the same
            # weak or strong type either way, so the same kept verdict program).
            jax.device_put(angle_tolerance),
            jax.device_put(judged_tolerance),
        )
    )
    return _outcome_compiled(*arguments), angle_tolerance, seam_tolerance, intended


def assess(
    system,
    trajectory: Trajectory,
    *,
    intended_angles=None,
    seam_gaps: Callable | None = None,
    tolerances: VerdictTolerances | None = None,
    angle_tolerance: float | None = None,
    seam_tolerance: float | None = None,
    panel_size: float | None = None,
    thickness: float | None = None,
) -> FoldReport:
    """The verdict on a simulated folding (module docstring).

    **Arguments:**
    - `system`, `trajectory`: the [`origami_jax.system.FoldingSystem`][] and its simulation (one, not
      batched).
    - `intended_angles`: the fold angle each crease should reach (rad, `(h,)`); default the system's
      hinge targets.
    - `seam_gaps`: a traceable function of the mechanism's coordinates ``q`` returning each seam's gap
      (length, `(s,)`), e.g. `Net.seam_gap_function`; `None` for a device without seams. With a
      `bodies` attribute (`(s, 2)` int, the two bodies each seam joins, numbered as in the
      contact tables, as `origami_jax.net.SeamGaps` has) a seam whose panels touch counts as
      closed whatever its gap (module docstring); a plain function judges the gaps alone.
    - `tolerances`: a `VerdictTolerances` (default: 3°, each seam's tolerance derived from it and
      the geometry; `VerdictTolerances(seam=0.01)`: seams within 1 % of the panel size), or
      the two as `angle_tolerance` (rad) and `seam_tolerance` (a length; not both ways).
    - `panel_size`: the ``L`` the seam tolerance is a fraction of (length; default the contact
      model's largest panel, `ContactTables.scale`; a system without contact and without
      `panel_size` gets a seam tolerance of 1 length unit). `origami_jax.net.Net.assess` gives
      the net's.
    - `thickness`: panel thickness for `penetration_fraction` (default: twice the contact model's
      smallest half thickness).

    **Returns:** a `FoldReport`.

    The verdict runs as one compiled program per model structure and per power of two of samples
    (at least 1024; the run is padded in front; the verdict is the unpadded run's), so that judging
    another run of the same model compiles nothing.
    """
    outcome, angle_tolerance, seam_tolerance, intended = _judged(
        system, trajectory, intended_angles, seam_gaps, tolerances, angle_tolerance,
        seam_tolerance, panel_size,
    )  # fmt: skip
    outcome = jax.device_get(outcome)
    contact = system.contact
    if thickness is None and contact is not None:
        thickness = 2 * float(np.min(np.asarray(contact.half_thickness)))
    theta = np.asarray(trajectory.theta)
    final = theta[-1]
    errors = final - intended
    gaps_final = np.zeros(0)
    if seam_gaps is not None and np.all(np.isfinite(final)):
        gaps_final = np.asarray(outcome.seam_gaps, dtype=float)
    seams_touching = np.asarray(outcome.seams_touching, dtype=bool)
    if seams_touching.shape != gaps_final.shape:  # a failed run: no final seams
        seams_touching = np.zeros(gaps_final.shape, dtype=bool)
    verdict = list(FoldVerdict)[int(outcome.code)]
    result = message(trajectory.result, RESULTS)
    if not bool(trajectory.succeeded):
        reason = (
            f"the solver ran out of steps ({result})"
            if verdict == FoldVerdict.UNFINISHED
            else f"the simulation failed: {result}"
        )
    elif verdict == FoldVerdict.FOLDED:
        reason = "every crease at its angle, every seam closed"
        by_contact = np.flatnonzero(seams_touching & (gaps_final >= seam_tolerance))
        if len(by_contact):
            reason += (
                f" (seam {', '.join(map(str, by_contact))} by contact: its panels touch, gap "
                f"{np.max(gaps_final[by_contact]):.3g} above the tolerance "
                f"{_length_text(seam_tolerance)})"
            )
    elif verdict == FoldVerdict.UNFINISHED:
        late = np.flatnonzero(_released_late(system, np.asarray(trajectory.times)))
        reason = "still moving at the end of the run"
        if len(late):
            when = np.asarray(system.hinges.release_time)[late]
            reason = (
                f"crease {', '.join(map(str, late))} released at "
                f"{', '.join(f'{t:g}' for t in when)} {system.units.time_symbol}, too near the end "
                "of the run (or after it) to judge: run longer"
            )
    elif verdict == FoldVerdict.JAMMED:
        creases = ", ".join(str(i) for i in np.nonzero(outcome.held)[0])
        reason = f"contact stops crease(s) {creases} short"
    elif np.all(np.abs(errors) < angle_tolerance):
        reason = "creases at their angles but seams open"
    else:
        worst = int(np.argmax(np.abs(errors)))
        reason = (
            f"crease {worst} at {np.degrees(final[worst]):.1f}° instead of "
            f"{np.degrees(intended[worst]):.1f}°"
        )
        rest = np.asarray(system.hinges.target)[worst]
        if abs(final[worst] - rest) <= angle_tolerance < abs(rest - intended[worst]):
            reason += f", where its hinge rests ({np.degrees(rest):.1f}°)"
    time_to_fold = float(outcome.time_to_fold)
    penetration = float(outcome.penetration)
    return FoldReport(
        verdict=verdict,
        reason=reason,
        final_angles=final,
        intended_angles=intended,
        angle_errors=errors,
        seam_gaps=gaps_final,
        angle_tolerance=float(angle_tolerance),
        seam_tolerance=seam_tolerance,
        time_to_fold=time_to_fold if np.isfinite(time_to_fold) else None,
        settled=bool(outcome.settled),
        contacts=int(outcome.engaged),
        min_gap=float(outcome.min_gap),
        max_penetration=penetration,
        penetration_fraction=penetration / thickness if thickness else 0.0,
        result="successful" if result == "" else str(result),
        seams_touching=seams_touching,
        length_unit=system.units.length_symbol,
        time_unit=system.units.time_symbol,
    )
