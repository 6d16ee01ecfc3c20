"""The charge-energy unfolding path of a single vertex beside the dynamics of the same vertex folding.

The paper's first half unfolds a folded single vertex by charge-energy descent (paper Eqs. 1–6,
`origami_jax.vertex.unfold`): a collision-free path from the folded state to flat. Run backwards it is
a way to *fold* the vertex. Is it a way the device can take? `compare_unfolding` answers in one call:

1. the vertex becomes a crease pattern (`vertex_pattern`: a flat fan of triangular panels around one
   interior vertex, its creases at the vertex's sector angles) and a folding system with the design's
   bilayer hinges, each aimed at the vertex's fold angle;
2. `unfold` gives the charge-energy path, reversed (flat → folded);
3. dynamics twice, both from flat with the panels' inertia and the fluid's drag: **driven** along the
   path (each hinge's spring target follows the path's angle for that crease over `duration`, then
   holds; `PathInput`) and **released** (every hinge at once, the step of paper Eq. 12);
4. every path is certified like the unfolding path (`origami_jax.vertex.certify_path`: no two
   non-adjacent flaps cross, no fold passes ±180°), judged (`folded` or not) and compared with the
   charge-energy path at equal progress (the fraction of the way from flat to the folded angles).

Contact is off (the charge model has no thickness, and a corner cube's gusset folds its two 45°
flaps flat onto each other); crossings are what the certificate checks.
"""

import dataclasses

import diffrax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ..fold import FoldFile, FoldFrame
from ..simulation import FIT_ATOL, FIT_RTOL, AbstractInput, SaveAt, SolveOptions, Step, simulate
from ..system import KOH_SOLUTION, HingeDesign
from ..vertex import certify_path, chain_from_fold_angles, corner_cube, fold_angles, unfold
from ._pattern import load_pattern

# The flaps of `vertex_pattern` reach this far from the vertex (µm).
FLAP_RADIUS_UM = 200.0


class PathInput(AbstractInput):
    """Hinge springs whose targets follow a path of fold angles: ``τ = K θ_path(t)``, piecewise linear
    between `times` (time units, `(k,)`), then held at the last row of `angles` (rad, `(k, h)`)."""

    times: Float[Array, " k"]
    angles: Float[Array, "k h"]

    def torque(self, t, theta, theta_dot, system):
        del theta, theta_dot
        column = jnp.stack(
            [jnp.interp(t, self.times, self.angles[:, j]) for j in range(self.angles.shape[1])]
        )
        return system.hinges.stiffness * column

    def target(self, system):
        del system
        return self.angles[-1]


def vertex_pattern(vertex, *, radius: float = FLAP_RADIUS_UM) -> FoldFile:
    """A flat crease pattern of one interior vertex with the sectors of `vertex` (a closed
    `SingleVertex`): crease ``i`` along the ray at ``Σ_{k<i} α_k``, each sector a triangular panel out
    to `radius` µm, targets the vertex's fold angles (valley +)."""
    if not vertex.closed:
        raise ValueError("compare_unfolding takes an interior (closed) vertex; this one is open.")
    sectors = np.asarray(vertex.sector_angles, dtype=float)
    if np.any(sectors >= np.pi):
        raise ValueError("every sector must be below 180° for triangular panels.")
    folds = np.asarray(fold_angles(vertex), dtype=float)
    n = len(sectors)
    rays = np.concatenate([[0.0], np.cumsum(sectors)[:-1]])
    coords = [(0.0, 0.0)] + [(radius * np.cos(a), radius * np.sin(a)) for a in rays]
    faces = [(0, 1 + i, 1 + (i + 1) % n) for i in range(n)]
    edges = [(0, 1 + i) for i in range(n)] + [(1 + i, 1 + (i + 1) % n) for i in range(n)]
    assignment = ["V" if f > 0 else "M" if f < 0 else "F" for f in folds] + ["B"] * n
    angles = list(np.degrees(folds)) + [0.0] * n
    frame = FoldFrame(
        vertices_coords=np.asarray(coords),
        edges_vertices=np.asarray(edges),
        edges_assignment=tuple(assignment),
        edges_fold_angle_deg=np.asarray(angles),
        faces_vertices=tuple(faces),
        frame_unit="um",
        frame_classes=("creasePattern",),
    )
    return FoldFile(frames=(frame,), file_metadata={"file_title": "single vertex"})


@dataclasses.dataclass(frozen=True)
class DynamicPath:
    """One simulated folding of the vertex: `times` `(t,)`, `angles` `(t, n)` (rad, the vertex's crease
    order), `certificate` (`origami_jax.vertex.Certificate`), `verdict` (`FoldVerdict`), `report`,
    `deviation`: the largest fold-angle difference (rad) from the charge-energy path at equal
    progress, `reached`: the final progress (1 = the folded angles)."""

    times: np.ndarray
    angles: np.ndarray
    certificate: object
    verdict: str
    report: object
    deviation: float
    reached: float


@dataclasses.dataclass(frozen=True)
class PathComparison:
    """What `compare_unfolding` found (angles rad, the vertex's crease order).

    - `unfolding`: the `UnfoldResult`; `folding_angles` `(k, n)`: its path reversed (flat → folded),
      `folding_progress` `(k,)`.
    - `driven`: the dynamics driven along that path; `released`: released at once (`DynamicPath`).
    - `takeable`: the driven device folds (`folded`) with a crossing-free certificate: the
      charge-energy path is one the device can take.
    """

    unfolding: object
    folding_angles: np.ndarray
    folding_progress: np.ndarray
    driven: DynamicPath
    released: DynamicPath | None
    takeable: bool

    def summary(self) -> str:
        lines = [
            f"charge-energy unfolding: {self.unfolding.verdict.value} in "
            f"{len(self.folding_angles)} states",
        ]
        for name, path in (("driven along it", self.driven), ("released at once", self.released)):
            if path is None:
                continue
            cert = path.certificate
            lines.append(
                f"dynamics {name}: {path.verdict}, reached {100 * path.reached:.1f} %, "
                f"{'no crossings' if not cert.crossing_states else 'CROSSINGS'} (min clearance "
                f"{np.degrees(cert.min_clearance):.3g}°), largest deviation from the charge-energy "
                f"path {np.degrees(path.deviation):.3g}°"
            )
        lines.append(
            "the charge-energy path is "
            + ("one the device can take" if self.takeable else "not one the device takes")
        )
        return "\n".join(lines)


def _progress(angles: np.ndarray, final: np.ndarray) -> np.ndarray:
    """Fraction of the way from flat to `final` (projection on the final angles)."""
    return angles @ final / float(final @ final)


def _deviation(angles, progress, reference, reference_progress) -> float:
    """Largest fold-angle difference from the reference path at equal progress (the reference
    interpolated, both within the reference's progress range)."""
    order = np.argsort(reference_progress)
    ref_p = reference_progress[order]
    ref = reference[order]
    inside = (progress >= ref_p[0]) & (progress <= ref_p[-1])
    if not np.any(inside):
        return float("inf")
    interpolated = np.stack(
        [np.interp(progress[inside], ref_p, ref[:, j]) for j in range(ref.shape[1])], axis=-1
    )
    return float(np.max(np.abs(angles[inside] - interpolated)))


UNFOLDING_OPTIONS = SolveOptions(
    saveat=SaveAt(n=401),
    solver=diffrax.Tsit5(),
    rtol=FIT_RTOL,
    atol=FIT_ATOL,
    max_steps=400_000,
    throw=False,
)
"""The default runs of `compare_unfolding`: explicit Tsit5 (the vertex runs without contact), 401
samples, rtol 1e-8 and atol 1e-10 (`FIT_RTOL`, `FIT_ATOL`), a budget of 400 000 steps for the slow
driven path, failures reported in the comparison rather than raised."""


def compare_unfolding(
    vertex=None,
    design: HingeDesign | None = None,
    options: SolveOptions | None = None,
    *,
    duration: float = 500.0,
    released: bool = True,
    energy: str = "separable",
) -> PathComparison:
    """Charge-energy path of `vertex` against the dynamic folding of the same vertex (module
    docstring), in one call.

    **Arguments:** `vertex`: a closed `SingleVertex` in its folded state (default the corner cube);
    `design`: the hinges, films and fluid (default `HingeDesign.literature()` in KOH solution;
    the paper's dynamics: the fluid's drag on the panels, not its added inertia);
    `options`: the runs' [`origami_jax.simulation.SolveOptions`][] (default
    `UNFOLDING_OPTIONS`: explicit Tsit5, 401 samples, rtol 1e-8; its `t1`, the end of the runs,
    default ``3 × duration``); `duration`: time over which the driven hinges follow the path (µs);
    `released`: also run the all-at-once release; `energy`: the unfolding energy (`"separable"` or
    `"nonseparable"`).

    **Returns:** a `PathComparison`.
    """

    vertex = corner_cube() if vertex is None else vertex
    design = HingeDesign.literature(fluid=KOH_SOLUTION) if design is None else design
    options = UNFOLDING_OPTIONS if options is None else options
    t1 = 3.0 * duration if options.t1 is None else float(options.t1)
    options = options.replace(t1=t1)
    pattern = load_pattern(vertex_pattern(vertex), name="vertex")
    g = pattern.geometry
    # The pattern's creases (tree, then cut) against the vertex's order (rays at increasing angle).
    tips = []
    for line in g.crease_edges:
        u, v = g.frame.edges_vertices[line[0]]
        tips.append(int(v if u == 0 else u) - 1)
    to_pattern = np.asarray(tips)  # pattern crease j is vertex crease to_pattern[j]
    final = np.asarray(fold_angles(vertex), dtype=float)

    result = unfold(vertex, energy=energy)
    unfolding = np.asarray(result.fold_angles, dtype=float)[::-1]
    progress = _progress(unfolding, final)
    # The paper's dynamics (no added fluid inertia): the path is followed over `duration`, the
    # paper's time scale; carrying the bath's inertia, the panels would need milliseconds.
    system = pattern.system(design, contact=False, added_mass=False, viscous=False)
    sectors = np.asarray(vertex.sector_angles, dtype=float)

    def certify(angles):
        nodes = np.stack(
            [
                np.asarray(chain_from_fold_angles(jnp.asarray(sectors), jnp.asarray(a), True)[0])[
                    : len(sectors)
                ]
                for a in angles
            ]
        )
        return certify_path(nodes, sectors, closed=True)

    def run(inputs) -> DynamicPath:
        trajectory = simulate(system, inputs, options)
        report = pattern.assess(system, trajectory)
        theta = np.asarray(trajectory.theta)
        angles = np.empty_like(theta)
        angles[:, to_pattern] = theta
        angles = angles[np.all(np.isfinite(angles), axis=1)]
        reached = _progress(angles, final)
        return DynamicPath(
            times=np.asarray(trajectory.times),
            angles=angles,
            certificate=certify(angles),
            verdict=str(report.verdict),
            report=report,
            deviation=_deviation(angles, reached, unfolding, progress),
            reached=float(reached[-1]),
        )

    times = np.linspace(0.0, duration, len(unfolding))
    path_input = PathInput(times=jnp.asarray(times), angles=jnp.asarray(unfolding[:, to_pattern]))
    driven = run(path_input)
    step = None
    if released:
        step = run(Step())
    takeable = driven.verdict == "folded" and not driven.certificate.crossing_states
    return PathComparison(
        unfolding=result,
        folding_angles=unfolding,
        folding_progress=progress,
        driven=driven,
        released=step,
        takeable=bool(takeable),
    )
