"""The compactness study's pilot (issue #48 part 6): the yield of a family of nets (the eleven cube
nets by default) under the default fabrication scatter, in one physics configuration, and its
Spearman rank correlation with the nets' compactness (`origami_jax.fab_yield.family_yield`).

Configurations (`CONFIGS`), every value inside the ranges of docs/physics.md "Adhesion and
friction" for the KOH etch bath:

- `control`: point creases, plate contact, no adhesion, no friction, the paper's dynamics in the
  bath (no fluid inertia, every hinge released at once: the package's defaults until nets in a
  liquid carried the fluid's inertia);
- `surface`: the same with adhesion and friction at the top of the bath's documented range (work
  of adhesion 10 mJ/m², seams bonding with ``γ = w t`` for the 0.2 µm panels, friction
  coefficient 0.3): the most the bath's surfaces can do, so that a trend absent here is absent
  below it too;
- `arc`, `arc-surface`: the same two with bending-arc hinges (`hinges="arc"`, fillet layout);
- `quasi-static`: the control with the bath's inertia and viscosity on every panel and each hinge
  released over 30 ms (`added_mass`, `viscous`, `release_ramp`): the device's release (an etch
  frees a hinge over minutes) where the control is the paper's step; run to the ramp + 6 ms and
  settled to twice that (docs/physics.md, "Released as an etch releases");
- `bath`: the package's defaults in the bath: the control with the fluid's inertia and viscosity,
  each net released over its own quasi-static ramp (`release_ramp="auto"`: three periods of its
  slowest mode, 24–69 ms for the cube nets, where 30 ms is 1.3–3.8 of them), run and settled by
  the defaults (`default_t_end`, `SETTLE_TIME` after the ramp).

Run: ``python -m benchmarks.compactness_study --config control --samples 8 --out DIR``; then
``--table DIR1 DIR2 ...`` prints the Markdown table of the docs from the stored `family.json`
files, and ``--diagnose DIR`` prints every sample's crease errors against its drawn film stress.
Writes DIR/family.json (`FamilyYield.to_dict()`, the configuration, the wall time) and
DIR/family.csv; each net's samples and summary in DIR/NET/ (resumed when run again).
"""

import argparse
import json
import sys
import time
from pathlib import Path

import jax
import numpy as np

import origami_jax
from origami_jax.contact import Adhesion, Friction
from origami_jax.fab_yield import SETTLE_TIME, RunOptions, Scatter, family_yield, spearman
from origami_jax.fold import catalogue_family
from origami_jax.net import FOLD_KERNEL_SOLVE, default_t_end, load_net
from origami_jax.system import KOH_SOLUTION

# The top of the documented ranges in KOH (docs/physics.md, "Adhesion and friction"): work of
# adhesion ≲ 1 mJ/m² expected, 0.1–10 mJ/m² as a sensitivity range; a seam's line energy ~ w t
# (t the panels' thickness, 0.2 µm for the catalogue's nets); friction 0.05–0.3 wet.
WORK_J_PER_M2 = 1e-2
PANEL_THICKNESS_M = 0.2e-6
LINE_J_PER_M = WORK_J_PER_M2 * PANEL_THICKNESS_M
FRICTION = 0.3
FRICTION_SLIP_M_PER_S = 0.01  # the CLI's default (--friction MU[,SLIP])

CONFIGS = {
    "control": {"hinges": "point", "surface": False},
    "surface": {"hinges": "point", "surface": True},
    "arc": {"hinges": "arc", "surface": False},
    "arc-surface": {"hinges": "arc", "surface": True},
    "quasi-static": {"hinges": "point", "surface": False, "release_ramp_us": 30_000.0},
    "bath": {"hinges": "point", "surface": False, "release_ramp_us": "auto"},
}
# After a release ramp: the run goes on this long for the panels to settle (µs).
AFTER_RAMP_US = 6000.0


def configured(name: str, config: str):
    """Net `name` (catalogue) with the physics of `config` (a key of `CONFIGS`); the adhesion's
    range is twice the net's contact activation gap (the CLI's default)."""
    if config not in CONFIGS:
        raise ValueError(f"config must be one of {sorted(CONFIGS)}, got {config!r}.")
    choice = CONFIGS[config]
    net = load_net(name).with_model(contact="plate", hinges=choice["hinges"])
    if choice.get("release_ramp_us") == "auto":
        pass  # the package's defaults: the fluid's inertia in a liquid, the quasi-static ramp
    elif "release_ramp_us" in choice:
        ramp = choice["release_ramp_us"]
        net = net.with_model(added_mass=True, viscous=True, release_ramp=ramp)
    else:  # the paper's dynamics in the bath: no fluid inertia, released at once
        net = net.with_model(added_mass=False, viscous=False, release_ramp=None)
    if not choice["surface"]:
        return net
    design = net.default_design(KOH_SOLUTION)
    span = 2 * float(net.system(design).contact.activation) * design.units.metre_per_length
    adhesion = Adhesion.from_si(design.units, work=WORK_J_PER_M2, range=span, line=LINE_J_PER_M)
    friction = Friction(
        coefficient=FRICTION, slip=design.units.from_si(FRICTION_SLIP_M_PER_S, length=1, time=-1)
    )
    return net.with_model(adhesion=adhesion, friction=friction)


def describe(config: str) -> dict:
    """The configuration as recorded in family.json."""
    choice = dict(CONFIGS[config])
    if choice.pop("surface"):
        choice.update(
            adhesion_work_J_per_m2=WORK_J_PER_M2,
            adhesion_line_J_per_m=LINE_J_PER_M,
            adhesion_range="2 x activation gap",
            friction=FRICTION,
            friction_slip_m_per_s=FRICTION_SLIP_M_PER_S,
        )
    return {"config": config, **choice}


def run_times(config: str, t_end: float | None) -> tuple[float | None, float]:
    """`(t_end, t_settle)` of `config` (µs): the given end time or the configuration's (1500 µs,
    or its release ramp + `AFTER_RAMP_US`), and the yield's settling (`RunOptions.t_settle`,
    counted from the end of the ramp: `SETTLE_TIME`, or after a ramp to twice the end time)."""
    ramp = CONFIGS[config].get("release_ramp_us")
    if ramp == "auto":
        return t_end, SETTLE_TIME  # each net's own: `default_t_end` of its ramp
    if t_end is None:
        t_end = default_t_end(None) if ramp is None else ramp + AFTER_RAMP_US
    return t_end, SETTLE_TIME if ramp is None else 2 * t_end - ramp


def run(args) -> int:
    names = args.nets.split(",") if args.nets else list(catalogue_family(args.family))
    t_end, t_settle = run_times(args.config, args.t_end)
    nets = [configured(n, args.config) for n in names]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    # Each net's wall time (compilation included), written as each net finishes, so that a run
    # cut short, then re-run over its finished nets (read back, not run), keeps them.
    walls_file = out / "wall_s.json"
    walls = json.loads(walls_file.read_text()) if walls_file.is_file() else {}
    current: list = []

    def finish_net(now):
        if current:
            name, began = current.pop()
            if (out / name / "estimate.json").is_file() and now - began > 1.0:
                walls[name] = now - began  # a net read back takes well under a second
                walls_file.write_text(json.dumps(walls, indent=1) + "\n")

    def on_net(name, index, total):
        now = time.perf_counter()
        finish_net(now)
        current.append((name, now))
        print(f"[{now - start:7.1f} s] net {index + 1}/{total}: {name}", flush=True)

    family = family_yield(
        nets,
        Scatter(),
        args.samples,
        args.seed,
        solve=FOLD_KERNEL_SOLVE.replace(t1=t_end),
        run=RunOptions(
            out=out,
            resume=True,
            workers=args.workers,
            chunk_size=args.chunk_size,
            progress=False,
            t_settle=t_settle,
        ),
        on_net=on_net,
    )
    finish_net(time.perf_counter())
    wall = sum(walls.get(n, 0.0) for n in names)
    record = {
        **describe(args.config),
        "family": args.family if not args.nets else args.nets,
        "t_end_us": t_end,
        "t_settle_us": t_settle,
        "wall_s": wall,
        "wall_s_per_net": {n: walls.get(n) for n in names},
        **family.to_dict(),
    }
    text = json.dumps(_strict(record), indent=1, default=str, allow_nan=False)
    (out / "family.json").write_text(text + "\n")
    (out / "family.csv").write_text(family.to_csv())
    print(family.summary())
    print(f"wall {wall:.0f} s (the nets' own, compilation included)")
    return 0


def _strict(value):
    """`value` with NaN as None (strict JSON: ρ is NaN when every net has the same yield)."""
    if isinstance(value, dict):
        return {k: _strict(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_strict(v) for v in value]
    if isinstance(value, float) and value != value:
        return None
    return value


def table(folders) -> str:
    """A Markdown table, one row per net, one yield column per stored family."""
    records = [json.loads((Path(f) / "family.json").read_text()) for f in folders]
    head = "| net | Rg (µm) | vertex connections | " + " | ".join(
        f"{r['config']} yield (95 % Wilson)" for r in records
    )
    lines = [head + " |", "|" + " --- |" * (3 + len(records))]
    rows = {n["name"]: n for n in sorted(records[0]["nets"], key=lambda n: n["name"])}
    for name, first in rows.items():
        cells = []
        for r in records:
            net = next((n for n in r["nets"] if n["name"] == name), None)
            if net is None:
                cells.append("—")
                continue
            folded = net["counts"].get("folded", 0)
            low, high = net["interval"]
            other = ", ".join(f"{k} {v}" for k, v in net["counts"].items() if v and k != "folded")
            cells.append(f"{folded}/{net['n_samples']} ({low:.2f}–{high:.2f}); {other}")
        lines.append(
            f"| {name} | {first['radius_of_gyration_um']:.1f} | {first['vertex_connections']} | "
            + " | ".join(cells)
            + " |"
        )
    for r in records:
        for c in r["spearman"].values():
            equal = c["rho"] is None or c["rho"] != c["rho"]
            rho = "undefined (equal yields)" if equal else f"{c['rho']:+.2f}"
            p = "" if equal else f", p = {c['p_value']:.2g}"
            lines.append(f"\n{r['config']}: Spearman ρ vs {c['measure']} {rho}{p} (n = {c['n']})")
        counts = sorted(n["n_samples"] for n in r["nets"])
        per_net = (
            f"{counts[0]} samples per net"
            if counts[0] == counts[-1]
            else f"{counts[0]}–{counts[-1]} samples per net (to ±"
            f"{r['settings']['n_samples']['half_width']:g})"
        )
        lines.append(f"{r['config']}: wall {r['wall_s']:.0f} s, {per_net}")
    for folder, r in zip(folders, records, strict=True):
        loose = loosened(folder, 2.0)
        folded = ", ".join(f"{n[-2:]} {k}/{m}" for n, (k, m) in sorted(loose["yields"].items()))
        rho = "; ".join(
            f"ρ vs {m} {v[0]:+.2f} (p = {v[1]:.2g})" for m, v in loose["spearman"].items()
        )
        lines.append(f"{r['config']} at 2× both tolerances: {folded}; {rho}")
    return "\n".join(lines)


def loosened(folder, factor: float = 2.0) -> dict:
    """The family's yields with both verdict tolerances multiplied by `factor` (one of the stored
    sensitivity factors, 0.5, 1, 2), from each net's stored margins (nothing simulated again),
    and their Spearman ρ and p against each compactness measure: `{"yields": {net: (folded, n)},
    "spearman": {measure: (rho, p)}}`."""
    record = json.loads((Path(folder) / "family.json").read_text())
    yields, counts = [], {}
    for net in record["nets"]:
        stored = json.loads((Path(folder) / net["name"] / "estimate.json").read_text())
        row = next(
            r
            for r in stored["tolerance_sensitivity"]["rows"]
            if r["angle_factor"] == factor and r["seam_factor"] == factor
        )
        counts[net["name"]] = (row["folded"], net["n_samples"])
        yields.append(row["yield"])
    out = {}
    for measure, key in (
        ("radius_of_gyration", "radius_of_gyration_um"),
        ("vertex_connections", "vertex_connections"),
    ):
        values = np.array([n[key] for n in record["nets"]], dtype=float)
        out[measure] = tuple(float(v) for v in spearman(np.array(yields), values))
    return {"yields": counts, "spearman": out}


def diagnose(folder) -> str:
    """Every stored sample of every net in `folder`: verdict, each crease's final error (degrees,
    positive past 90°) and its film's misfit strain relative to the design's, touching seams, engaged
    contact pairs."""
    import xarray as xr

    verdicts = ("folded", "jammed", "misfolded", "unfinished", "invalid")
    lines = []
    for store in sorted(Path(folder).glob("*/sweep.nc")):
        ds = xr.open_dataset(store)
        names = [v for v in ds.coords if str(v).startswith("misfit_strain[")]
        strain = np.stack([ds[v].values for v in names], axis=1)
        nominal = float(load_net(store.parent.name).default_design(KOH_SOLUTION).misfit_strain)
        final = np.degrees(np.abs(ds["final_angle"].values)) - 90.0
        lines.append(f"{store.parent.name}:")
        for i in range(ds.sizes["design"]):
            lines.append(
                f"  {i}: {verdicts[int(ds['verdict'].values[i])]:10s} error "
                + " ".join(f"{e:+5.1f}" for e in final[i])
                + "  stress "
                + " ".join(f"{100 * (s / nominal - 1):+4.0f}%" for s in strain[i])
                + f"  seams touching {int(ds['seams_touching'].values[i])}"
                + f", engaged {int(ds['engaged'].values[i])}"
                + f", angle margin {float(ds['angle_margin'].values[i]):.2f}"
                + f", seam margin {float(ds['seam_margin'].values[i]):.2f}"
            )
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.compactness_study", description=__doc__
    )
    parser.add_argument("--config", choices=sorted(CONFIGS), default="control")
    parser.add_argument("--family", default="cube_nets")
    parser.add_argument("--nets", default=None, help="comma-separated nets instead of the family")
    parser.add_argument("--samples", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--t-end", type=float, default=None, help="µs (default 1500; after a ramp, it + 6000)"
    )
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--chunk-size", type=int, default=None)
    parser.add_argument("--out", default=None)
    parser.add_argument("--table", nargs="+", default=None, help="print the table of these runs")
    parser.add_argument("--diagnose", default=None, help="print every sample of this run")
    args = parser.parse_args(argv)
    if args.table:
        print(table(args.table))
        return 0
    if args.diagnose:
        print(diagnose(args.diagnose))
        return 0
    if args.out is None:
        parser.error("--out is required to run")
    jax.config.update("jax_enable_x64", True)
    origami_jax.enable_compilation_cache()  # as the CLI: a re-run reuses the compiled nets
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
