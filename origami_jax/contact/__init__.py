"""Contact between panels: smooth, frictionless, energy-consistent, differentiable.

- [`origami_jax.contact.PanelContact`][]: the contact model a [`origami_jax.system.FoldingSystem`][]
  takes (`contact=`), for any mechanism (chains, panel trees) through its geometry
  (`body_poses`, `outlines`, `hinge_layout`); IPC's log barrier on plate-to-plate gaps with thickness.
- [`origami_jax.contact.ContactTables`][]: its static geometry (rim points, faces, pairs).
- `barrier`, `smoothstep`: the scalar functions it is built from.
- `contact_points`: where a system's panels touch along a trajectory (for views and exports).
"""

from ._model import PanelContact as PanelContact
from ._model import barrier as barrier
from ._model import contact_points as contact_points
from ._model import smoothstep as smoothstep
from ._tables import ContactTables as ContactTables
from ._tables import build_tables as build_tables
