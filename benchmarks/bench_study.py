"""The compactness study's scatter in MuJoCo: the cube nets' yields, ours against MuJoCo (C), side by side.

The yield issue asks for the study "benchmarked against the same scatter in MuJoCo where MuJoCo can
represent it". What MuJoCo represents: the panels (same tree, inertias, hinge axes), each sample's
hinge springs (the stiffness and aimed angle its drawn films give: film stress, hinge thickness
and width per crease, as `yield_estimate` draws them from the default `Scatter` and seed 0; the
hinge lengths drawn for the nominal design, so a film off its stress folds its crease past or
short of 90°), every hinge released at once, the panels as thin prisms with frictionless soft
contact. What it does not: the bath's added mass and viscous loads (MuJoCo's fluid model is
another one), our panel drag (MuJoCo gets linear joint damping at critical, `bench_net`'s peer),
the membrane thickness's scatter in the panels' mass (2.5 % per net: the nominal tree), adhesion
(not representable); friction it has, and neither side uses it here. So the study's
configuration compared is the pilot's `control` (the paper's dynamics in the bath: no fluid
inertia, released at once, point creases, plate contact), both judged at 1500 µs (ours without
the settling run of samples still moving then), and the verdict
compared is the part MuJoCo's state gives: **every crease within the angle tolerance (3°) of its
intended angle**. Ours reports the full verdict too (seams, jams).

Per net: the yield by the angle criterion in each model, how many samples the two judge alike,
our full-verdict yield, and samples/s (ours through `yield_estimate`'s sweep, one sample per
compiled call on a CPU, compile apart; MuJoCo one `rollout` over the samples' models on two
threads).

Run: ``python -m benchmarks --only study`` (20 samples per net, the study's first round; ``--quick``:
4 nets, 4 samples).
"""

import time

import jax
import jax.numpy as jnp
import numpy as np

from origami_jax._kernel import replace_fields
from origami_jax.fab_yield import (
    PARAMETERS,
    RunOptions,
    Scatter,
    family_names,
    sample_values,
    standard_draws,
    yield_estimate,
)
from origami_jax.net import FOLD_KERNEL_SOLVE, load_net
from origami_jax.system import KOH_SOLUTION

from ._harness import Result, Timing
from ._mujoco_tree import hinge_period_step, release_controls
from .bench_net import _datas, _mujoco, _mujoco_angles

T1 = 1500.0  # µs, the pilot's control run
SEED = 0
ANGLE_TOLERANCE = np.radians(3.0)


def _sample_springs(
    pattern, design, n_samples: int, scatter: Scatter
) -> tuple[np.ndarray, np.ndarray]:
    """Each sample's hinge stiffness and aimed angle `(n, m)` each, as the fold kernel builds them
    for `yield_estimate`'s draws from `scatter` (`hinge_lengths="designed"`: aim = intended ×
    ρ₀/ρ)."""
    m = pattern.n_creases
    nominal = {
        name: np.broadcast_to(np.asarray(getattr(design, name), float), (m,))
        for name in PARAMETERS
        if name != "release"
    }
    nominal["release"] = np.zeros(m)
    values = sample_values(scatter, nominal, standard_draws(SEED, n_samples, m))
    intended = jnp.asarray(pattern.intended_angles)
    stiffness, aims = [], []
    for i in range(n_samples):
        fields = {
            "misfit_strain": jnp.asarray(values["misfit_strain"][i]),
            "t_hinge": jnp.asarray(values["t_hinge"][i]),
            "hinge_width": jnp.asarray(values["hinge_width"][i]),
            "t_structural": jnp.asarray(values["t_structural"][i, 0]),
            "drag_coefficient": jnp.asarray(values["drag_coefficient"][i, 0]),
        }
        sample = replace_fields(design, fields)
        aim = intended * sample.curvature() / design.curvature()
        per_crease = replace_fields(sample, {"theta_final": jnp.abs(aim) + 0.0})
        stiffness.append(np.asarray(per_crease.stiffness(m)))
        aims.append(np.asarray(aim))
    return np.asarray(stiffness), np.asarray(aims)


def _mujoco_finals(
    system, design, stiffness, aims, threads: int
) -> tuple[np.ndarray, float, float]:
    """MuJoCo's final hinge angles `(n, m)` of every sample, the rollout's wall seconds and the
    seconds building its models and data (its side of an end-to-end time)."""
    built = time.perf_counter()
    dt = hinge_period_step(system.mechanism, stiffness.max(axis=0))
    models = []
    for k, aim in zip(stiffness, aims, strict=True):
        model = _mujoco(system, design, dt, damped_for=k)
        model.actuator_gainprm[:, 0] = k * aim
        model.actuator_gainprm[:, 1] = -k
        models.append(model)
    controls = release_controls(np.zeros_like(aims), int(round(T1 / dt)), dt)
    data = _datas(models[0], threads)
    start = time.perf_counter()
    finals = _mujoco_angles(models, controls, data)[:, -1]
    return finals, time.perf_counter() - start, start - built


def run(quick: bool, n_samples: int | None = None) -> list[Result]:
    jax.config.update("jax_enable_x64", True)
    names = family_names("cube_nets")
    if quick:
        names = names[:4]
    n = (4 if quick else 20) if n_samples is None else n_samples
    rows, per_net = [], []
    for name in names:
        pattern = load_net(name).with_model(added_mass=False, viscous=False)
        design = pattern.default_design(KOH_SOLUTION)
        system = pattern.system(design)
        stiffness, aims = _sample_springs(pattern, design, n, Scatter())
        intended = np.asarray(pattern.intended_angles)
        # The springs as the kernel builds them: an unscattered sample's against the system's own.
        nominal_k, _ = _sample_springs(pattern, design, 1, Scatter.none())
        solve = FOLD_KERNEL_SOLVE.replace(t1=T1)
        start = time.perf_counter()
        # Judged at T1 as MuJoCo's state is (no settling run of the samples still moving).
        options = RunOptions(progress=False, t_settle=None)
        yield_estimate(pattern, Scatter(), 1, seed=SEED, solve=solve, run=options)
        compile_s = time.perf_counter() - start
        ours = yield_estimate(pattern, Scatter(), n, seed=SEED, solve=solve, run=options)
        ours_angles = np.asarray(ours.dataset["final_angle"].values)
        ours_ok = np.max(np.abs(ours_angles - intended), axis=1) < ANGLE_TOLERANCE
        finals, mujoco_s, mujoco_build_s = _mujoco_finals(
            system, design, stiffness, aims, threads=2
        )
        mujoco_ok = np.max(np.abs(finals - intended), axis=1) < ANGLE_TOLERANCE
        # Both models' springs rest at the same aims: where neither is held by contact, their
        # final angles agree (a jam, a wall held on another's edge, may differ with the dynamics).
        alike = int(np.sum(ours_ok == mujoco_ok))
        spring_check = float(np.max(np.abs(nominal_k[0] - np.asarray(system.hinges.stiffness))))
        per_net.append(
            {
                "net": name,
                "ours_angle_yield": int(ours_ok.sum()),
                "mujoco_angle_yield": int(mujoco_ok.sum()),
                "alike": alike,
                "ours_counts": ours.counts,
                "ours_s_per_sample": ours.seconds_per_sample,
                "mujoco_s_per_sample": mujoco_s / n,
                "mujoco_build_s": mujoco_build_s,
                "compile_s": compile_s,
                # From the net's pattern to its n verdicts: the first call (tracing, compiling
                # and one sample) and the estimate's own wall time.
                "ours_end_to_end_s": compile_s + ours.seconds_per_sample * n,
                "largest_angle_difference_rad": float(np.max(np.abs(ours_angles - finals))),
                "nominal_spring_difference": spring_check,
            }
        )
        print(per_net[-1], flush=True)
    total = n * len(names)
    ours_s = sum(row["ours_s_per_sample"] for row in per_net) * n / total
    mujoco_s = sum(row["mujoco_s_per_sample"] for row in per_net) * n / total
    alike = sum(row["alike"] for row in per_net)
    ours_yield = " ".join(f"{row['ours_angle_yield']}" for row in per_net)
    mujoco_yield = " ".join(f"{row['mujoco_angle_yield']}" for row in per_net)
    rows.append(
        Result(
            name=f"study scatter, {len(names)} cube nets x {n} samples (control, 1500 µs): "
            "s/sample, ours (full verdict) vs MuJoCo (crease angles)",
            ours=Timing.once(ours_s),
            peer_name="MuJoCo rollout over each net's samples (C), 2 threads",
            peer=Timing.once(mujoco_s),
            compile_s=sum(row["compile_s"] for row in per_net) / len(per_net),
            notes=(
                f"every crease within 3°, per net: ours {ours_yield}, MuJoCo {mujoco_yield} "
                f"(of {n}); judged alike {alike}/{total}; compile per net"
            ),
            extra={"n_samples": n, "nets": per_net, "alike": alike, "total": total},
        )
    )
    print(rows[-1].line(), rows[-1].notes, flush=True)
    ours_total = sum(row["ours_end_to_end_s"] for row in per_net)
    mujoco_total = sum(row["mujoco_build_s"] + row["mujoco_s_per_sample"] * n for row in per_net)
    rows.append(
        Result(
            name=f"study scatter, {len(names)} cube nets x {n} samples (control, 1500 µs), end to "
            "end (compile included): s/sample, ours vs MuJoCo",
            ours=Timing.once(ours_total / total),
            peer_name="MuJoCo: each net's models built, one rollout (C), 2 threads",
            peer=Timing.once(mujoco_total / total),
            notes=(
                f"per sample, each net from its pattern to its {n} verdicts: ours "
                f"{sum(row['compile_s'] for row in per_net):.0f} s tracing, compiling and a "
                f"first sample over {len(names)} nets + the estimates; MuJoCo "
                f"{sum(row['mujoco_build_s'] for row in per_net):.2f} s building models + the "
                "rollouts"
            ),
            extra={"n_samples": n, "total": total},
        )
    )
    print(rows[-1].line(), rows[-1].notes, flush=True)
    return rows
