"""Contact between panels: smooth, frictionless, energy-consistent, differentiable.

- [`origami_jax.contact.PanelContact`][]: the contact model a [`origami_jax.system.FoldingSystem`][]
  takes (`contact=`), for any mechanism (chains, panel trees) through its geometry
  (`body_poses`, `outlines`, `hinge_layout`); IPC's log barrier on plate-to-plate gaps with thickness.
- [`origami_jax.contact.ContactTables`][]: its static geometry (rim points, faces, pairs).
- [`origami_jax.contact.Adhesion`][], [`origami_jax.contact.Friction`][]: optional surface physics of
  `PlateContact` (adhesion of touching faces and seams, smoothed Coulomb friction).
- `barrier`, `smoothstep`: the scalar functions it is built from.
- `overlap_depth`, `additive_ccd`, `earliest_impact`, `closest_on_polygon`: the plate contact's exact
  primitives (the overlap of two plates, conservative times of impact, closest points).
- `contact_points`: where a system's panels touch along a trajectory (for views and exports).
"""

from ._barrier import barrier as barrier
from ._barrier import smoothstep as smoothstep
from ._kind import CONTACT_MODELS as CONTACT_MODELS
from ._kind import DEFAULT_CONTACT as DEFAULT_CONTACT
from ._kind import check_sampling as check_sampling
from ._kind import contact_kind as contact_kind
from ._model import PanelContact as PanelContact
from ._model import contact_points as contact_points
from ._plate_tables import PlateTables as PlateTables
from ._plate_tables import build_plate_tables as build_plate_tables
from ._plates import PairSelection as PairSelection
from ._plates import PlateContact as PlateContact
from ._primitives import additive_ccd as additive_ccd
from ._primitives import closest_on_polygon as closest_on_polygon
from ._primitives import earliest_impact as earliest_impact
from ._primitives import overlap_depth as overlap_depth
from ._surface import Adhesion as Adhesion
from ._surface import Friction as Friction
from ._surface import SurfaceTables as SurfaceTables
from ._surface import build_surface_tables as build_surface_tables
from ._tables import ContactTables as ContactTables
from ._tables import build_tables as build_tables
from ._tables import sampling_pair as sampling_pair
