"""Regenerate the documentation's gallery (`docs/gallery/`) from `origami-jax paper`.

    python docs/scripts/make_gallery.py                      # runs `origami-jax paper` (minutes)
    python docs/scripts/make_gallery.py --from origami_out   # reuses the output of an earlier run

Copies the figures the gallery shows into `docs/gallery/` (re-encoded as palette PNGs to keep the
repository small), writes `numbers.md` (the paper's numbers next to the run's, from its JSON records)
and `summary.txt` (the run's own summary, without machine-specific paths). `docs/gallery/index.md`
includes both; commit the changed files.
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
GALLERY = ROOT / "docs" / "gallery"

# Output of `origami-jax paper` -> name in the gallery.
FIGURES = {
    "unfolding/corner_cube_separable_strip.png": "fig3a_corner_cube.png",
    "unfolding/corner_cube_separable_energy.png": "fig3a_corner_cube_energy.png",
    "unfolding/waterbomb_separable_strip.png": "fig3b_waterbomb.png",
    "fig7_8_step_air_angles.png": "fig7_step_air.png",
    "fig7_8_step_air_frames.png": "fig8_step_air_frames.png",
    "fig7_8_step_koh_angles.png": "fig7_step_koh.png",
    "fig10_11_fast_ramp_air_angles.png": "fig10_fast_ramp_air.png",
    "fig10_11_fast_ramp_air_frames.png": "fig11_fast_ramp_air_frames.png",
    "calibration/fig7_calibration_response.png": "fig7_calibrated.png",
}

PAPER_RISE_US = (37.0, 101.0, 38.0)  # paper, "Step Input" (Fig. 7)
PAPER_OVERSHOOT_PERCENT = 39.0  # joint 1


def _shrink(source: Path, target: Path) -> None:
    """Copy a figure as an 8-bit palette PNG (line plots lose nothing visible)."""
    from PIL import Image

    with Image.open(source) as image:
        image.convert("RGB").quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(
            target, optimize=True
        )


def _fmt(values, spec: str = ".1f") -> str:
    return " / ".join("–" if v is None or math.isnan(v) else format(v, spec) for v in values)


def numbers_table(out: Path) -> str:
    """Markdown tables: the paper's numbers next to the run's."""
    dynamics = json.loads((out / "dynamics_metrics.json").read_text())
    calibration = json.loads((out / "calibration" / "fig7_calibration.json").read_text())
    air, koh = dynamics["step_air"], dynamics["step_koh"]
    ramp_air, ramp_koh = dynamics["fast_ramp_air"], dynamics["fast_ramp_koh"]
    slow = dynamics["slow_ramp_koh"]
    fitted = {name: p["value"] for name, p in calibration["parameters"].items()}
    achieved = {row["label"]: row["achieved"] for row in calibration["targets"]}
    rise_fit = [achieved[f"rise_time[joint {j}]"] for j in (1, 2, 3)]
    overshoot_fit = 100 * achieved["overshoot[joint 1]"]
    paper_rise = _fmt(PAPER_RISE_US, ".0f")
    lines = [
        "| Fig. 7, step response | rise time, joints 1 / 2 / 3 (µs) | overshoot, joints 1 / 2 / 3 (%) |",
        "| --- | --- | --- |",
        f"| paper | {paper_rise} | {PAPER_OVERSHOOT_PERCENT:.0f} / – / – |",
        f"| package, literature values, air | {_fmt(air['rise_time'])} | {_fmt(air['overshoot'])} |",
        f"| package, literature values, KOH bath | {_fmt(koh['rise_time'])} | {_fmt(koh['overshoot'])} |",
        f"| package, calibrated to the paper (k × {fitted['k_scale']:.3g}, "
        f"b × {fitted['b_scale']:.3g}), air | {_fmt(rise_fit)} | {overshoot_fit:.1f} / – / – |",
        "",
        "| Fig. 10, ramp of 0.1 s | overshoot, joints 1 / 2 / 3 (%) |",
        "| --- | --- |",
        '| paper | "minimal overshoot" |',
        f"| package, literature values, air | {_fmt(ramp_air['overshoot'], '.3f')} |",
        f"| package, literature values, KOH bath | {_fmt(ramp_koh['overshoot'], '.3f')} |",
        "",
        f'The real etch ramp in the KOH bath (β = 1.5 µm/min, the paper\'s "2–3 hours") lasts '
        f"{slow['duration_hours']:.2f} h; the package integrates it in {slow['steps']} implicit steps, "
        f"with the hinges within {max(slow['large_step_error_rad']):.1e} rad of the desired angles at "
        f"the samples and within {max(slow['quasi_static_error_rad']):.1e} rad over the first "
        f"{slow['window_us'] / 1e3:.0f} ms resolved in full.",
    ]
    return "\n".join(lines) + "\n"


def summary_text(out: Path) -> str:
    """The run's `summary.txt` without lines that name its output folder or its timings."""
    keep = [
        line
        for line in (out / "summary.txt").read_text().splitlines()
        if str(out) not in line and not line.startswith("(took ")
    ]
    return "\n".join(keep).strip() + "\n"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--from",
        dest="source",
        type=Path,
        help="output folder of an earlier `origami-jax paper --out ...` (default: run it now)",
    )
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as scratch:
        out = args.source
        if out is None:
            out = Path(scratch) / "paper"
            command = [sys.executable, "-m", "origami_jax", "paper", "--out", str(out)]
            print("running:", " ".join(command), flush=True)
            # This checkout's package, whatever is installed.
            path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
            subprocess.run(command, check=True, cwd=ROOT, env=dict(os.environ, PYTHONPATH=path))
        out = out.resolve()
        GALLERY.mkdir(parents=True, exist_ok=True)
        for source, name in FIGURES.items():
            _shrink(out / source, GALLERY / name)
            print(f"{GALLERY / name}: {(GALLERY / name).stat().st_size / 1e3:.0f} kB")
        (GALLERY / "numbers.md").write_text(numbers_table(out))
        (GALLERY / "summary.txt").write_text(summary_text(out))
    print(f"gallery updated in {GALLERY}; commit it.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
