"""Sweep throughput: step responses of the 3-flap accordion over a hinge width × misfit strain grid.

Ours: `origami_jax.sweep.sweep` with the `accordion-step` kernel (one compiled, vmapped call per
chunk; metrics computed inside). Peer: a Python loop of `scipy.integrate.solve_ivp(method="LSODA")`
with a Pinocchio `aba` right-hand side (`τ = K(θ_des − θ) − B θ̇|θ̇|`) over the same designs, same
tolerances, same sample grid, rise time from linear interpolation of the samples.

Sizes: full mode 40 × 25 = 1,000 designs (in air) with Tsit5, and a 10 × 10 sub-grid with Kvaerno5
(the simulation's default implicit solver, ~10× dearer per design here); quick mode 4 × 4 = 16 with
both. The peer loop is run on
an evenly spaced subsample of the designs (50 in full mode, 4 in quick) and its time per design is
extrapolated to the whole grid: the notes of each row say so. Our figure is the steady-state time
(compile time reported apart), plus the end-to-end wall time including compilation and tracing in
`extra`. The sweep reports both: `Dataset.attrs["compile_s"]` (compiling the kernel and the cost
estimate) and `Dataset.attrs["run_s"]`, the time spent computing, copying and labelling chunks (the
steady state, used here). Until 2026-11-26 the steady time was the wall time minus `compile_s`,
which also counted ~3 s of one-off tracing (the kernel's output shapes, the cost pass) against us.
"""

import time

import numpy as np

from ._harness import Result, Timing
from .bench_simulate import accordion_solve_flops

RTOL, ATOL = 1e-8, 1e-10  # the simulation's defaults, used for both
T_END, N_SAVE = 2000.0, 2001  # µs, samples


def _grid(quick: bool, shape: tuple[int, int] | None = None):
    from origami_jax.sweep import Grid

    n_w, n_e = shape if shape is not None else ((4, 4) if quick else (40, 25))
    return Grid(
        {
            "hinge_width": np.geomspace(20.0, 200.0, n_w),
            "misfit_strain": np.linspace(1.5e-3, 4.0e-3, n_e),
        },
        units={"hinge_width": "um"},
    )


def _pinocchio_peer(design_values: dict[str, float]):
    """One design by scipy LSODA + Pinocchio ABA; returns (rise times µs, wall seconds)."""
    import pinocchio as pin
    from scipy.integrate import solve_ivp

    from origami_jax.chain import accordion_system
    from origami_jax.system import MICRO, HingeDesign

    system = accordion_system(HingeDesign.literature(MICRO, **design_values), 3)
    n = 3
    chain = system.mechanism
    k = np.asarray(system.hinges.stiffness)
    b = np.asarray(system.drag.coefficient)
    points = np.asarray(chain.points)
    cg = np.asarray(chain.cg_poses)[:, :3, 3]
    assert np.allclose(np.asarray(chain.axes), [1.0, 0.0, 0.0])
    model = pin.Model()
    # Pinocchio's default gravity 9.81 would be read in µm/µs²; the SPEC's model has none.
    model.gravity.linear[:] = 0.0
    parent, previous = 0, np.zeros(3)
    for i in range(n):
        placement = pin.SE3(np.eye(3), points[i] - previous)
        joint = model.addJoint(parent, pin.JointModelRX(), placement, f"hinge{i}")
        inertia = pin.Inertia(
            float(chain.masses[i]), cg[i] - points[i], np.asarray(chain.inertias[i])
        )
        model.appendBodyToJoint(joint, inertia, pin.SE3.Identity())
        parent, previous = joint, points[i]
    data = model.createData()
    target = np.asarray(system.hinges.target)

    def rhs(t, y):
        q, v = y[:n], y[n:]
        tau = k * (target - q) - b * v * np.abs(v)
        return np.concatenate([v, pin.aba(model, data, q, v, tau)])

    ts = np.linspace(0.0, T_END, N_SAVE)
    start = time.perf_counter()
    solution = solve_ivp(
        rhs, (0.0, T_END), np.zeros(2 * n), method="LSODA", t_eval=ts, rtol=RTOL, atol=ATOL
    )
    y = solution.y[:n].T / target
    rise = []
    for j in range(n):
        t10 = np.interp(0.1, *_first_rise(ts, y[:, j], 0.1))
        t90 = np.interp(0.9, *_first_rise(ts, y[:, j], 0.9))
        rise.append(t90 - t10)
    return np.array(rise), time.perf_counter() - start


def _first_rise(ts, y, level):
    k = int(np.argmax(y >= level))
    return y[k - 1 : k + 1], ts[k - 1 : k + 1]


def run(quick: bool) -> list[Result]:
    import origami_jax.sweep as ojs

    space = _grid(quick)
    columns = space.columns()
    n_designs = space.size
    rows = []
    # Kvaerno5 (the simulation's default, implicit) costs ~1 ms per step per design on this CPU;
    # in full mode it runs on a 10 x 10 sub-grid of the same ranges, Tsit5 on the whole grid.
    cases = [("tsit5", space), ("kvaerno5", space if quick else _grid(quick, shape=(10, 10)))]
    peer_ids = np.linspace(0, n_designs - 1, 4 if quick else 50).round().astype(int)
    peer_rise, peer_seconds = [], []
    for i in peer_ids:
        values = {name: float(columns[name][i]) for name in columns}
        rise, seconds = _pinocchio_peer(values)
        peer_rise.append(rise)
        peer_seconds.append(seconds)
    peer_per_design = float(np.median(peer_seconds))
    for solver, case in cases:
        n_designs = case.size
        peer_total = peer_per_design * n_designs
        kernel = ojs.get_model("accordion-step", rtol=RTOL, atol=ATOL, solver=solver)
        start = time.perf_counter()
        ds = ojs.sweep(kernel, case, progress=False)
        wall = time.perf_counter() - start
        chunk = int(ds.attrs["chunk_size"])
        compile_s = float(ds.attrs["compile_s"])
        # Steady state: the sweep's own time computing and storing chunks (`run_s`), without
        # compilation and without the one-off tracing (output shapes, cost estimates) before it.
        steady = max(float(ds.attrs["run_s"]), 1e-9)
        if case is space:
            check_ids, peer_check = peer_ids, peer_rise
        else:
            # A sub-grid: check the answers on a few of its own designs against the peer too.
            case_columns = case.columns()
            check_ids = np.linspace(0, n_designs - 1, 4).round().astype(int)
            peer_check = [
                _pinocchio_peer({name: float(case_columns[name][i]) for name in case_columns})[0]
                for i in check_ids
            ]
        implicit = solver == "kvaerno5"
        flops = accordion_solve_flops(int(np.sum(ds["num_steps"].values)), implicit=implicit)
        flop_note = (
            "; FLOP = XLA count of one right-hand side x 6"
            + (" + one Jacobian" if implicit else "")
            + " per step x all designs' steps (lower bound: no solver arithmetic, metrics or saving)"
        )
        ours_rise = ds["rise_time"].values[check_ids]
        difference = float(np.nanmax(np.abs(ours_rise - np.asarray(peer_check))))
        rows.append(
            Result(
                name=f"sweep accordion-step ({solver}) {n_designs} designs",
                ours=Timing.once(steady),
                peer_name="scipy LSODA + pinocchio aba loop",
                peer=Timing.once(peer_total),
                compile_s=compile_s,
                max_abs_difference=difference,
                flops=flops,
                per_item=n_designs,
                notes=(
                    f"peer timed on {len(peer_ids)} of the {space.size} grid designs, time per "
                    f"design extrapolated to these {n_designs}; "
                    f"difference = max |rise time ours - peer| in µs on "
                    f"{'those designs' if case is space else '4 designs of this sub-grid'} (peer rise "
                    f"time from linear interpolation of 1 µs samples); failed designs "
                    f"{int(ds.attrs['n_failed'])}; devices {ds.attrs['devices']}{flop_note}"
                ),
                extra={
                    "designs_per_s_steady": n_designs / steady,
                    "designs_per_s_with_compile": n_designs / wall,
                    "peer_designs_per_s": 1.0 / peer_per_design,
                    "wall_s_with_compile": wall,
                    "chunk_size": chunk,
                },
            )
        )
        print(
            f"  {solver}: {n_designs / steady:.2f} designs/s steady, "
            f"{n_designs / wall:.2f} designs/s incl. compile ({compile_s:.0f} s); peer "
            f"{1.0 / peer_per_design:.2f} designs/s; ratio {peer_total / steady:.2f}x",
            flush=True,
        )
    return rows
