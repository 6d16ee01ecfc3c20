"""Yield: how often a fabricated net folds into the intended shape.

What self-folding labs report is yield, the fraction of fabricated nets that close into the shape
they were drawn for (Azam et al., PLoS ONE 4, e4451, 2009; Pandey et al., PNAS 108, 2011). Films
vary in stress and thickness across a wafer and hinges release at different times, so a net that
folds perfectly with ideal hinges can jam or misfold with real ones. `yield_estimate` measures
this by Monte Carlo:

```python
import origami_jax.fab_yield as ojy
from origami_jax.loops import load_pattern

cube = load_pattern("cube_net_01")  # a pattern object: names become patterns once, here
estimate = ojy.yield_estimate(cube, ojy.Scatter(), 200, seed=0, run=ojy.RunOptions(out="yield_out"))
print(estimate.summary())   # yield 0.81 (95 % interval 0.75-0.86, wilson) over 200 samples: ...
estimate.dataset            # xarray.Dataset: the drawn parameters and every sample's verdict
```

- `Scatter`: one `Spread` per parameter (film misfit strain, i.e. film stress; hinge film and
  membrane thickness; hinge width; drag coefficient; release time): normal, lognormal or uniform,
  relative or absolute, per crease or one draw per net. Defaults and their sources: `Scatter`.
  `load_scatter` reads one from TOML; bad configs are refused with one line before anything
  compiles.
- Each sample is a full folding simulation with contact (`origami_jax.net.Net.system`, explicit
  Tsit5) judged by `origami_jax.simulation.fold_outcome`: folded, jammed, misfolded, unfinished or
  invalid. The hinges are *fabricated*: their lengths are the nominal design's, so a film that
  bends more or less than nominal folds its crease past or short of the target (a contact can
  stop a crease that overfolds; one that underfolds leaves its seams open).
- The samples run through the sweep engine (`origami_jax.sweep.sweep`): chunked, vmapped, sharded
  over the devices, stored as they finish in `RunOptions.out`; `RunOptions(resume=True)`
  continues an interrupted estimate with the same samples; `SampleUntil` as the sample count
  draws in rounds until the interval is as narrow as asked ("±0.1"). The solve's settings are a
  `origami_jax.simulation.SolveOptions`, the physics model the pattern's (`Net.with_model`).
- The result, `YieldEstimate`: the yield, its confidence interval (`wilson_interval`, or
  `clopper_pearson_interval` by `YieldEstimate.with_interval`), the verdict counts and the
  samples as a dataset.

- `yield_gradient`: the yield's gradient with respect to the nominal value of every scattered
  parameter (film stress, thicknesses, hinge widths; normal or lognormal spreads), by the score
  function (likelihood ratio) from an estimate's own samples: no derivative of the simulation, so
  it holds with contact, jams and misfolds, and it is unbiased for the Monte Carlo yield (checked
  against closed forms, and against central differences of the Monte Carlo yield of the corner cube
  with contact). `yield_estimate`'s `process` moves the fabrication's nominal values away from the
  design's (a film deposited more stressed than the hinges were drawn for).
- `yield_ascent`: maximises the yield over the fabrication's nominal values of chosen scattered
  parameters (film stress, thicknesses, hinge widths, release times with a normal spread) by
  stochastic gradient ascent along `yield_gradient`: one estimate per iteration, steps measured in
  spread widths inside a trust region, common random numbers, the best iterate re-estimated on
  fresh draws (`AscentSettings.confirm_samples`). `ascend` is its loop with any estimator; `YieldAscent` the
  iterations (`summary()`, `paired()`; `origami_jax.plotting.fab_yield.ascent_figure` draws them).
- `soft_yield`: a differentiable surrogate of the yield over the same samples (logistic margins of
  each sample's final angles and seams), a traceable function of the drawn hinge angles, widths and
  release times, for `jax.grad`. Checked against finite differences without contact; with contact
  the surrogate is not smooth (a panel stopped by another) and its gradient is not validated: use
  `yield_gradient` there.

- Folding order: release times per crease are design variables (`yield_estimate`'s
  `release_times`, `soft_yield`'s `release` or an etch front's `front_angle` and `front_speed`,
  `front_release_times`); `order_search` estimates the yield of candidate schedules
  (`front_candidates`: all at once, and straight etch fronts from several directions) on the same
  fabricated nets and names the best. `examples/flap_under_flap.fold`, with friction at its
  contacts, jams unless its long flap goes first.
- The verdict's tolerances: `tolerances=`, a `origami_jax.simulation.VerdictTolerances` (the
  angle, and each seam's tolerance derived from it and the geometry by default, or a fixed
  fraction of the panel size). `tolerance_sensitivity`: the yield at multiples of both, from the
  margins every sample stores (`YieldEstimate.tolerance_sensitivity`; nothing simulated again).

- A family of nets: `family_yield` estimates the yield of every net of a family (`"cube_nets"`,
  `"octahedron_nets"`, or a list) from the same seed, each in its own folder (a resumed family
  skips finished nets), and ranks the yields against the nets' compactness (radius of gyration,
  vertex connections: `spearman`), as Azam et al. (PLoS ONE 4, e4451, 2009) did with experiments;
  `FamilyYield` holds the table (`to_csv`) and the correlations.

`yield_estimate` also takes crease patterns with closed loops (pre-folded by `bias`; a sample on
another branch is misfolded); the ascent, the order search and the surrogate take nets only.

Not done yet: arc hinges with designed lengths; the ascent, order search and surrogate for
closed-loop patterns.
"""

from ._ascent import AscentIterate as AscentIterate
from ._ascent import AscentSettings as AscentSettings
from ._ascent import YieldAscent as YieldAscent
from ._ascent import ascend as ascend
from ._ascent import check_ascent as check_ascent
from ._ascent import yield_ascent as yield_ascent
from ._estimate import SETTLE_TIME as SETTLE_TIME
from ._estimate import YIELD_RTOL as YIELD_RTOL
from ._estimate import YIELD_SOLVE as YIELD_SOLVE
from ._estimate import RunOptions as RunOptions
from ._estimate import SampleFold as SampleFold
from ._estimate import YieldEstimate as YieldEstimate
from ._estimate import stored_run_tolerances as stored_run_tolerances
from ._estimate import yield_estimate as yield_estimate
from ._family import MEASURES as MEASURES
from ._family import FamilyYield as FamilyYield
from ._family import NetYield as NetYield
from ._family import RankCorrelation as RankCorrelation
from ._family import family_names as family_names
from ._family import family_yield as family_yield
from ._gradient import YieldGradient as YieldGradient
from ._gradient import score as score
from ._gradient import score_gradient as score_gradient
from ._gradient import yield_gradient as yield_gradient
from ._order import OrderSearch as OrderSearch
from ._order import front_candidates as front_candidates
from ._order import front_release_times as front_release_times
from ._order import order_search as order_search
from ._scatter import DISTRIBUTIONS as DISTRIBUTIONS
from ._scatter import PARAMETERS as PARAMETERS
from ._scatter import Scatter as Scatter
from ._scatter import Spread as Spread
from ._scatter import load_scatter as load_scatter
from ._scatter import sample_values as sample_values
from ._scatter import standard_draws as standard_draws
from ._stats import INTERVAL_METHODS as INTERVAL_METHODS
from ._stats import average_ranks as average_ranks
from ._stats import binomial_interval as binomial_interval
from ._stats import clopper_pearson_interval as clopper_pearson_interval
from ._stats import spearman as spearman
from ._stats import wilson_interval as wilson_interval
from ._surrogate import DESIGN_VARIABLES as DESIGN_VARIABLES
from ._surrogate import SoftYield as SoftYield
from ._surrogate import soft_yield as soft_yield
from ._tolerance import TOLERANCE_FACTORS as TOLERANCE_FACTORS
from ._tolerance import ToleranceSensitivity as ToleranceSensitivity
from ._tolerance import tolerance_sensitivity as tolerance_sensitivity
from ._until import SampleUntil as SampleUntil
