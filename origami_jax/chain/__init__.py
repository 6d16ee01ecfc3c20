"""Hinged-flap chains (paper Eqs. 8–11): the serial chain mechanism, its kinematics and dynamics.

[`origami_jax.chain.Chain`][] implements [`origami_jax.system.AbstractMechanism`][];
[`origami_jax.chain.accordion_system`][] builds the paper's accordion as a
[`origami_jax.system.FoldingSystem`][] from a [`origami_jax.system.HingeDesign`][]. Kernels are
unit-agnostic; the builders take their constants in a `UnitSystem` (`MICRO`: µm, µs, ng, by default).
FOLD files in and out: `load_chain` (an accordion crease pattern) and `trajectory_to_fold` (a
simulated folding as a FOLD animation). `compare_models`: the paper's model next to the extended
one (arc hinges, the fluid's inertia and viscosity, contact) on Fig. 7's step in air and KOH and the
etch ramp, with the physical reason for each difference; `model_designs` (the literature device
under both models) and `accordion_diagnostics` (where they differ, in numbers) are its pieces.
"""

from ._chain import FLAP_SIZE_SI as FLAP_SIZE_SI
from ._chain import Chain as Chain
from ._chain import accordion as accordion
from ._chain import flap_chain as flap_chain
from ._chain import flap_size as flap_size
from ._chain import plate_inertia as plate_inertia
from ._compare import ModelComparison as ModelComparison
from ._compare import accordion_diagnostics as accordion_diagnostics
from ._compare import compare_models as compare_models
from ._compare import model_designs as model_designs
from ._compare import plot_comparison as plot_comparison
from ._dynamics import bias_torque as bias_torque
from ._dynamics import coriolis_matrix as coriolis_matrix
from ._dynamics import forward_dynamics as forward_dynamics
from ._dynamics import hinge_torque as hinge_torque
from ._dynamics import inverse_dynamics as inverse_dynamics
from ._dynamics import kinetic_energy as kinetic_energy
from ._dynamics import mass_matrix as mass_matrix
from ._dynamics import potential_energy as potential_energy
from ._extended import tip_contact_angle as tip_contact_angle
from ._fold import accordion_dimensions as accordion_dimensions
from ._fold import chain_from_geometry as chain_from_geometry
from ._fold import load_chain as load_chain
from ._fold import trajectory_to_fold as trajectory_to_fold
from ._kernel import ACCORDION_PARAMETERS as ACCORDION_PARAMETERS
from ._kernel import accordion_step as accordion_step
from ._kinematics import body_jacobians as body_jacobians
from ._kinematics import forward_kinematics as forward_kinematics
from ._kinematics import spatial_jacobians as spatial_jacobians
from ._pattern import ACCORDION_GEOMETRY as ACCORDION_GEOMETRY
from ._pattern import Accordion as Accordion
from ._se3 import adjoint as adjoint
from ._se3 import exp_so3 as exp_so3
from ._se3 import exp_twist as exp_twist
from ._se3 import hat as hat
from ._se3 import inverse_adjoint as inverse_adjoint
from ._se3 import inverse_transform as inverse_transform
from ._se3 import make_transform as make_transform
from ._se3 import revolute_twist as revolute_twist
from ._se3 import twist_hat as twist_hat
from ._se3 import twist_vee as twist_vee
from ._se3 import vee as vee
from ._system import accordion_system as accordion_system
from ._system import alternating_targets as alternating_targets
