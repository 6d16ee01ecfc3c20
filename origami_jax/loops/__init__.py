"""Crease patterns whose creases close loops: single vertices, Miura-ori, waterbomb tessellations.

Every interior vertex of a crease pattern closes a loop of panels. [`origami_jax.loops.LoopedPanels`][]
implements [`origami_jax.system.AbstractMechanism`][] for such patterns: the panels ride on a spanning
tree of the faces (the net engine's [`origami_jax.net.PanelTree`][]) and the creases left out of the
tree are held by the closure of every vertex loop, solved exactly at the constraint level with
Baumgarte stabilisation and an augmented-Lagrangian solve that stays well posed where the loops'
Jacobian loses rank (the flat state, fully folded states). The state is every crease's fold angle, so
hinges, inputs, drag, contact, verdicts, `simulate`, `design` and `sweep` are those of chains and nets.

[`origami_jax.loops.load_pattern`][] reads a catalogue name or FOLD file (nets go to the net engine);
[`origami_jax.loops.CreasePattern`][] builds systems, start states (the branch at the flat state),
verdicts with the branch taken, rigid-foldability reports; [`origami_jax.loops.compare_unfolding`][]
sets the charge-energy unfolding path of a single vertex beside its dynamic folding.
See docs/physics.md, "Closed loops".
"""

from ._compare import UNFOLDING_OPTIONS as UNFOLDING_OPTIONS
from ._compare import PathComparison as PathComparison
from ._compare import compare_unfolding as compare_unfolding
from ._kinematics import CLOSURE_TOL as CLOSURE_TOL
from ._kinematics import RIGID_TOL as RIGID_TOL
from ._kinematics import RigidFoldability as RigidFoldability
from ._mechanism import LoopedPanels as LoopedPanels
from ._pattern import CreasePattern as CreasePattern
from ._pattern import NotRigidlyFoldableError as NotRigidlyFoldableError
from ._pattern import PatternLayout as PatternLayout
from ._pattern import load_pattern as load_pattern
from ._pattern import release_times_from_front as release_times_from_front
from ._report import LoopFoldReport as LoopFoldReport
