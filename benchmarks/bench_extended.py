"""The cost of each effect the extended model adds, on one step response of the 3-flap accordion.

Rows (literature design in air, 500 µs, rtol 1e-8, default solver): the paper's model on the serial
chain (the existing step row's system); the same model on the panel-tree engine the extended
variants use (`fluid=("hinge",)`: isolates the engine's own cost); + viscous drag; + added
inertia; + arc hinges (bilayer stiffness, the paper's drag); all (arc hinges, quadratic drag on every
flap, added inertia, viscous drag). Each row: compile time and run time, the system built
inside the timed function from the design (contact is left out: its geometry is built on the host
and cannot be traced from the design).

Peers: for the paper's model, the same as the existing step-response rows,
`scipy.integrate.solve_ivp(LSODA)` over Pinocchio's `aba` (`bench_simulate.lsoda_peer`); for
"+ viscous drag", the same LSODA over `aba` with the fluid's viscous wrench on every flap as
Pinocchio's external forces, and for "+ added inertia" over `crba` plus the fluid's inertia through
the flaps' Jacobians with Kirchhoff's velocity terms (`benchmarks._fluid_peer`, written from the
physics: Sader's hydrodynamic function by `scipy.special.kv`, the flaps' frequencies by
`pinocchio.crba`). Those rows are the peer's physics: their answers are compared before timing (the fluid rows' against
the peer solved at rtol 1e-12: see `lsoda_fluid_peer`).
The arc-hinge rows model more than any peer here and are shown against the paper model's peer: their
ratio is "the peer on the paper's model over ours on the extended one" (what a user pays relative
to today's scipy route). Every row's note gives its time relative to our paper model, and the fluid
rows' also the peer's own cost of the effect (its time over the paper model's peer).
"""

import numpy as np

from ._fluid_peer import lsoda_fluid_peer
from ._harness import Result, compile_jitted, time_calls
from .bench_simulate import ATOL, RTOL, SAME_ANSWER_RAD, lsoda_peer

VARIANTS = (
    ("paper model (serial chain)", dict()),
    ("paper model (panel-tree engine)", dict(fluid=("hinge",))),
    ("+ viscous drag", dict(fluid=("hinge", "viscous"))),
    ("+ added inertia", dict(fluid=("hinge", "added_mass"))),
    ("+ arc hinges", dict(hinges="arc", bilayer=True)),
    (
        "all (arc, panel drag, added inertia, viscous)",
        dict(hinges="arc", fluid="extended", bilayer=True),
    ),
)


def run(quick: bool) -> list[Result]:
    import jax

    import origami_jax.simulation as sim
    from origami_jax.chain import accordion_system
    from origami_jax.system import HingeDesign

    t1 = 300.0 if quick else 500.0
    n_save = 201
    ts = np.linspace(0.0, t1, n_save)
    repeats = 2 if quick else 5
    variants = VARIANTS[:3] if quick else VARIANTS

    paper = accordion_system(HingeDesign.literature(), 3)
    paper_peer = lsoda_peer(paper, ts, repeats)
    peers = {
        frozenset({"hinge"}): ("scipy LSODA + pinocchio.aba (paper model)", *paper_peer, None),
        frozenset({"hinge", "viscous"}): (
            "scipy LSODA + pinocchio.aba + viscous fext (same physics)",
            *lsoda_fluid_peer(HingeDesign.literature(), 3, ts, repeats, added_mass=False),
        ),
    }
    if not quick:
        peers[frozenset({"hinge", "added_mass"})] = (
            "scipy LSODA + pinocchio.crba + sum J^T A J, Kirchhoff terms (same physics)",
            *lsoda_fluid_peer(HingeDesign.literature(), 3, ts, repeats, added_mass=True),
        )

    rows = []
    paper_time = None
    for name, options in variants:
        options = dict(options)
        bilayer = options.pop("bilayer", False)
        design = HingeDesign.literature(stiffness_model="bilayer" if bilayer else "paper")

        def ours(design, options=options):
            system = accordion_system(design, 3, **options)
            trajectory = sim.simulate(
                system,
                sim.Step(),
                sim.SolveOptions(saveat=sim.SaveAt(n=n_save), rtol=RTOL, atol=ATOL, throw=False),
                t1=t1,
            )
            return trajectory.theta, trajectory.stats["num_steps"]

        compiled, compile_s, _ = compile_jitted(ours, design)
        theta, steps = jax.block_until_ready(compiled(design))
        fluid = options.get("fluid", ("hinge",))
        fluid = frozenset((fluid,) if isinstance(fluid, str) else fluid)
        same_physics = not options.get("hinges") and fluid in peers
        peer_name, reference, peer_timing, tight = peers[
            fluid if same_physics else frozenset({"hinge"})
        ]
        fluid_peer = same_physics and fluid != {"hinge"}
        theta = np.asarray(theta)
        if tight is None:
            difference = float(np.max(np.abs(theta - reference.y[:3].T)))
        else:  # the fluid peers' answers: against their tight solve (`lsoda_fluid_peer`)
            difference = float(np.max(np.abs(theta - tight)))
            peer_error = float(np.max(np.abs(reference.y[:3].T - tight)))
        if same_physics and difference > SAME_ANSWER_RAD:
            raise RuntimeError(f"{name}: answers differ by {difference:.2e} rad; not timing")
        timing = time_calls(lambda c=compiled, d=design: c(d), repeats=repeats)
        if paper_time is None:
            paper_time = timing.median
        relative = timing.median / paper_time
        row = Result(
            name=f"extended step {t1:.0f} us: {name}",
            ours=timing,
            peer_name=peer_name,
            peer=peer_timing,
            compile_s=compile_s,
            max_abs_difference=difference if same_physics else None,
            notes=f"{int(steps)} diffrax steps (default solver); {relative:.2f}x our paper "
            "model's run time"
            + (
                f"; the peer's {peer_timing.median / paper_peer[1].median:.2f}x its paper model's"
                f" ({reference.nfev} against {paper_peer[0].nfev} RHS calls); max |diff| against "
                f"the peer solved at rtol 1e-12 (DOP853), from which the timed LSODA run is "
                f"{peer_error:.2g} rad"
                if fluid_peer
                else ""
            )
            + (
                ""
                if same_physics
                else f"; not the peer's physics (max |theta - paper| {difference:.2g} rad)"
            ),
        )
        # Printed as measured: a long run keeps what it has if it is stopped.
        print("  (row)", row.line(), "|", row.notes, flush=True)
        rows.append(row)
    return rows
