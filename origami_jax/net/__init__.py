"""Nets of rigid panels: panel trees and their dynamics.

A net's panels joined by its creases form a tree once its seams are cut.
[`origami_jax.net.PanelTree`][] implements [`origami_jax.system.AbstractMechanism`][] for any such
tree with Featherstone's algorithms in the world frame (CRBA, RNEA, the tree-sparse ``LᵀL`` solve);
[`origami_jax.net.panel_tree`][] builds one from a flat pattern of polygonal plates
([`origami_jax.net.polygon_plate`][]). Hinges are point creases ([`origami_jax.net.RevoluteJoints`][])
or bending arcs ([`origami_jax.net.ArcJoints`][]); [`origami_jax.net.StripTree`][] gives the arcs'
strips their own mass and inertia ([`origami_jax.net.strip_tree`][]); a net laid out for them
([`origami_jax.net.fillet_layout`][]) trims its panels so that its seams close; a net drawn with its
hinge strips in FOLD is read as such, and [`origami_jax.net.strip_fold`][] draws one. Fold angles
are valley positive.

[`origami_jax.net.Net`][] is a pattern ([`origami_jax.system.AbstractPattern`][]) read from FOLD; it
and the closed-loop crease patterns built on it ([`origami_jax.loops.CreasePattern`][]) share
[`origami_jax.net.AbstractPanelPattern`][], their default design, hinge checks, seam gaps, FOLD
animation and etch fronts (exported here for the loops package) and their sweep kernel,
[`origami_jax.net.fold_kernel`][].
"""

from ..simulation import SeamGaps as SeamGaps
from ._fillet import ArcLayout as ArcLayout
from ._fillet import arc_length as arc_length
from ._fillet import fillet_layout as fillet_layout
from ._fillet import fillet_trim as fillet_trim
from ._joints import AbstractJoints as AbstractJoints
from ._joints import ArcJoints as ArcJoints
from ._joints import RevoluteJoints as RevoluteJoints
from ._kernel import FOLD_KERNEL_SOLVE as FOLD_KERNEL_SOLVE
from ._kernel import check_agitation_balanced as check_agitation_balanced
from ._kernel import check_kernel_sampling as check_kernel_sampling
from ._kernel import default_t_end as default_t_end
from ._kernel import fold_kernel as fold_kernel
from ._kernel import model_settings as model_settings
from ._kernel import stored_tolerances as stored_tolerances
from ._kernel import surface_settings as surface_settings
from ._net import Net as Net
from ._net import NetLayout as NetLayout
from ._net import folding_animation as folding_animation
from ._net import kept_samples as kept_samples
from ._net import load_net as load_net
from ._net import release_times_from_front as release_times_from_front
from ._net import seam_gap_function as seam_gap_function
from ._net import vertex_corners as vertex_corners
from ._pattern import AbstractPanelPattern as AbstractPanelPattern
from ._pattern import HostCache as HostCache
from ._pattern import check_hinges_longer_than_film as check_hinges_longer_than_film
from ._pattern import check_loader_arguments as check_loader_arguments
from ._pattern import check_per_crease as check_per_crease
from ._pattern import check_physics_options as check_physics_options
from ._pattern import check_release_ramp as check_release_ramp
from ._pattern import check_surface_model as check_surface_model
from ._pattern import default_design as default_design
from ._pattern import front_release as front_release
from ._pattern import hinges_within_creases as hinges_within_creases
from ._pattern import unit_front_direction as unit_front_direction
from ._pattern import warn_if_hinges_wider_than_creases as warn_if_hinges_wider_than_creases
from ._pattern import with_fluid_loads as with_fluid_loads
from ._pattern import with_surface_physics as with_surface_physics
from ._plate import Plate as Plate
from ._plate import polygon_plate as polygon_plate
from ._strip import StripTree as StripTree
from ._strip import strip_tree as strip_tree
from ._strips import HINGE_KEY as HINGE_KEY
from ._strips import strip_fold as strip_fold
from ._tree import PanelTree as PanelTree
from ._tree import panel_tree as panel_tree
