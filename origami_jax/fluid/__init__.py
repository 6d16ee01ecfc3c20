"""The fluid a device folds in: drag models beyond the paper's hinge drag.

- [`origami_jax.fluid.PanelDrag`][]: quadratic pressure drag on every panel from its own motion
  (strip theory integrated over the panel), for any mechanism.
- [`origami_jax.fluid.PanelQuadrature`][], `polygon_quadrature`: integration over panels.

The paper's model, ``−b θ̇|θ̇|`` per hinge, is [`origami_jax.system.HingeDrag`][].
"""

from ._panel_drag import PanelDrag as PanelDrag
from ._panel_drag import PanelQuadrature as PanelQuadrature
from ._quadrature import polygon_quadrature as polygon_quadrature
