"""The folding system: one model object for every engine, and the physics every mechanism shares.

- [`origami_jax.system.FoldingSystem`][]: mechanism + hinges + drag + contact, the one object that
  `simulate`, `design` and `sweep` take. Builders: [`origami_jax.chain.accordion_system`][].
- [`origami_jax.system.AbstractPattern`][]: what is folded and what counts as folded (a net, a
  crease pattern, the accordion): its systems, start state, fold, verdict and sweep kernel.
- [`origami_jax.system.AbstractMechanism`][]: the contract a mechanism implements (state layout, mass
  matrix and forward dynamics, hinge angles, energy, geometry); the serial chain is the first.
- [`origami_jax.system.Hinges`][], [`origami_jax.system.HingeDrag`][] and the abstract drag and
  contact models; [`origami_jax.system.Agitation`][], random forcing by the bath (Langevin).
- Hinge physics shared by every mechanism: [`origami_jax.system.HingeDesign`][] (bilayer films,
  Timoshenko curvature, stiffness and drag, paper Eqs. 7 and 11), materials, fluids, unit systems.
- Published measurements of stressed bilayers against that curvature:
  [`origami_jax.system.MEASURED_HINGES`][], [`origami_jax.system.compare_measured_hinges`][]
  (docs/guides/hinge-measurements.md).
"""

from ._agitation import BOLTZMANN as BOLTZMANN
from ._agitation import Agitation as Agitation
from ._drag import AbstractDrag as AbstractDrag
from ._drag import HingeDrag as HingeDrag
from ._hinge import AIR as AIR
from ._hinge import CR as CR
from ._hinge import KOH_SOLUTION as KOH_SOLUTION
from ._hinge import LIQUID_DENSITY as LIQUID_DENSITY
from ._hinge import SINX as SINX
from ._hinge import Fluid as Fluid
from ._hinge import HingeDesign as HingeDesign
from ._hinge import Material as Material
from ._hinge import biaxial_modulus as biaxial_modulus
from ._hinge import bilayer_curvature as bilayer_curvature
from ._hinges import Hinges as Hinges
from ._measured_hinges import MEASURED_HINGES as MEASURED_HINGES
from ._measured_hinges import HingeComparison as HingeComparison
from ._measured_hinges import MeasuredFilm as MeasuredFilm
from ._measured_hinges import MeasuredHinge as MeasuredHinge
from ._measured_hinges import compare_measured_hinges as compare_measured_hinges
from ._measured_hinges import measured_hinges_table as measured_hinges_table
from ._mechanism import AbstractMechanism as AbstractMechanism
from ._mechanism import HingeLayout as HingeLayout
from ._pattern import AbstractPattern as AbstractPattern
from ._pattern import check_known_names as check_known_names
from ._system import AbstractContact as AbstractContact
from ._system import FoldingSystem as FoldingSystem
from ._system import rest_inertia as rest_inertia
from ._units import MICRO as MICRO
from ._units import SI as SI
from ._units import UnitSystem as UnitSystem

AbstractLayout = AbstractPattern
"""The former name of [`origami_jax.system.AbstractPattern`][] (a layout is now its pattern)."""
