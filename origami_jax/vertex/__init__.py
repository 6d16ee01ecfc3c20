"""Single-vertex origami: charge-energy unfolding with a collision-free path and a verdict.

Paper Eqs. 1–6, Figs. 2–3; docs/physics.md, "Single-vertex unfolding". Build a `SingleVertex` (from fold angles, directions or
spherical coordinates, or from the catalogue), then `unfold` it::

    result = unfold(corner_cube(), energy="separable")
    result.verdict  # Verdict.FLAT_UNFOLDED

FOLD files in and out: `load_single_vertex` (a crease pattern or folded state at one of its
vertices), `single_vertex_to_fold` and `unfolding_to_fold` (an unfolding path as a FOLD animation).
"""

from ._catalogue import close_loop as close_loop
from ._catalogue import corner_cube as corner_cube
from ._catalogue import degree4_vertex as degree4_vertex
from ._catalogue import open_chain_vertex as open_chain_vertex
from ._catalogue import random_vertex as random_vertex
from ._catalogue import random_vertices as random_vertices
from ._catalogue import stack_vertices as stack_vertices
from ._catalogue import waterbomb_base as waterbomb_base
from ._descent import CERT_MARGIN as CERT_MARGIN
from ._descent import RESULTS as RESULTS
from ._descent import DescentOutput as DescentOutput
from ._descent import DescentSettings as DescentSettings
from ._energy import DEFAULT_P as DEFAULT_P
from ._energy import charge_distances as charge_distances
from ._energy import energy as energy
from ._energy import nonseparable_energy as nonseparable_energy
from ._energy import separable_energy as separable_energy
from ._fold import load_single_vertex as load_single_vertex
from ._fold import single_vertex_to_fold as single_vertex_to_fold
from ._fold import unfolding_to_fold as unfolding_to_fold
from ._fold import vertex_from_geometry as vertex_from_geometry
from ._geometry import Topology as Topology
from ._geometry import arc_pair_clearances as arc_pair_clearances
from ._geometry import arcs_cross as arcs_cross
from ._geometry import chain_from_fold_angles as chain_from_fold_angles
from ._geometry import constraints as constraints
from ._geometry import planarity as planarity
from ._geometry import point_arc_distance as point_arc_distance
from ._geometry import topology as topology
from ._model import FLAT_FOLD_TOL as FLAT_FOLD_TOL
from ._model import PLANAR_TOL as PLANAR_TOL
from ._model import InvalidVertexError as InvalidVertexError
from ._model import SingleVertex as SingleVertex
from ._model import ValidationReport as ValidationReport
from ._model import fold_angles as fold_angles
from ._model import spherical_arc_lengths as spherical_arc_lengths
from ._model import to_spherical as to_spherical
from ._model import validate_vertex as validate_vertex
from ._unfold import BatchResult as BatchResult
from ._unfold import Certificate as Certificate
from ._unfold import CreaseReport as CreaseReport
from ._unfold import UnfoldResult as UnfoldResult
from ._unfold import Verdict as Verdict
from ._unfold import certify_path as certify_path
from ._unfold import unfold as unfold
from ._unfold import unfold_batch as unfold_batch
from ._unfold import unfold_kernel as unfold_kernel
