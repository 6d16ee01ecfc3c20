"""FOLD format (spec 1.2, Demaine, Ku and Lang) input and output.

Read crease patterns and folded states written by Origami Simulator, Rabbit Ear, crease-pattern
editors or by hand; write single-vertex states, unfolding paths and chain trajectories as FOLD
animations (`file_frames`) that those tools load. This package is plain NumPy and knows no physics:
the physics packages build their objects from it (`origami_jax.vertex.load_single_vertex`,
`origami_jax.chain.load_chain`) and feed it their results (`origami_jax.vertex.unfolding_to_fold`,
`origami_jax.vertex.single_vertex_to_fold`, `origami_jax.chain.trajectory_to_fold`).

- Reading: `read_fold` → `FoldFile` (frames of `FoldFrame`), checked by `check_fold` and, when
  `jsonschema` is installed, by the shipped schema (`fold_schema()`); errors are `FoldFormatError`.
- Geometry (plain arrays, radians): `list_vertices`, `single_vertex_geometry`, `chain_geometry`,
  `net_geometry` (a net of rigid panels joined by creases into a tree: polyhedra, corner cubes);
  `unfold_folded_form` (a folded form's flat crease pattern, fold angles from its dihedral angles);
  `triangulate`, `signed_area`, `convex_hull` and `convex_pieces` for a face's polygon.
- Catalogue of shipped nets: `catalogue_names`, `catalogue_path` (accordion, corner cube, the eleven
  cube nets, tetrahedron, the eleven octahedron nets and the first-drawn `octahedron`);
  `catalogue_family` names a family's members (`cube_nets`, `octahedron_nets`:
  `catalogue_families`).
- Writing: `write_fold`, `normalise_fold`; `single_vertex_fold` / `chain_fold` from plain arrays.

Conventions: FOLD stores fold angles in degrees (valley +, mountain −); the model keeps them so
(`FoldFrame.edges_fold_angle_deg`), geometry and physics use radians.
"""

from ._catalogue import catalogue_families as catalogue_families
from ._catalogue import catalogue_family as catalogue_family
from ._catalogue import catalogue_names as catalogue_names
from ._catalogue import catalogue_path as catalogue_path
from ._catalogue import source_and_label as source_and_label
from ._chain_geometry import ChainGeometry as ChainGeometry
from ._chain_geometry import chain_geometry as chain_geometry
from ._checks import check_fold as check_fold
from ._convex_pieces import convex_hull as convex_hull
from ._convex_pieces import convex_pieces as convex_pieces
from ._errors import FoldFormatError as FoldFormatError
from ._geometry import VertexGeometry as VertexGeometry
from ._geometry import VertexInfo as VertexInfo
from ._geometry import candidate_vertices as candidate_vertices
from ._geometry import fold_angles_from_coords as fold_angles_from_coords
from ._geometry import format_vertex_table as format_vertex_table
from ._geometry import list_vertices as list_vertices
from ._geometry import paper_plane as paper_plane
from ._geometry import pick_vertex as pick_vertex
from ._geometry import single_vertex_geometry as single_vertex_geometry
from ._geometry import vertex_fold_angles as vertex_fold_angles
from ._loop_geometry import LoopGeometry as LoopGeometry
from ._loop_geometry import flat_faces_merged as flat_faces_merged
from ._loop_geometry import loop_geometry as loop_geometry
from ._model import FRAME_UNITS_M as FRAME_UNITS_M
from ._model import FoldFile as FoldFile
from ._model import FoldFrame as FoldFrame
from ._model import length_scale_from_unit as length_scale_from_unit
from ._net_geometry import NetGeometry as NetGeometry
from ._net_geometry import Seams as Seams
from ._net_geometry import net_geometry as net_geometry
from ._polygons import signed_area as signed_area
from ._polygons import triangulate as triangulate
from ._read import fold_from_dict as fold_from_dict
from ._read import loads_fold as loads_fold
from ._read import read_fold as read_fold
from ._schema import fold_schema as fold_schema
from ._schema import validate_schema as validate_schema
from ._states import chain_fold as chain_fold
from ._states import single_vertex_fold as single_vertex_fold
from ._unfold import flat_fold as flat_fold
from ._unfold import is_folded_form as is_folded_form
from ._unfold import unfold_folded_form as unfold_folded_form
from ._write import dumps_fold as dumps_fold
from ._write import normalise_fold as normalise_fold
from ._write import planar_faces as planar_faces
from ._write import write_fold as write_fold
