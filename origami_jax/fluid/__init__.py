"""The fluid a device folds in: drag and fluid inertia beyond the paper's hinge drag.

- [`origami_jax.fluid.PanelDrag`][]: quadratic pressure drag on every panel from its own motion
  (strip theory integrated over the panel), for any mechanism.
- [`origami_jax.fluid.ViscousDrag`][]: linear (viscous) drag on every panel, a body-frame damping
  matrix; [`origami_jax.fluid.CombinedDrag`][] sums drag models.
- Added (fluid) inertia of a panel, strip theory: `rectangle_added_inertia`,
  `polygon_added_inertia`; Sader's hydrodynamic function for its viscous correction:
  `hydrodynamic_function`; both applied to a mechanism at the fold's frequency by
  [`origami_jax.fluid.fluid_loads`][].
- [`origami_jax.fluid.PanelQuadrature`][], `polygon_quadrature`: integration over panels.

The paper's model, ``−b θ̇|θ̇|`` per hinge, is [`origami_jax.system.HingeDrag`][].
"""

from ._added_mass import bessel_k_ratio as bessel_k_ratio
from ._added_mass import circular_hydrodynamic_function as circular_hydrodynamic_function
from ._added_mass import hydrodynamic_function as hydrodynamic_function
from ._added_mass import polygon_added_inertia as polygon_added_inertia
from ._added_mass import rectangle_added_inertia as rectangle_added_inertia
from ._added_mass import rectangular_correction as rectangular_correction
from ._added_mass import reynolds_number as reynolds_number
from ._loads import FluidLoads as FluidLoads
from ._loads import fluid_loads as fluid_loads
from ._loads import with_added_inertias as with_added_inertias
from ._panel_drag import PanelDrag as PanelDrag
from ._panel_drag import PanelQuadrature as PanelQuadrature
from ._quadrature import polygon_quadrature as polygon_quadrature
from ._viscous import CombinedDrag as CombinedDrag
from ._viscous import ViscousDrag as ViscousDrag
