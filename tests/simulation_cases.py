"""Shared, cached simulation cases for tests/test_simulation_*.py.

Every default-solver solve of the 3-flap accordion uses the same structure (input type, `n_save`, tolerances,
`max_steps`), so the whole suite compiles it once; cheap Tsit5 single-flap cases cover failure handling.
"""

import functools

import numpy as np

import origami_jax.simulation as sim
from origami_jax.chain import accordion_system
from origami_jax.system import AIR, KOH_SOLUTION, MICRO, HingeDesign

# One structure for every default-solver accordion solve in the tests (one compilation).
N_SAVE = 1201
RTOL = 1e-9
ATOL = 1e-11
FLUIDS = {"air": AIR, "koh": KOH_SOLUTION}


def literature(fluid: str = "air", units=MICRO, **overrides):
    """The literature design and its 3-flap accordion system."""
    design = HingeDesign.literature(units=units, fluid=FLUIDS[fluid], **overrides)
    return design, accordion_system(design, 3)


def step_simulation(
    fluid: str = "air", units=MICRO, t1_us: float = 1200.0, solver=None, **overrides
):
    _, system = literature(fluid, units, **overrides)
    t1 = units.time(t1_us * 1e-6)
    # θ is in rad in both unit systems; θ̇ is 1e6× larger in SI, where rtol dominates anyway.
    return sim.simulate(
        system,
        sim.Step(),
        sim.SolveOptions(saveat=sim.SaveAt(n=N_SAVE), rtol=RTOL, atol=ATOL, solver=solver),
        t1=t1,
    )


@functools.cache
def air_step():
    return step_simulation("air")


@functools.cache
def air_step_metrics():
    return sim.response_metrics(air_step())


def as_numpy(x):
    return np.asarray(x)
