"""Time to a first result: the command line cold and warm against a SciPy + Pinocchio + matplotlib
script, where compile time goes, and a notebook's rerun after a parameter change.

- **CLI, end to end:** `origami-jax simulate --input step --flaps 3` with its figures (angle plot,
  3D frames, GIF), as a new process: *cold* with an empty compilation cache folder, *warm* the same
  command again (programs loaded from the cache). Wall time of the whole process, imports included
  (the package's bytecode compiled, as an installation has it: `command_env`).
- **Peer:** the script a robotics user would write for the same job: imports, the accordion in
  Pinocchio (`pin.aba` plus hinge springs and quadratic drag), `solve_ivp(method="LSODA")` over the
  same 2000 µs and 2001 samples, a CSV, the angle plot, and a 24-frame GIF of the panels with
  matplotlib. Also a new process, timed the same way.
- **Script, end to end:** the library called from a script (`enable_compilation_cache()`, the
  accordion's step response over the same 2000 µs, its metrics, a CSV; no figures), cold and warm as
  the CLI: what a script user waits for in each new process.
- **Where compile time goes** (in this process, no persistent cache): the first `simulate` call,
  the first reverse-mode gradient of a metric through it and its first forward-mode derivative
  (`diffrax.ForwardMode`), split with JAX's monitoring events into
  tracing (Python to jaxpr), lowering (jaxpr to StableHLO) and XLA compilation.
- **Notebook:** after those, a parameter change followed by a new step response, and a new
  gradient, in the same process.
- **`design` and `unfold`:** their first calls in the same process (programs they share with the
  rows above are already compiled), split the same way.

Run: `python -m benchmarks.bench_compile [--repeats N]` (about 1-6 minutes on 2 cores);
`python -m benchmarks --only compile` gives the same rows in the suite's format.
"""

import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

from ._harness import Result, Timing

SAME_ANSWER_RAD = 1e-3  # both at rtol 1e-7: they agree to ~4e-5 rad over the first 500 us

ROOT = Path(__file__).resolve().parents[1]

PEER_SCRIPT = """
import sys, time
import numpy as np
import pinocchio as pin
from scipy.integrate import solve_ivp
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.animation import FuncAnimation, PillowWriter
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

out = sys.argv[1]
# The literature accordion (MICRO units: um, us, ng; torque pN*m), numbers from origami_jax.
n, L, W = 3, {length!r}, {width!r}
points, cgs = np.array({points!r}), np.array({cgs!r})
mass, inertia, k, b, target = {mass!r}, {inertia!r}, {k!r}, {b!r}, {target!r}
model = pin.Model()
parent, previous = 0, np.zeros(3)
for i in range(n):
    placement = pin.SE3(np.eye(3), points[i] - previous)
    previous = points[i]
    joint = model.addJoint(parent, pin.JointModelRX(), placement, f"hinge_{{i + 1}}")
    model.appendBodyToJoint(
        joint, pin.Inertia(mass[i], cgs[i] - points[i], np.array(inertia[i])), pin.SE3.Identity()
    )
    parent = joint
model.gravity = pin.Motion.Zero()
data = model.createData()
k, b, tau = np.array(k), np.array(b), np.array(k) * np.array(target)

def rhs(t, y):
    q, v = y[:n], y[n:]
    return np.concatenate([v, pin.aba(model, data, q, v, tau - k * q - b * v * np.abs(v))])

ts = np.linspace(0.0, 2000.0, 2001)
sol = solve_ivp(rhs, (0.0, 2000.0), np.zeros(2 * n), method="LSODA", t_eval=ts, rtol=1e-7,
                atol=1e-9)
assert sol.success, sol.message
np.savetxt(out + "/trajectory.csv", np.column_stack([ts, sol.y.T]), delimiter=",")
fig, ax = plt.subplots(figsize=(7, 4))
ax.plot(ts, sol.y[:n].T)
ax.set_xlabel("time [us]")
ax.set_ylabel("angle [rad]")
fig.savefig(out + "/angles.png", dpi=120)
plt.close(fig)
corners = np.array([[-W / 2, 0, 0], [W / 2, 0, 0], [W / 2, L, 0], [-W / 2, L, 0]])

def panels(q):
    pin.forwardKinematics(model, data, q)
    return [corners @ data.oMi[j].rotation.T + data.oMi[j].translation for j in range(1, n + 1)]

frames = np.linspace(0, 700, 24).astype(int)
fig = plt.figure(figsize=(4, 4))
ax = fig.add_subplot(projection="3d")

def update(i):
    ax.cla()
    ax.add_collection3d(Poly3DCollection(panels(sol.y[:n, frames[i]]), edgecolors="k"))
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-400, 400)
    ax.set_title(f"t = {{ts[frames[i]]:.0f}} us")

FuncAnimation(fig, update, frames=len(frames)).save(out + "/animation.gif",
                                                     writer=PillowWriter(fps=12))
"""


def _peer_script() -> str:
    import numpy as np

    from origami_jax.chain import accordion_system, flap_size
    from origami_jax.system import HingeDesign

    design = HingeDesign.literature()
    system = accordion_system(design, 3)
    chain = system.mechanism
    length, width = flap_size(design.units)  # the accordion's default flaps, as the system's
    if not np.allclose(np.asarray(chain.axes), [1.0, 0.0, 0.0]):
        raise ValueError("the peer script is written for hinges along x (the accordion)")
    # Inertia about each flap's centre, in the world frame of the flat state (as bench_simulate).
    inertias = [
        (
            np.asarray(chain.cg_poses[i, :3, :3])
            @ np.asarray(chain.inertias[i])
            @ np.asarray(chain.cg_poses[i, :3, :3]).T
        ).tolist()
        for i in range(3)
    ]
    return PEER_SCRIPT.format(
        points=np.asarray(chain.points).tolist(),
        cgs=np.asarray(chain.cg_poses[:, :3, 3]).tolist(),
        length=float(length),
        width=float(width),
        mass=np.asarray(chain.masses).tolist(),
        inertia=inertias,
        k=np.asarray(system.hinges.stiffness).tolist(),
        b=np.asarray(system.drag.coefficient).tolist(),
        target=np.asarray(system.hinges.target).tolist(),
    )


SCRIPT = """
import sys
import jax
import numpy as np
import origami_jax
from origami_jax import chain, simulation, system

jax.config.update("jax_enable_x64", True)
origami_jax.enable_compilation_cache()
accordion = chain.accordion_system(system.HingeDesign.literature(), 3)
trajectory = simulation.simulate(accordion, simulation.Step(), t1=2000.0)
metrics = simulation.response_metrics(trajectory)
table = np.column_stack([np.asarray(trajectory.times), np.asarray(trajectory.theta)])
np.savetxt(sys.argv[1], table, delimiter=",")
print("rise times (us):", np.asarray(metrics.rise_time))
"""


def command_env() -> dict[str, str]:
    """The environment of a timed command's new process: this one's, without a JAX cache folder
    of its own (each run names `ORIGAMI_JAX_CACHE`) and with the package's bytecode compiled and
    kept, as an installation has it (`pip install` compiles it; Python keeps it after a first
    import). Where `PYTHONDONTWRITEBYTECODE` is set, as in some containers, every run would
    otherwise compile every module of the package from source (~0.7 s on 2 cores), which no
    user's second run does."""
    unset = ("JAX_COMPILATION_CACHE_DIR", "PYTHONDONTWRITEBYTECODE")
    env = {k: v for k, v in os.environ.items() if k not in unset}
    env["PYTHONPATH"] = str(ROOT)
    compileall = [sys.executable, "-m", "compileall", "-q", str(ROOT / "origami_jax")]
    subprocess.run(compileall, check=True, capture_output=True, env=env)
    return env


def _wall(argv: list[str], env: dict[str, str]) -> float:
    start = time.perf_counter()
    process = subprocess.run(argv, capture_output=True, text=True, env=env, cwd=ROOT)
    elapsed = time.perf_counter() - start
    if process.returncode != 0:
        raise RuntimeError(f"{' '.join(argv[:4])}... failed: {process.stderr[-2000:]}")
    return elapsed


def end_to_end(repeats: int = 1) -> dict[str, list[float]]:
    """Wall seconds of cold and warm CLI runs and of the peer script, each a new process."""
    times: dict[str, list[float]] = {
        "cold": [],
        "warm": [],
        "peer": [],
        "script_cold": [],
        "script_warm": [],
    }
    env = command_env()
    with tempfile.TemporaryDirectory(prefix="bench_compile_") as tmp:
        peer = Path(tmp) / "peer.py"
        peer.write_text(textwrap.dedent(_peer_script()))
        for r in range(repeats):
            env["ORIGAMI_JAX_CACHE"] = str(Path(tmp) / f"cache{r}")
            cli = [sys.executable, "-m", "origami_jax", "simulate", "--input", "step"]
            cli += ["--flaps", "3", "--overwrite", "--out", str(Path(tmp) / "out")]
            times["cold"].append(_wall(cli, env))
            times["warm"].append(_wall(cli, env))
            (Path(tmp) / "peer_out").mkdir(exist_ok=True)
            times["peer"].append(
                _wall([sys.executable, str(peer), str(Path(tmp) / "peer_out")], env)
            )
            env["ORIGAMI_JAX_CACHE"] = str(Path(tmp) / f"script_cache{r}")
            script = [sys.executable, "-c", SCRIPT, str(Path(tmp) / "script.csv")]
            times["script_cold"].append(_wall(script, env))
            times["script_warm"].append(_wall(script, env))
        # Same answer first: the angles over the fold and its first ringing (past ~0.5 ms two
        # correct solvers drift apart: see bench_simulate).
        ours = np.loadtxt(Path(tmp) / "out" / "trajectory.csv", delimiter=",", skiprows=1)
        theirs = np.loadtxt(Path(tmp) / "peer_out" / "trajectory.csv", delimiter=",")
        difference = float(np.abs(ours[:501, 1:4] - theirs[:501, 1:4]).max())
        if not difference < SAME_ANSWER_RAD:
            raise RuntimeError(f"the CLI and the peer script disagree by {difference:.3g} rad")
        times["max_abs_difference"] = [difference]
    return times


class _Stages:
    """Seconds spent tracing, lowering and compiling (JAX's monitoring events) while active."""

    EVENTS = {
        "/jax/core/compile/jaxpr_trace_duration": "trace",
        "/jax/core/compile/jaxpr_to_mlir_module_duration": "lower",
        "/jax/core/compile/backend_compile_duration": "compile",
    }

    def __init__(self):
        self.seconds = dict.fromkeys(self.EVENTS.values(), 0.0)

    def __call__(self, event, duration, **kwargs):
        if event in self.EVENTS:
            self.seconds[self.EVENTS[event]] += duration


def _staged(call):
    import jax

    stages = _Stages()
    jax.monitoring.register_event_duration_secs_listener(stages)
    start = time.perf_counter()
    try:
        jax.block_until_ready(call())
    finally:
        jax.monitoring.unregister_event_duration_listener(stages)
    return time.perf_counter() - start, stages.seconds


def in_process() -> dict[str, dict]:
    """First `simulate`, first reverse-mode gradient and first forward-mode derivative with their
    stages, then reruns after a parameter change (the notebook case)."""
    import diffrax
    import jax
    import jax.numpy as jnp

    import origami_jax.simulation as sim
    from origami_jax.chain import accordion_system
    from origami_jax.system import HingeDesign

    jax.config.update("jax_enable_x64", True)

    def response(k_scale, adjoint=None):
        system = accordion_system(HingeDesign.literature(k_scale=k_scale), 3)
        return sim.simulate(system, sim.Step(), sim.SolveOptions(adjoint=adjoint), t1=2000.0).theta

    def overshoot_like(k_scale, adjoint=None):
        # A smooth metric of the response: the mean square angle of joint 1 over the run.
        return jnp.mean(response(k_scale, adjoint)[:, 0] ** 2)

    gradient = jax.grad(overshoot_like)
    # Forward mode: the derivative of the same metric by one tangent (a design fit's Jacobian
    # columns), traced through the solve's forward-mode path.
    tangent = jax.jacfwd(lambda k: overshoot_like(k, diffrax.ForwardMode()))
    rows = {}
    wall, stages = _staged(lambda: response(jnp.asarray(1.0)))
    rows["simulate, first call"] = {"wall": wall, **stages}
    wall, stages = _staged(lambda: gradient(jnp.asarray(1.0)))
    rows["reverse-mode gradient, first call"] = {"wall": wall, **stages}
    wall, stages = _staged(lambda: tangent(jnp.asarray(1.0)))
    rows["forward-mode derivative, first call"] = {"wall": wall, **stages}
    wall, stages = _staged(lambda: response(jnp.asarray(1.3)))
    rows["simulate after a parameter change"] = {"wall": wall, **stages}
    wall, stages = _staged(lambda: gradient(jnp.asarray(1.3)))
    rows["gradient after a parameter change"] = {"wall": wall, **stages}
    wall, stages = _staged(lambda: tangent(jnp.asarray(1.3)))
    rows["forward-mode derivative after a parameter change"] = {"wall": wall, **stages}
    rows.update(first_calls_of_design_and_unfold())
    return rows


def first_calls_of_design_and_unfold() -> dict[str, dict]:
    """The first `design` (a two-parameter fit of the 3-flap accordion to three rise times, four
    starts) and the first `unfold` (the corner cube vertex), with their stages. Compile time
    dominates both; the wall time includes the (short) runs."""
    import origami_jax.design as ojd
    from origami_jax import simulation, vertex
    from origami_jax.system import HingeDesign

    rows = {}
    targets = ojd.Targets(rise_time=[30.0, 30.0, 30.0])
    wall, stages = _staged(
        lambda: ojd.design(
            HingeDesign.literature(),
            targets,
            ["k_scale", "b_scale"],
            simulation.FIT_OPTIONS.replace(t1=400.0),
            n_starts=4,
            max_steps=16,
            throw=False,
        )
    )
    rows["design, first call (2 parameters, 4 starts, 16 steps)"] = {"wall": wall, **stages}
    wall, stages = _staged(lambda: vertex.unfold(vertex.corner_cube()))
    rows["unfold, first call (corner cube)"] = {"wall": wall, **stages}
    return rows


def run(quick: bool) -> list[Result]:
    times = end_to_end(repeats=1)
    rows = [
        Result(
            "CLI simulate --input step --flaps 3, figures, cold cache (new process)",
            Timing.of(times["cold"]),
            peer_name="scipy LSODA + pinocchio.aba + matplotlib script (new process)",
            peer=Timing.of(times["peer"]),
            max_abs_difference=times["max_abs_difference"][0],
        ),
        Result(
            "CLI simulate --input step --flaps 3, figures, warm cache (new process)",
            Timing.of(times["warm"]),
            peer_name="scipy LSODA + pinocchio.aba + matplotlib script (new process)",
            peer=Timing.of(times["peer"]),
        ),
        Result(
            "script: step response, metrics, CSV (no figures), cold cache (new process)",
            Timing.of(times["script_cold"]),
        ),
        Result(
            "script: step response, metrics, CSV (no figures), warm cache (new process)",
            Timing.of(times["script_warm"]),
        ),
    ]
    if not quick:
        for name, row in in_process().items():
            notes = ", ".join(f"{k} {row[k]:.2f} s" for k in ("trace", "lower", "compile"))
            rows.append(Result(name, Timing.of([row["wall"]]), notes=notes, extra=row))
    return rows


def main(argv=None) -> None:
    import argparse

    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.bench_compile",
        description="Time to a first result: the CLI cold and warm against the SciPy + Pinocchio "
        "script, then the first calls of simulate, its gradients, design and unfold in one process "
        "(stages from JAX's monitoring events).",
    )
    parser.add_argument(
        "--repeats", type=int, default=1, help="end-to-end runs of each command (default 1)"
    )
    args = parser.parse_args(argv)
    times = end_to_end(repeats=args.repeats)
    for key, values in times.items():
        print(f"{key:>5}: " + ", ".join(f"{v:.3g}" for v in values), flush=True)
    for name, row in in_process().items():
        stages = ", ".join(f"{k} {row[k]:.2f} s" for k in ("trace", "lower", "compile"))
        print(f"{name}: {row['wall']:.2f} s wall ({stages})", flush=True)


if __name__ == "__main__":
    main()
