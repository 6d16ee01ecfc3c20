"""Folding simulation: inputs, `simulate`, response metrics, fold verdicts.

Paper sections "Open Loop Control Law", "Step Input", "Ramp Input", Figs. 7–11; docs/physics.md, "Inputs",
"Results to reproduce", "Numerics".
"""

from ._continue import fold_pattern as fold_pattern
from ._continue import fold_until_settled as fold_until_settled
from ._continue import join_trajectories as join_trajectories
from ._implicit import FIXED_STEP_PRE_FOLD as FIXED_STEP_PRE_FOLD
from ._implicit import ImplicitStep as ImplicitStep
from ._implicit import start_bias as start_bias
from ._inputs import FAST_RAMP_DURATION_SI as FAST_RAMP_DURATION_SI
from ._inputs import KOH_ETCH_RATE_SI as KOH_ETCH_RATE_SI
from ._inputs import AbstractInput as AbstractInput
from ._inputs import EtchRamp as EtchRamp
from ._inputs import Step as Step
from ._inputs import UserTorque as UserTorque
from ._inputs import fast_ramp as fast_ramp
from ._inputs import quasi_static_ramp as quasi_static_ramp
from ._metrics import ResponseMetrics as ResponseMetrics
from ._metrics import response_metrics as response_metrics
from ._options import DEFAULT_ATOL as DEFAULT_ATOL
from ._options import DEFAULT_MAX_STEPS as DEFAULT_MAX_STEPS
from ._options import DEFAULT_N_SAVE as DEFAULT_N_SAVE
from ._options import DEFAULT_RTOL as DEFAULT_RTOL
from ._options import FIT_ATOL as FIT_ATOL
from ._options import FIT_N_SAVE as FIT_N_SAVE
from ._options import FIT_OPTIONS as FIT_OPTIONS
from ._options import FIT_RTOL as FIT_RTOL
from ._options import FIXED_STEP_SOLVERS as FIXED_STEP_SOLVERS
from ._options import SLOW_RAMP_OPTIONS as SLOW_RAMP_OPTIONS
from ._options import SLOW_RAMP_WINDOW_OPTIONS as SLOW_RAMP_WINDOW_OPTIONS
from ._options import SOLVER_NAMES as SOLVER_NAMES
from ._options import SaveAt as SaveAt
from ._options import SolveOptions as SolveOptions
from ._options import named_solver as named_solver
from ._results import RESULTS as RESULTS
from ._results import kernel_result_messages as kernel_result_messages
from ._simulate import Trajectory as Trajectory
from ._simulate import default_controller as default_controller
from ._simulate import default_solver as default_solver
from ._simulate import padded_sample_count as padded_sample_count
from ._simulate import simulate as simulate
from ._slow_ramp import SlowRampResult as SlowRampResult
from ._slow_ramp import simulate_slow_ramp as simulate_slow_ramp
from ._switching import StiffnessSwitching as StiffnessSwitching
from ._switching import implicit_solver as implicit_solver
from ._verdict import DEFAULT_TOLERANCES as DEFAULT_TOLERANCES
from ._verdict import LEGACY_SEAM_FRACTION as LEGACY_SEAM_FRACTION
from ._verdict import VERDICT_CODES as VERDICT_CODES
from ._verdict import AbstractFoldReport as AbstractFoldReport
from ._verdict import FoldOutcome as FoldOutcome
from ._verdict import FoldReport as FoldReport
from ._verdict import FoldVerdict as FoldVerdict
from ._verdict import SeamGaps as SeamGaps
from ._verdict import VerdictTolerances as VerdictTolerances
from ._verdict import assess as assess
from ._verdict import derived_seam_tolerances as derived_seam_tolerances
from ._verdict import fold_outcome as fold_outcome
from ._verdict import thermal_wobble as thermal_wobble
