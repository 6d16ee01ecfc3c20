"""The static shape of a panel tree: parent indices, their checks, and what the algorithms derive.

Bodies (panels) are numbered ``0..n−1`` in any order; ``parents[i]`` is the panel across body ``i``'s
hinge towards the root, or ``−1`` for a panel hinged to the fixed base (the substrate or a fixed root
panel). Hinge ``i`` is the one between body ``i`` and its parent, so ``q[i]`` folds body ``i``.
Everything here is host-side Python, computed once per tree shape and cached.
"""

import functools
from typing import NamedTuple

import numpy as np


def check_parents(parents) -> tuple[int, ...]:
    """The parent indices as a tuple of ints, or a one-line `ValueError` saying what is wrong.

    Valid: a non-empty sequence of integers in ``[−1, n)``, no body its own parent, and every body
    reaches the base (``−1``) by following parents (a forest rooted at the base: no cycles).
    """
    if isinstance(parents, str | bytes) or not hasattr(parents, "__len__"):
        raise ValueError(
            f"parents must be a sequence of integers (−1 = the base), got {parents!r}."
        )
    values = []
    for i, p in enumerate(parents):
        if isinstance(p, bool) or not isinstance(p, int | np.integer):
            raise ValueError(f"parents[{i}] must be an integer (−1 = the base), got {p!r}.")
        values.append(int(p))
    n = len(values)
    if n == 0:
        raise ValueError("parents is empty; a panel tree needs at least one hinged panel.")
    for i, p in enumerate(values):
        if not -1 <= p < n:
            raise ValueError(
                f"parents[{i}] = {p} is out of range; use −1 (the base) or a body index in [0, {n})."
            )
        if p == i:
            raise ValueError(f"parents[{i}] = {i}: a panel cannot be its own parent.")
    for i in range(n):
        seen = [i]
        j = values[i]
        while j != -1:
            if j in seen:
                cycle = " → ".join(str(k) for k in seen[seen.index(j) :] + [j])
                raise ValueError(
                    f"parents has a cycle ({cycle}); every panel must reach the base (−1) by "
                    "following parents."
                )
            seen.append(j)
            j = values[j]
    return tuple(values)


class Topology(NamedTuple):
    """What the tree algorithms need from `parents` (all host-side, static).

    - `order`: bodies in topological order (every parent before its children), breadth first.
    - `levels`: bodies at depth 1, 2, … (depth 1: hinged to the base), each an int array.
    - `level_parents`: for each level after the first, the position of each body's parent within the
      previous level's array.
    - `position`: where each body sits in ``concatenate(levels)``.
    - `ancestors`: ``A[j, i] = 1`` if body ``j`` is an ancestor of body ``i`` or ``i`` itself,
      `(n, n)` float (``A @ x`` sums over subtrees, ``Aᵀ @ x`` over paths to the base).
    - `path`: for each body, its proper ancestors from the parent to the root (tuple of tuples).
    - `depth`: number of hinges between each body and the base (1 for a root).
    """

    order: tuple[int, ...]
    levels: tuple[np.ndarray, ...]
    level_parents: tuple[np.ndarray, ...]
    position: np.ndarray
    ancestors: np.ndarray
    path: tuple[tuple[int, ...], ...]
    depth: tuple[int, ...]


@functools.lru_cache(maxsize=256)
def topology(parents: tuple[int, ...]) -> Topology:
    """The `Topology` of a checked `parents` tuple (cached per shape)."""
    n = len(parents)
    path = []
    for i in range(n):
        chain = []
        j = parents[i]
        while j != -1:
            chain.append(j)
            j = parents[j]
        path.append(tuple(chain))
    depth = tuple(len(p) + 1 for p in path)
    levels = []
    for d in range(1, max(depth) + 1):
        levels.append(np.array([i for i in range(n) if depth[i] == d], dtype=np.int64))
    level_parents = []
    for previous, level in zip(levels[:-1], levels[1:], strict=True):
        where = {int(b): k for k, b in enumerate(previous)}
        level_parents.append(np.array([where[parents[int(b)]] for b in level], dtype=np.int64))
    order = tuple(int(b) for level in levels for b in level)
    position = np.empty(n, dtype=np.int64)
    position[list(order)] = np.arange(n)
    ancestors = np.eye(n)
    for i in range(n):
        ancestors[list(path[i]), i] = 1.0
    return Topology(
        order, tuple(levels), tuple(level_parents), position, ancestors, tuple(path), depth
    )
