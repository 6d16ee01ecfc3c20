"""Scenes from what the package produces: unfolding paths, trajectories, mechanisms, sweep members.

`scene_from(obj, ...)` dispatches on the type; each adapter is also public. Physics packages are
imported inside the adapters, so `import origami_jax.view` stays light.
"""

from __future__ import annotations

import functools
import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from ..fold import vertex_fold_angles
from ._fold_scene import FILE_VERDICT_LEVELS, _rotation
from ._scene import Scene

# Sector arcs of a single vertex are drawn with one corner per this angle (rad) at least.
ARC_STEP = math.pi / 24
# Adjacent flaps of a planar chain lie on each other when |θ| reaches π; a contact is marked from
# this distance to π (rad), the drawing resolution of a fold-flat hinge.
FLAT_CONTACT_TOL = 1e-3
# Single-vertex arcs closer than this (rad of arc) are marked as touching.
ARC_CONTACT_TOL = 1e-6

_LENGTH_NAMES = {1.0: "m", 1e-3: "mm", 1e-6: "µm", 1e-9: "nm"}
_TIME_NAMES = {1.0: "s", 1e-3: "ms", 1e-6: "µs", 1e-9: "ns"}


def _unit_name(value: float, names: dict[float, str]) -> str:
    for scale, name in names.items():
        if math.isclose(value, scale, rel_tol=1e-12):
            return name
    return f"{value:g} {names[1.0]}"


# ---------------------------------------------------------------- single vertex


def scene_from_vertex_path(
    path: np.ndarray,
    sector_angles: np.ndarray,
    *,
    closed: bool,
    fold_angles: np.ndarray | None = None,
    path_length: np.ndarray | None = None,
    verdict: str | None = None,
    reason: str | None = None,
    sign_changes: np.ndarray | None = None,
    title: str = "single vertex",
) -> Scene:
    """A single-vertex path as a scene: each sector a flat wedge of the unit sphere's radius.

    **Arguments:** `path` `(k, n, 3)` crease directions (or `(n, 3)`); `sector_angles` `(n,)`
    closed or `(n − 1,)` open, radians; `fold_angles` `(k, m)` (default computed from the path);
    `path_length` `(k,)` the slider's quantity (default the state index); `verdict`, `reason` the
    banner; `sign_changes` `(m,)` creases to highlight (those that changed sign).

    Sector `i` runs from ray `i` to ray `i + 1` through ``cos(sα) u_i + sin(sα) w`` with
    ``w = (u_{i+1} − cos α u_i) / sin α``, which follows the sector's own angle α (reflex sectors
    included) rather than the shorter arc. Contacts: touching or crossing arcs (`arc_pair_clearances`)
    marked where they meet, their sectors highlighted.
    """
    path = np.asarray(path, dtype=float)
    if path.ndim == 2:
        path = path[None]
    sectors = np.asarray(sector_angles, dtype=float)
    k, n, _ = path.shape
    n_sectors = n if closed else n - 1
    if path.shape[2] != 3 or sectors.shape != (n_sectors,):
        raise ValueError(
            f"path must be (k, n, 3) and sector_angles ({n_sectors},) for a "
            f"{'closed' if closed else 'open'} vertex of {n} creases; got {path.shape}, "
            f"{sectors.shape}"
        )
    if np.any(np.abs(np.sin(sectors)) < 1e-9):
        raise ValueError("a sector angle of 0 or π cannot be drawn as a wedge")
    creases = np.arange(n) if closed else np.arange(1, n - 1)
    if fold_angles is None:
        fold_angles = np.stack([vertex_fold_angles(state, closed=closed) for state in path])
    fold_angles = np.asarray(fold_angles, dtype=float).reshape(k, len(creases))
    steps = [max(2, math.ceil(abs(a) / ARC_STEP)) for a in sectors]
    frames = []
    for state in path:
        state = state / np.linalg.norm(state, axis=1, keepdims=True)
        panels = []
        for i, (alpha, m) in enumerate(zip(sectors, steps, strict=True)):
            u, v = state[i], state[(i + 1) % n]
            w = (v - math.cos(alpha) * u) / math.sin(alpha)
            s = np.linspace(0.0, alpha, m + 1)[:, None]
            arc = np.cos(s) * u + np.sin(s) * w
            panels.append(np.concatenate([np.zeros((1, 3)), arc], axis=0))
        frames.append(panels)
    offsets = np.concatenate([[0], np.cumsum([m + 2 for m in steps])]).astype(np.int64)
    # Crease c is the first ray of sector c: corners 0 (apex) and 1 of that panel.
    hinges = np.array([[offsets[c], offsets[c] + 1] for c in creases], dtype=np.int64)
    contact_frames, contact_points, touching = _arc_contacts(path, closed)
    highlight = np.zeros(n_sectors, bool)
    highlight[list(touching)] = True
    level = "ok"
    if verdict is not None:
        level = {"flat-unfolded": "ok", "flat-folded": "warn"}.get(str(verdict), "fail")
    banner = None if verdict is None else f"verdict: {verdict}" + (f" ({reason})" if reason else "")
    notes = ["sectors drawn as wedges of the unit sphere's radius"]
    if sign_changes is not None and np.any(np.asarray(sign_changes) > 0):
        notes.append("highlighted creases change sign along the path")
    return Scene(
        vertices=np.stack([np.concatenate(p, axis=0) for p in frames]),
        offsets=offsets,
        times=np.arange(k, dtype=float) if path_length is None else np.asarray(path_length, float),
        hinges=hinges,
        fold_angles=fold_angles,
        hinge_names=tuple(f"crease {int(c)}" for c in creases),
        highlight_panels=highlight,
        highlight_hinges=None if sign_changes is None else np.asarray(sign_changes) > 0,
        contact_frames=contact_frames,
        contact_points=contact_points,
        verdict=banner,
        verdict_level=level,
        title=title,
        length_unit="",
        time_unit="rad" if path_length is not None else "",
        time_label="path length" if path_length is not None else "state",
        notes=tuple(notes),
    )


def _arc_contacts(path: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray, set[int]]:
    """Frames and points where two non-adjacent sector arcs touch or cross (the vertex package's
    `arc_pair_clearances`), and the sectors involved. A crossing is marked where the two great
    circles meet on the arcs; a touching pair at the arc end nearest the other arc."""
    import jax
    import jax.numpy as jnp

    from ..vertex import arc_pair_clearances, point_arc_distance, topology

    top = topology(path.shape[1], closed)
    pairs = np.asarray(top.arc_pairs)
    if len(pairs) == 0:
        return np.zeros(0, np.int64), np.zeros((0, 3)), set()
    x = path / np.linalg.norm(path, axis=-1, keepdims=True)
    clearance, crossing = jax.vmap(lambda s: arc_pair_clearances(s, closed))(jnp.asarray(x))
    clearance, crossing = np.asarray(clearance), np.asarray(crossing)
    frames, index = np.nonzero(crossing | (clearance < ARC_CONTACT_TOL))
    if len(frames) == 0:
        return np.zeros(0, np.int64), np.zeros((0, 3)), set()
    arcs = np.asarray(top.arcs)
    a1, a2 = x[frames, arcs[pairs[index, 0], 0]], x[frames, arcs[pairs[index, 0], 1]]
    b1, b2 = x[frames, arcs[pairs[index, 1], 0]], x[frames, arcs[pairs[index, 1], 1]]
    meet = np.cross(np.cross(a1, a2), np.cross(b1, b2))
    meet = meet / np.maximum(np.linalg.norm(meet, axis=-1, keepdims=True), 1e-300)
    meet = np.where(np.sum(meet * (a1 + a2), axis=-1, keepdims=True) < 0, -meet, meet)
    ends = np.stack([a1, a2, b1, b2])
    distance = np.stack(
        [
            np.asarray(point_arc_distance(jnp.asarray(p), jnp.asarray(q1), jnp.asarray(q2)))
            for p, q1, q2 in ((a1, b1, b2), (a2, b1, b2), (b1, a1, a2), (b2, a1, a2))
        ]
    )
    nearest = ends[np.argmin(distance, axis=0), np.arange(len(frames))]
    points = np.where(crossing[frames, index][:, None], meet, nearest)
    touching = {int(s) for s in pairs[np.unique(index)].ravel()}
    return frames.astype(np.int64), points, touching


def scene_from_unfolding(result: Any, *, title: str | None = None) -> Scene:
    """A scene of `origami_jax.vertex.unfold`'s `UnfoldResult`: its path over its path length,
    the verdict as a banner, creases that change sign highlighted, contacts marked."""
    vertex = result.vertex
    return scene_from_vertex_path(
        np.asarray(result.path),
        np.asarray(vertex.sector_angles),
        closed=bool(vertex.closed),
        fold_angles=np.asarray(result.fold_angles),
        path_length=np.asarray(result.path_length),
        verdict=str(result.verdict.value),
        reason=result.reason,
        sign_changes=np.asarray(result.crease_report.sign_changes),
        title=title or "single-vertex unfolding",
    )


def scene_from_unfold_npz(path: str | os.PathLike) -> Scene:
    """A scene of the `path.npz` that `origami-jax unfold` writes."""
    with np.load(path, allow_pickle=False) as data:
        return scene_from_vertex_path(
            data["directions"],
            data["sector_angles_rad"],
            closed=bool(data["closed"]),
            fold_angles=data["fold_angles_rad"],
            path_length=data["path_length_rad"],
            verdict=str(data["verdict"]),
            title=f"single-vertex unfolding ({Path(path).name})",
        )


# ---------------------------------------------------------------- mechanisms and trajectories


def scene_from_trajectory(
    trajectory: Any,
    system: Any,
    *,
    thickness: float | None = None,
    report: Any = None,
    title: str = "folding trajectory",
) -> Scene:
    """A scene of a simulated trajectory of `system` (a `FoldingSystem` or a mechanism).

    Panels are the mechanism's body outlines moved by `body_poses`, evaluated for all samples in
    one jitted `vmap`; a serial chain also gets its fixed base drawn (flap 1 turned flat about hinge
    1) and its hinges (the edge of each flap on its hinge axis). Contacts: hinges of a planar chain
    at |θ| ≥ π − 1e-3 rad, where adjacent flaps lie on each other (beyond π they pass through one
    another: panels do not collide in the model unless the system has a contact model).
    Samples after a failed solve (non-finite) are dropped and the failure is the verdict.

    A system with a panel contact model (nets, crease patterns) gets its contacts marked where
    panels touch (`PanelContact.engaged_points`) and the panels touching at the end highlighted.

    **Arguments:** `trajectory` an `origami_jax.simulation.Trajectory` (one member, not a batch);
    `thickness` panel thickness in the system's length unit (default: not drawn to scale);
    `report` the run's `FoldReport` (`Net.assess`, `CreasePattern.assess`): its verdict is the
    banner and the creases outside its angle tolerance are highlighted.
    """
    times = np.asarray(trajectory.times, dtype=float)
    q = np.asarray(trajectory.state[0] if trajectory.state is not None else trajectory.theta)
    if q.ndim != 2:
        raise ValueError(
            f"a batched trajectory ({q.shape}): pick one member first, e.g. "
            "jax.tree_util.tree_map(lambda x: x[i], trajectory) for array fields"
        )
    finite = np.all(np.isfinite(q), axis=1)
    result = trajectory.result
    ok = bool(np.all(np.asarray(trajectory.succeeded)))
    notes = []
    if not np.all(finite):
        notes.append(f"{int(np.sum(~finite))} samples after the failure dropped")
    q, times = q[finite], times[finite]
    if len(q) == 0:
        raise ValueError("the trajectory has no finite sample to draw")
    scene = scene_from_mechanism(system, q, times=times, thickness=thickness, title=title)
    if ok:
        target = np.asarray(trajectory.target, dtype=float)
        error = np.abs(scene.fold_angles[-1] - target) if len(target) == scene.n_hinges else None
        text = "solve successful"
        if error is not None:
            text += f"; final |θ − target| ≤ {np.rad2deg(np.max(error)):.3g}°"
        level = "warn" if len(scene.contact_frames) else "ok"
        if len(scene.contact_frames):
            text += "; adjacent flaps reach each other (|θ| ≥ π): contacts marked"
    else:
        from ..simulation import RESULTS

        message = RESULTS[result]  # pyright: ignore[reportInvalidTypeArguments] (an enum lookup)
        text, level = f"solve failed: {message}", "fail"
    highlight = None
    if report is not None:
        text, level, highlight = _report_banner(report, scene.n_hinges)
    units = getattr(system, "units", None)
    return scene.replace(
        verdict=text,
        verdict_level=level,
        highlight_hinges=highlight,
        time_unit=scene.time_unit
        if units is None
        else _unit_name(units.second_per_time, _TIME_NAMES),
        notes=(*scene.notes, *notes),
    )


# Frames of a pattern's preview (`scene_from_pattern`): flat to folded in this many steps.
PATTERN_FRAMES = 25


def pattern_panel_thickness(design: Any) -> float:
    """The panels' thickness of a design (its structural film, `t_structural`; the thickest where
    it is given per crease), its length unit."""
    return float(np.max(np.asarray(design.t_structural, dtype=float)))


def scene_from_pattern(
    pattern: Any,
    design: Any = None,
    *,
    frames: int = PATTERN_FRAMES,
    thickness: float | None = None,
    title: str | None = None,
) -> Scene:
    """A pattern (an `origami_jax.system.AbstractPattern`: `Net`, `CreasePattern`, `Accordion`)
    flat and folded as intended: `frames` states turning every hinge linearly from the pattern's
    start state (flat) to its intended angles, the last frame its intended folded shape. A
    kinematic preview, not a simulation (fold it with `pattern.fold` and view the trajectory):
    in a closed-loop pattern the panels may part on the way, and meet again at the end.

    **Arguments:** `design`, the `HingeDesign` the system is built with (default the pattern's,
    `pattern.default_design()`; arc hinges take their strips' length from it); `frames` (>= 1;
    1 shows the flat pattern only); `thickness`, the panels' (default the design's
    `t_structural`); `title` (default the pattern's name).
    """
    if not isinstance(frames, int) or isinstance(frames, bool) or frames < 1:
        raise ValueError(f"frames must be an integer >= 1, got {frames!r}")
    design = pattern.default_design() if design is None else design
    system = pattern.system(design)
    start = np.asarray(pattern.start_state(system)[0], dtype=float)
    intended = np.asarray(pattern.intended_angles, dtype=float)
    fraction = np.linspace(0.0, 1.0, frames) if frames > 1 else np.zeros(1)
    q = start + fraction[:, None] * (intended - start)
    scene = scene_from_mechanism(
        system,
        q,
        times=fraction,
        thickness=pattern_panel_thickness(design) if thickness is None else thickness,
        title=title or f"{pattern.name}: flat and folded as intended",
    )
    names = tuple(pattern.hinge_name(j) for j in range(scene.n_hinges))
    text = "intended fold: every hinge turned linearly from flat to its intended angle (a preview)"
    return scene.replace(
        hinge_names=names if len(names) == pattern.n_hinges else scene.hinge_names,
        verdict=text if frames > 1 else "flat pattern",
        verdict_level="ok",
        time_label="fold fraction",
        notes=(
            *scene.notes,
            "a kinematic preview, not a simulation: fold the pattern and view the trajectory",
        ),
    )


def _report_banner(report: Any, n_hinges: int) -> tuple[str, str, np.ndarray | None]:
    """Banner text, level and the hinges to highlight (outside the angle tolerance) of a
    `FoldReport`."""
    verdict = str(report.verdict)
    text = f"verdict: {verdict} ({report.reason})"
    highlight = report.off_target if len(report.off_target) == n_hinges else None
    if highlight is not None and np.any(highlight):
        text += f"; {int(np.sum(highlight))} crease(s) outside tolerance highlighted"
    return text, FILE_VERDICT_LEVELS.get(verdict, "fail"), highlight


def scene_from_mechanism(
    mechanism: Any,
    q: np.ndarray | None = None,
    *,
    times: np.ndarray | None = None,
    thickness: float | None = None,
    title: str = "mechanism",
) -> Scene:
    """A scene of a mechanism (or `FoldingSystem`) at states `q` `(T, n_coordinates)` (default the
    rest state), see `scene_from_trajectory`."""
    import jax.numpy as jnp

    units = getattr(mechanism, "units", None)
    system = mechanism
    mechanism = getattr(mechanism, "mechanism", mechanism)
    if q is None:
        q = np.asarray(mechanism.rest_state()[0])[None]
    q = np.asarray(q, dtype=float)
    if q.ndim == 1:
        q = q[None]
    if q.shape[1] != mechanism.n_coordinates:
        raise ValueError(
            f"states must have {mechanism.n_coordinates} coordinates per row, got {q.shape}"
        )
    poses, angles = _poses_and_angles(mechanism, jnp.asarray(q))
    poses, angles = np.asarray(poses), np.asarray(angles)
    outlines = [np.asarray(o, dtype=float) for o in mechanism.outlines()]
    sizes = [len(o) for o in outlines]
    # World polygons of every body and frame in one product: (T, b, k, 3) per body size group.
    world = [
        outline @ poses[:, b, :3, :3].transpose(0, 2, 1) + poses[:, b, None, :3, 3]
        for b, outline in enumerate(outlines)
    ]
    panels = list(world)
    fixed = [False] * len(outlines)
    base = mechanism.base_outline()
    rest_poses = np.asarray(mechanism.body_poses(jnp.zeros(mechanism.n_coordinates)))
    notes = []
    if base is None and hasattr(mechanism, "axes") and len(outlines):
        base = _chain_base(mechanism, outlines[0], rest_poses[0])
        notes.append("fixed base drawn as flap 1 turned flat about hinge 1")
    if base is not None:
        base = np.asarray(base, dtype=float)
        panels.insert(0, np.broadcast_to(base, (len(q), *base.shape)))
        fixed.insert(0, True)
        sizes.insert(0, len(base))
    offsets = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    vertices = np.concatenate(panels, axis=1)
    hinges = _hinge_segments(mechanism, outlines, rest_poses, offsets, base)
    if hinges is None:
        hinges = np.zeros((0, 2), np.int64)
        angles = angles[:, :0]
        notes.append("hinge positions unknown for this mechanism: fold angles not plotted")
    contact_frames, contact_points = _flat_contacts(mechanism, vertices, hinges, angles)
    first = 1 if base is not None else 0
    frames, points, touching = _panel_contacts(system, q, len(offsets) - 1, first)
    if touching is not None:
        contact_frames, contact_points = frames, points
        notes.append("contacts: where panels touch (the contact model's engaged points)")
    return Scene(
        vertices=vertices,
        offsets=offsets,
        times=np.arange(len(q), dtype=float) if times is None else np.asarray(times, dtype=float),
        hinges=hinges,
        fold_angles=angles,
        hinge_names=tuple(f"hinge {i + 1}" for i in range(len(hinges))),
        thickness=thickness,
        fixed_panels=np.array(fixed),
        highlight_panels=touching,
        contact_frames=contact_frames,
        contact_points=contact_points,
        title=title,
        length_unit="" if units is None else _unit_name(units.metre_per_length, _LENGTH_NAMES),
        time_unit="",
        time_label="time" if times is not None else "state",
        notes=tuple(notes),
    )


def _poses_and_angles(mechanism, q):
    """Body poses `(T, b, 4, 4)` and hinge angles `(T, h)` of all states in one compiled call."""
    return _batched_kinematics()(mechanism, q)


@functools.cache
def _batched_kinematics():
    # Built once (JAX imported on first use), so that the compiled call is cached per mechanism
    # structure across scenes.
    import equinox as eqx
    import jax

    @eqx.filter_jit
    def run(mechanism, q):
        return jax.vmap(mechanism.body_poses)(q), jax.vmap(mechanism.hinge_angles)(q)

    return run


def _chain_base(chain, outline: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """Flap 1 at rest turned by π about hinge 1: the fixed base a chain's first hinge sits on."""
    axis = np.asarray(chain.axes[0], dtype=float)
    point = np.asarray(chain.points[0], dtype=float)
    rest = outline @ pose[:3, :3].T + pose[:3, 3]
    turn = _rotation(axis / np.linalg.norm(axis), math.pi)
    return ((rest - point) @ turn.T + point)[::-1].copy()


def _hinge_segments(mechanism, outlines, rest_poses, offsets, base) -> np.ndarray | None:
    """Each hinge as two panel corners: the corners of the child body (or, when closer, of the
    parent body or the drawn base) nearest the two ends of its crease in the flat state
    (`hinge_layout`), so the segment moves with that body. `offsets`: the scene's panel offsets;
    `base`: the drawn base polygon (scene panel 0) or `None`."""
    layout = mechanism.hinge_layout()
    if len(layout.parent) != mechanism.n_hinges:
        return None
    first = 1 if base is not None else 0
    rest = [o @ p[:3, :3].T + p[:3, 3] for o, p in zip(outlines, rest_poses, strict=True)]
    out = []
    for h in range(mechanism.n_hinges):
        best = None
        for body in (int(layout.child[h]), int(layout.parent[h])):
            if body < 0 and base is None:
                continue
            corners = base if body < 0 else rest[body]
            start = offsets[0] if body < 0 else offsets[first + body]
            distance = np.linalg.norm(corners[None] - np.asarray(layout.ends[h])[:, None], axis=-1)
            i = int(np.argmin(distance[0]))
            other = distance[1].copy()
            other[i] = np.inf
            j = int(np.argmin(other))
            error = distance[0, i] + other[j]
            if best is None or error < best[0]:
                best = (error, start + min(i, j), start + max(i, j))
        if best is None:
            return None
        out.append(best[1:])
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def _panel_contacts(system, q, n_panels: int, first: int):
    """Contacts of a system with a panel contact model at every state `q` `(T, n_coordinates)`
    (`origami_jax.contact.contact_points`): frames, points, and the scene panels (moving body `b` is
    panel `first + b`, the base panel 0) touching at the last state (`None` without a model)."""
    if getattr(system, "contact", None) is None:
        return np.zeros(0, np.int64), np.zeros((0, 3)), None
    from ..contact import contact_points

    frames, points, bodies = contact_points(system, q)
    highlight = np.zeros(n_panels, bool)
    n_bodies = system.mechanism.n_bodies
    for body in np.unique(bodies[frames == len(q) - 1]):
        if body < n_bodies:
            highlight[first + body] = True
        elif first:
            highlight[0] = True
    return frames, points, highlight


def _flat_contacts(mechanism, vertices, hinges, angles):
    """Hinges of a planar chain folded to |θ| ≥ π: adjacent flaps on each other (frames, points
    at the hinges' midpoints)."""
    if not getattr(mechanism, "planar", False) or len(hinges) == 0:
        return np.zeros(0, np.int64), np.zeros((0, 3))
    frames, index = np.nonzero(np.abs(angles) >= math.pi - FLAT_CONTACT_TOL)
    ends = vertices[frames[:, None], hinges[index]]  # (K, 2, 3)
    return frames.astype(np.int64), ends.mean(axis=1)
