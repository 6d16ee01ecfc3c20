"""`AbstractPattern`: what is folded and what counts as folded.

A pattern is a device's layout — its panels and hinges, what each hinge should fold to, the seams
that should close — together with the physics model it is folded with (contact, drag, hinge kind).
Everything above the engines takes a pattern object: `fold`, `sweep`, `design`, the yield estimate,
the viewer and the command line (a catalogue name or file name becomes a pattern once, in the
command line and in a sweep's stored metadata). Its final implementations are
[`origami_jax.net.Net`][] (a tree of panels), [`origami_jax.loops.CreasePattern`][] (creases that
close loops) and [`origami_jax.chain.Accordion`][] (the paper's chain of flaps).

A pattern is a plain, immutable Python object compared by identity (a net's geometry is host
arrays and its caches are kept with it), so it can be a static field of an equinox module: the
compiled fit or sweep of one pattern object is reused. `with_model(...)` gives the same pattern
with other physics options (the same object for the same options).
"""

import abc
from typing import Any

import numpy as np

from ._hinge import HingeDesign
from ._system import FoldingSystem


def check_known_names(method: str, given, known, *, kind: str, whose: str) -> None:
    """Refuse (one-line `ValueError`) names in `given` that are not in `known`: the check of a
    pattern's `with_model` (`kind="option"`, `whose="model's"`) and of its other `with_...`
    methods. `method` names the call (`"Net.with_model"`); `known` is listed as given."""
    unknown = sorted(set(given) - set(known))
    if unknown:
        raise ValueError(f"{method}: unknown {kind}(s) {unknown}; the {whose} are {list(known)}.")


class AbstractPattern(abc.ABC):
    """What is folded (panels, hinges, seams, the physics model) and what counts as folded.

    **Attributes** every pattern has: `name` (a label: the catalogue name or file stem for a net,
    what stored metadata records).

    **Members** (abstract unless said):
    - `n_hinges`: hinges of the systems it builds (static).
    - `hinge_name(j)`: what reports call hinge `j` (counted from 0).
    - `n_loops` (concrete, 0): closed loops of hinges.
    - `intended_angles`: the fold angle each hinge should reach (rad, `(n_hinges,)`): what counts
      as folded.
    - `seams`: the seams that close when it folds (`origami_jax.fold.SeamSet`), or `None`.
    - `continues_from_angles`: whether a run can be continued from its last hinge angles and
      rates (a closed-loop pattern's state is more than its angles).
    - `default_design(fluid=None)`: the `HingeDesign` it is folded with when none is given.
    - `system(design=None, *, targets=None, release_times=None)`: its
      [`origami_jax.system.FoldingSystem`][] with the hinges, films and fluid of `design` (targets
      in rad, release times in time units, `(n_hinges,)` each). Calling the pattern,
      ``pattern(design)``, is ``pattern.system(design)`` (concrete): the layout that `design`
      and `sweep` rebuild for every candidate.
    - `start_state(system=None, *, bias=0.0)`: `(θ0, θ̇0)` (rad, rad/time, `(n_hinges,)`), where a
      simulation starts (`bias`: a pre-fold, rad; patterns that start flat take 0 only).
    - `assess(system, trajectory, *, bias=0.0, **kwargs)`: the verdict on a folding (a
      `FoldReport`; keyword arguments go to `origami_jax.simulation.assess`).
    - `outcome(system, trajectory, **kwargs)`: that verdict as arrays, traceable (a
      `FoldOutcome`).
    - `fold(system, inputs=None, *, t1=None, bias=0.0, tolerances=None, ...)`: simulate and
      judge, `(trajectory, report)`.
    - `kernel(**settings)`: its sweep kernel (`origami_jax.sweep.Kernel`), one design per call.
    - `resume_settings()`: what a stored sweep of it must record so that a resume checks it is the
      same pattern (JSON-able; names, not objects).
    - `with_model(**options)`: the same pattern with other physics options.
    """

    name: str

    @property
    @abc.abstractmethod
    def n_hinges(self) -> int:
        """Hinges of the systems this pattern builds (static)."""

    @abc.abstractmethod
    def hinge_name(self, j: int) -> str:
        """What reports call hinge `j` (counted from 0)."""

    @property
    @abc.abstractmethod
    def intended_angles(self) -> np.ndarray:
        """The fold angle each hinge should reach (rad, `(n_hinges,)`)."""

    @property
    @abc.abstractmethod
    def seams(self) -> Any:
        """The seams that close when the pattern folds, or `None` (none)."""

    @property
    def n_loops(self) -> int:
        """Closed loops of hinges (0: the panels form a tree, as a net's and a chain's do)."""
        return 0

    @property
    @abc.abstractmethod
    def continues_from_angles(self) -> bool:
        """Whether a run can be continued from its last hinge angles and rates."""

    @abc.abstractmethod
    def default_design(self, fluid=None) -> HingeDesign:
        """The design the pattern is folded with when none is given, in `fluid` (a `Fluid`;
        `None`: the literature design's)."""

    @abc.abstractmethod
    def system(
        self, design: HingeDesign | None = None, *, targets=None, release_times=None
    ) -> FoldingSystem:
        """The folding system of this pattern with the hinges, films and fluid of `design`."""

    def __call__(self, design: HingeDesign) -> FoldingSystem:
        """``pattern.system(design)``: the pattern as the layout `design` and `sweep` rebuild."""
        return self.system(design)

    @abc.abstractmethod
    def start_state(self, system: FoldingSystem | None = None, *, bias: float = 0.0):
        """Where a simulation starts: `(θ0, θ̇0)` (rad, rad/time)."""

    @abc.abstractmethod
    def assess(self, system: FoldingSystem, trajectory, *, bias: float = 0.0, **kwargs):
        """The verdict on a folding of this pattern (a `FoldReport`)."""

    @abc.abstractmethod
    def outcome(self, system: FoldingSystem, trajectory, **kwargs):
        """`assess`'s verdict as arrays, traceable (a `FoldOutcome`)."""

    @abc.abstractmethod
    def fold(
        self,
        system: FoldingSystem,
        inputs=None,
        options=None,
        *,
        t1=None,
        bias=0.0,
        tolerances=None,
    ):
        """Simulate `system` (one this pattern built) under `inputs` (default a step release) with
        `options` (an `origami_jax.simulation.SolveOptions`) and judge the run:
        `(trajectory, report)`."""

    @abc.abstractmethod
    def kernel(self, **settings):
        """The pattern's sweep kernel (`origami_jax.sweep.Kernel`) with `settings`."""

    @abc.abstractmethod
    def resume_settings(self) -> dict[str, Any]:
        """What a stored sweep of this pattern records to be resumed (JSON-able)."""

    @abc.abstractmethod
    def with_model(self, **options) -> "AbstractPattern":
        """The same pattern with other physics options."""
