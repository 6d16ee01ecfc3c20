"""One flat crease pattern as a FOLD file: what every shipped pattern (nets and closed loops) is."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ._model import WRITTEN_SPEC, FoldFile, FoldFrame

CREATOR = "origami_jax catalogue (python -m origami_jax.fold.catalogue._generate)"


def edges_of(faces: Sequence[Sequence[int]]) -> tuple[list[tuple[int, int]], dict]:
    """The edges of polygonal `faces` in first-seen order, and how many faces share each (keyed by
    the frozenset of its two vertices): 1 on the boundary, 2 inside."""
    count: dict[frozenset[int], int] = {}
    edges: list[tuple[int, int]] = []
    for face in faces:
        for u, v in zip(face, face[1:] + face[:1], strict=True):
            key = frozenset((u, v))
            if key not in count:
                edges.append((u, v))
            count[key] = count.get(key, 0) + 1
    return edges, count


def crease_pattern_file(
    *,
    title: str,
    frame_title: str,
    description: str,
    coords,
    edges: list[tuple[int, int]],
    assignment: list[str],
    angles: list[float],
    faces: list[tuple[int, ...]],
) -> FoldFile:
    """A single-frame FOLD file of a flat crease pattern in µm (`coords` `(n, 2)`, faces
    counter-clockwise seen from +z), with the catalogue's metadata."""
    frame = FoldFrame(
        vertices_coords=np.asarray(coords, dtype=float),
        edges_vertices=np.asarray(edges),
        edges_assignment=tuple(assignment),
        edges_fold_angle_deg=np.asarray(angles, dtype=float),
        faces_vertices=tuple(tuple(int(v) for v in f) for f in faces),
        frame_unit="um",
        frame_classes=("creasePattern",),
        frame_attributes=("2D", "manifold", "orientable"),
        extra={"frame_title": frame_title},
    )
    metadata = {
        "file_creator": CREATOR,
        "file_title": title,
        "file_description": description,
        "file_classes": ["singleModel"],
    }
    return FoldFile(frames=(frame,), file_spec=WRITTEN_SPEC, file_metadata=metadata)
