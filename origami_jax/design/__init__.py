"""Gradient-based hinge design and calibration to measured responses.

```python
import origami_jax.design as ojd
from origami_jax.system import HingeDesign

targets = ojd.Targets(rise_time=[37.0, 101.0, 38.0], overshoot=[0.39, nan, nan])   # µs, fraction
result = ojd.calibrate(HingeDesign.literature(), targets, ["k_scale", "b_scale"],
                       bounds={"k_scale": (0.1, 100), "b_scale": (0.1, 1000)})
print(result.summary())
```

- `design` / `calibrate`: bounded (sigmoid-reparametrised) least squares through the simulation,
  Levenberg–Marquardt from several starts in one vmapped batch; a `DesignResult` with the metrics next to
  the targets, sensitivities, an identifiability verdict and a report of unreachable targets.
- `Targets`, `MeasuredCurve`: what to aim at. `ParameterSpace` / `parameter_space`: free parameters.
- `fit_batch`: the multi-start least-squares driver over any residual function; `default_solver`
  (`GaussNewtonStepStop`, a Levenberg–Marquardt that also stops on a negligible next step).
- `identifiability`: rank and (non-)determined combinations of a sensitivity matrix.
- `PLAUSIBLE_RANGES`, `plausible_bounds`: physically plausible ranges of the design's parameters,
  with their sources, for calibrations that must stay inside what a device can be.
- `calibrate_extended`: the paper's Fig. 7 with plausible parameters only, for the paper's model
  and each added effect (viscous drag, added inertia, arc hinges, all), with the best fit, misses and
  sensitivities per variant (`ExtendedCalibration`).
- Plots: `origami_jax.design.plot_response` (imports matplotlib when called).
"""

from ._design import DEFAULT_TOLERANCE as DEFAULT_TOLERANCE
from ._design import SimulationSettings as SimulationSettings
from ._design import calibrate as calibrate
from ._design import design as design
from ._design import evaluate as evaluate
from ._design import residual_and_jacobian as residual_and_jacobian
from ._design import residual_at as residual_at
from ._design import response as response
from ._extended_fit import FIG7_TOLERANCE as FIG7_TOLERANCE
from ._extended_fit import VARIANTS as VARIANTS
from ._extended_fit import ExtendedCalibration as ExtendedCalibration
from ._extended_fit import ModelVariant as ModelVariant
from ._extended_fit import VariantFit as VariantFit
from ._extended_fit import calibrate_extended as calibrate_extended
from ._extended_fit import fig7_targets as fig7_targets
from ._identify import RANK_RTOL as RANK_RTOL
from ._identify import WEAK_RTOL as WEAK_RTOL
from ._identify import Identifiability as Identifiability
from ._identify import identifiability as identifiability
from ._lstsq import RESULTS as RESULTS
from ._lstsq import FitBatch as FitBatch
from ._lstsq import GaussNewtonStepStop as GaussNewtonStepStop
from ._lstsq import default_solver as default_solver
from ._lstsq import fit_batch as fit_batch
from ._plausible import PLAUSIBLE_RANGES as PLAUSIBLE_RANGES
from ._plausible import PlausibleRange as PlausibleRange
from ._plausible import plausible_bounds as plausible_bounds
from ._plot import plot_response as plot_response
from ._report import DesignResult as DesignResult
from ._report import TargetRow as TargetRow
from ._space import PARAMETER_NAMES as PARAMETER_NAMES
from ._space import ParameterSpace as ParameterSpace
from ._space import parameter_space as parameter_space
from ._space import parameter_unit as parameter_unit
from ._targets import KINDS as KINDS
from ._targets import MeasuredCurve as MeasuredCurve
from ._targets import Targets as Targets
from ._targets import time_horizon as time_horizon
