"""`Scene`: what the interactive view draws, as plain host arrays (no JAX).

A scene is a sequence of frames of the same set of rigid panels. Each panel owns its vertices (a
world-frame polygon, any number of corners); hinges are segments between two panel vertices, so they
move with the panels; every hinge has a fold angle per frame (the linked plot). Contacts are points
tied to frames; a verdict is one line with a level, and panels or hinges may be highlighted.

Adapters in `origami_jax.view._adapters` build scenes from FOLD files, unfolding results, simulated
trajectories and sweep members; `origami_jax.view.write_html` draws one.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike

DEFAULT_MAX_FRAMES = 300
VERDICT_LEVELS = ("ok", "warn", "fail")


_FIELDS = (
    "vertices",
    "offsets",
    "times",
    "hinges",
    "fold_angles",
    "hinge_names",
    "thickness",
    "fixed_panels",
    "highlight_panels",
    "highlight_hinges",
    "contact_frames",
    "contact_points",
    "verdict",
    "verdict_level",
    "title",
    "length_unit",
    "time_unit",
    "time_label",
    "notes",
)


class Scene:
    """Frames of rigid panels, hinges with fold angles, contacts and a verdict (host numpy).

    **Fields** (`T` frames, `P` panels, `V` panel vertices in all, `H` hinges, `K` contacts):
    - `vertices`: `(T, V, 3)` world coordinates, `length_unit`. Panel `p` is the polygon
      `vertices[:, offsets[p]:offsets[p + 1]]`, counter-clockwise seen from its front (+normal).
    - `offsets`: `(P + 1,)` int, increasing from 0 to `V`; every panel has at least 3 corners.
    - `times`: `(T,)` increasing, `time_unit` (a unitless path parameter or frame index is fine).
    - `hinges`: `(H, 2)` int, indices into the `V` vertices of the hinge segment's ends.
    - `fold_angles`: `(T, H)` radians, valley positive (NaN where unknown); `hinge_names`: `H` labels.
    - `thickness`: panel thickness, `length_unit` (`None`: unknown; the view draws a visible one).
    - `fixed_panels`, `highlight_panels`: `(P,)` bool; `highlight_hinges`: `(H,)` bool.
    - `contact_frames`: `(K,)` int frame of each contact; `contact_points`: `(K, 3)` its location.
    - `verdict`: one line shown as a banner (or `None`); `verdict_level`: `"ok"`, `"warn"`, `"fail"`.
    - `title`, `length_unit`, `time_unit`, `time_label` (the slider's quantity, e.g. "time" or
      "path length"), `notes` (lines shown under the legend: resampling, exaggerations, skipped data).

    Build with the adapters or by hand; the constructor checks shapes and values.
    """

    vertices: np.ndarray
    offsets: np.ndarray
    times: np.ndarray
    hinges: np.ndarray
    fold_angles: np.ndarray
    hinge_names: tuple[str, ...]
    thickness: float | None
    fixed_panels: np.ndarray
    highlight_panels: np.ndarray
    highlight_hinges: np.ndarray
    contact_frames: np.ndarray
    contact_points: np.ndarray
    verdict: str | None
    verdict_level: str
    title: str
    length_unit: str
    time_unit: str
    time_label: str
    notes: tuple[str, ...]

    def __init__(
        self,
        vertices: ArrayLike,
        offsets: ArrayLike,
        times: ArrayLike,
        hinges: ArrayLike,
        fold_angles: ArrayLike,
        *,
        hinge_names: Sequence[str] = (),
        thickness: float | None = None,
        fixed_panels: ArrayLike | None = None,
        highlight_panels: ArrayLike | None = None,
        highlight_hinges: ArrayLike | None = None,
        contact_frames: ArrayLike | None = None,
        contact_points: ArrayLike | None = None,
        verdict: str | None = None,
        verdict_level: str = "ok",
        title: str = "origami_jax",
        length_unit: str = "",
        time_unit: str = "",
        time_label: str = "time",
        notes: Sequence[str] = (),
    ) -> None:
        vertices = np.asarray(vertices, dtype=float)
        if vertices.ndim != 3 or vertices.shape[2] != 3 or vertices.shape[0] < 1:
            raise ValueError(
                f"vertices must have shape (frames, vertices, 3), not {np.shape(vertices)}"
            )
        if not np.all(np.isfinite(vertices)):
            bad = np.unique(np.nonzero(~np.isfinite(vertices))[0])
            raise ValueError(
                f"vertices are not finite in frame(s) {bad[:5].tolist()}: drop failed samples "
                "before building the scene"
            )
        n_frames, n_vertices, _ = vertices.shape
        offsets = np.asarray(offsets, dtype=np.int64)
        if (
            offsets.ndim != 1
            or len(offsets) < 2
            or offsets[0] != 0
            or offsets[-1] != n_vertices
            or np.any(np.diff(offsets) < 3)
        ):
            raise ValueError(
                "offsets must run from 0 to the vertex count with at least 3 corners per panel; "
                f"got {offsets.tolist()[:8]}... for {n_vertices} vertices"
            )
        n_panels = len(offsets) - 1
        times = np.asarray(times, dtype=float)
        if (
            times.shape != (n_frames,)
            or np.any(np.diff(times) < 0)
            or not np.all(np.isfinite(times))
        ):
            raise ValueError(f"times must be ({n_frames},) finite and non-decreasing")
        hinges = np.asarray(hinges, dtype=np.int64).reshape(-1, 2)
        if np.any(hinges < 0) or np.any(hinges >= n_vertices):
            raise ValueError(f"hinges must index the {n_vertices} vertices")
        n_hinges = len(hinges)
        angles = np.asarray(fold_angles, dtype=float)
        if angles.size == 0:
            angles = angles.reshape(n_frames, 0)
        if angles.shape != (n_frames, n_hinges):
            raise ValueError(
                f"fold_angles must have shape ({n_frames}, {n_hinges}), one per frame and hinge, "
                f"not {np.shape(fold_angles)}"
            )
        names = tuple(hinge_names) or tuple(f"hinge {i + 1}" for i in range(n_hinges))
        if len(names) != n_hinges:
            raise ValueError(f"hinge_names needs {n_hinges} labels, got {len(names)}")

        def mask(value, n, name):
            out = np.zeros(n, bool) if value is None else np.asarray(value, dtype=bool)
            if out.shape != (n,):
                raise ValueError(f"{name} must have shape ({n},), not {out.shape}")
            return out

        frames = np.zeros(0, np.int64) if contact_frames is None else contact_frames
        frames = np.asarray(frames, dtype=np.int64).reshape(-1)
        points = np.zeros((0, 3)) if contact_points is None else contact_points
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        if len(frames) != len(points) or np.any((frames < 0) | (frames >= n_frames)):
            raise ValueError(
                "contact_frames (K,) must index frames and match contact_points (K, 3)"
            )
        if verdict_level not in VERDICT_LEVELS:
            raise ValueError(f"verdict_level must be one of {VERDICT_LEVELS}")
        if thickness is not None and not (np.isfinite(thickness) and thickness >= 0):
            raise ValueError(f"thickness must be finite and >= 0, got {thickness}")
        for name, value in (
            ("vertices", vertices),
            ("offsets", offsets),
            ("times", times),
            ("hinges", hinges),
            ("fold_angles", angles),
            ("hinge_names", names),
            ("fixed_panels", mask(fixed_panels, n_panels, "fixed_panels")),
            ("highlight_panels", mask(highlight_panels, n_panels, "highlight_panels")),
            ("highlight_hinges", mask(highlight_hinges, n_hinges, "highlight_hinges")),
            ("contact_frames", frames),
            ("contact_points", points),
            ("notes", tuple(notes)),
            ("thickness", None if thickness is None else float(thickness)),
            ("verdict", verdict),
            ("verdict_level", verdict_level),
            ("title", title),
            ("length_unit", length_unit),
            ("time_unit", time_unit),
            ("time_label", time_label),
        ):
            setattr(self, name, value)

    @property
    def n_frames(self) -> int:
        return self.vertices.shape[0]

    @property
    def n_panels(self) -> int:
        return len(self.offsets) - 1

    @property
    def n_hinges(self) -> int:
        return len(self.hinges)

    def panel(self, index: int, frame: int = 0) -> np.ndarray:
        """Polygon of panel `index` at `frame`, `(k, 3)`."""
        return self.vertices[frame, self.offsets[index] : self.offsets[index + 1]]

    def panels(self, frame: int = 0) -> list[np.ndarray]:
        """Every panel's polygon at `frame`."""
        return [self.panel(p, frame) for p in range(self.n_panels)]

    def replace(self, **changes) -> Scene:
        """A copy with some fields changed (checked again)."""
        return Scene(**{**{name: getattr(self, name) for name in _FIELDS}, **changes})

    def __repr__(self) -> str:
        return (
            f"Scene({self.title!r}: {self.n_panels} panels, {self.n_hinges} hinges, "
            f"{self.n_frames} frames)"
        )


def scene_from_polygons(
    frames: Sequence[Sequence[np.ndarray]] | np.ndarray,
    *,
    times: Sequence[float] | np.ndarray | None = None,
    hinges: Sequence[tuple[int, int, int, int]] = (),
    fold_angles: np.ndarray | None = None,
    **fields,
) -> Scene:
    """A `Scene` from per-frame lists of panel polygons (the same corner counts in every frame).

    **Arguments:**
    - `frames`: `T` lists of `P` polygons `(k_p, 3)`, or an array `(T, P, k, 3)`.
    - `times`: `(T,)`, default the frame index.
    - `hinges`: `(panel, corner, panel, corner)` per hinge: the segment between two corners (the
      panel indices may be equal: an edge of one panel).
    - `fold_angles`: `(T, H)` radians; default NaN (no plot).
    - `fields`: any other `Scene` field.
    """
    polys = [[np.asarray(p, dtype=float) for p in frame] for frame in frames]
    if not polys or not polys[0]:
        raise ValueError("frames must hold at least one frame with at least one panel")
    sizes = [len(p) for p in polys[0]]
    for t, frame in enumerate(polys):
        if [len(p) for p in frame] != sizes:
            raise ValueError(f"frame {t} has other panels or corner counts than frame 0")
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    vertices = np.stack([np.concatenate(frame, axis=0) for frame in polys])
    n = len(polys)
    segments = np.array(
        [[offsets[a] + i, offsets[b] + j] for a, i, b, j in hinges], dtype=np.int64
    ).reshape(-1, 2)
    if fold_angles is None:
        fold_angles = np.full((n, len(segments)), np.nan)
    return Scene(
        vertices=vertices,
        offsets=offsets,
        times=np.arange(n, dtype=float) if times is None else np.asarray(times, dtype=float),
        hinges=segments,
        fold_angles=fold_angles,
        **fields,
    )


def frame_indices(times: np.ndarray, max_frames: int | None) -> np.ndarray:
    """Indices of at most `max_frames` samples, evenly spread in time, first and last kept.

    Results with no more samples than `max_frames` keep all of them. Otherwise each of
    `max_frames` evenly spaced times takes the nearest sample (states are never interpolated:
    rigid panels rotate, a blend of two polygons would not be rigid); duplicates are dropped.
    """
    times = np.asarray(times, dtype=float)
    n = len(times)
    if max_frames is None or n <= max_frames:
        return np.arange(n)
    if max_frames < 2:
        raise ValueError(f"max_frames must be at least 2, got {max_frames}")
    if times[-1] == times[0]:
        return np.unique(np.round(np.linspace(0, n - 1, max_frames)).astype(np.int64))
    wanted = np.linspace(times[0], times[-1], max_frames)
    right = np.clip(np.searchsorted(times, wanted), 1, n - 1)
    left = right - 1
    nearest = np.where(wanted - times[left] <= times[right] - wanted, left, right)
    return np.unique(np.concatenate([[0], nearest, [n - 1]]))


def resample(scene: Scene, max_frames: int | None = DEFAULT_MAX_FRAMES) -> Scene:
    """The scene with at most `max_frames` frames (`frame_indices`), contacts remapped.

    Contacts of dropped frames go to the nearest kept frame, so that a short contact is not lost.
    """
    keep = frame_indices(scene.times, max_frames)
    if len(keep) == scene.n_frames:
        return scene
    kept_times = scene.times[keep]
    contact_frames = scene.contact_frames
    if len(contact_frames):
        at = scene.times[contact_frames]
        right = np.clip(np.searchsorted(kept_times, at), 1, len(keep) - 1)
        left = right - 1
        contact_frames = np.where(
            at - kept_times[left] <= kept_times[right] - at, left, right
        ).astype(np.int64)
    note = (
        f"{scene.n_frames} samples shown as {len(keep)} frames, evenly spaced in {scene.time_label}"
    )
    return scene.replace(
        vertices=scene.vertices[keep],
        times=kept_times,
        fold_angles=scene.fold_angles[keep],
        contact_frames=contact_frames,
        notes=(*scene.notes, note),
    )


def triangulate(polygon: np.ndarray) -> np.ndarray:
    """Triangles `(k - 2, 3)` (local corner indices) covering a planar polygon `(k, 3)`.

    Fans convex polygons; ear-clips the others in the polygon's own plane (Newell normal). The
    winding follows the polygon's, so triangle normals agree with the panel's front.
    """
    polygon = np.asarray(polygon, dtype=float)
    k = len(polygon)
    normal = np.sum(np.cross(polygon, np.roll(polygon, -1, axis=0)), axis=0)
    norm = np.linalg.norm(normal)
    if k == 3 or norm == 0:
        return np.array([[0, i, i + 1] for i in range(1, k - 1)], dtype=np.int64)
    normal = normal / norm
    turns = np.cross(np.roll(polygon, -1, 0) - polygon, np.roll(polygon, -2, 0) - polygon) @ normal
    if np.all(turns >= -1e-12 * norm):
        return np.array([[0, i, i + 1] for i in range(1, k - 1)], dtype=np.int64)
    # Ear clipping in 2D coordinates of the polygon's plane.
    u = polygon[1] - polygon[0]
    u = u - (u @ normal) * normal
    u = u / np.linalg.norm(u)
    v = np.cross(normal, u)
    xy = np.stack([polygon @ u, polygon @ v], axis=1)

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    remaining = list(range(k))
    triangles = []
    guard = 0
    while len(remaining) > 3 and guard < k * k:
        guard += 1
        m = len(remaining)
        for j in range(m):
            a, b, c = remaining[j - 1], remaining[j], remaining[(j + 1) % m]
            if cross(xy[a], xy[b], xy[c]) <= 0:
                continue
            others = [i for i in remaining if i not in (a, b, c)]
            if any(
                cross(xy[a], xy[b], xy[i]) >= 0
                and cross(xy[b], xy[c], xy[i]) >= 0
                and cross(xy[c], xy[a], xy[i]) >= 0
                for i in others
            ):
                continue
            triangles.append([a, b, c])
            remaining.pop(j)
            break
        else:
            break  # degenerate polygon: fan the rest
    triangles += [
        [remaining[0], remaining[i], remaining[i + 1]] for i in range(1, len(remaining) - 1)
    ]
    return np.array(triangles, dtype=np.int64)
