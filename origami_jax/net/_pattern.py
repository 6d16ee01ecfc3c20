"""`AbstractPanelPattern`: what the two patterns of panels on a panel tree share — a net
([`origami_jax.net.Net`][]) and a crease pattern with closed loops
([`origami_jax.loops.CreasePattern`][]) — and their explicit host cache (`HostCache`).

Both have one hinge per crease of their geometry, the literature hinge each no wider than its
crease as their default design, the fold kernel (`origami_jax.net.fold_kernel`) as their sweep
kernel, and physics options whose variants (`with_model`) are kept with the pattern, so that the
same options give the same object (and a compiled fit or sweep of it is reused).
"""

import abc
import dataclasses
from collections.abc import Callable, Hashable, Mapping
from typing import Any, ClassVar, final

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..system import AbstractPattern, HingeDesign
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

    MODEL: ClassVar[Mapping[str, Any]]
    geometry: Any
    host_cache: HostCache

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
        unknown = sorted(set(options) - set(self.MODEL))
        if unknown:
            raise ValueError(
                f"{type(self).__name__}.with_model: unknown option(s) {unknown}; the model's are "
                f"{sorted(self.MODEL)}."
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

    def default_design(self, fluid=None) -> HingeDesign:
        """The literature hinge in `fluid` (default air), each hinge no wider than its crease
        (`origami_jax.net.default_design`)."""
        return default_design(self, fluid)

    def kernel(self, **settings):
        """The fold kernel of this pattern for `sweep` (`origami_jax.net.fold_kernel`, `settings`
        its keyword arguments)."""
        return fold_kernel(self, **settings)


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
    return eqx.tree_at(lambda d: d.hinge_width, design, jnp.asarray(np.minimum(width, lengths)))


def default_design(pattern, fluid=None) -> HingeDesign:
    """The design a net or pattern is folded with when none is given: the literature hinge
    (`HingeDesign.literature`, in `fluid`, default air), each hinge no wider than its crease of
    `pattern` (a `Net` or `CreasePattern`; `hinges_within_creases`)."""
    overrides = {} if fluid is None else {"fluid": fluid}
    return hinges_within_creases(HingeDesign.literature(**overrides), pattern.crease_lengths)
