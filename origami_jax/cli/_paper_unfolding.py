"""Paper part: unfoldings of the corner cube and the waterbomb base (paper Fig. 3)."""

from pathlib import Path

from ._unfold import write_path


def run(out: Path) -> list[str]:
    """Unfold Fig. 3's corner cube (3a) and waterbomb base (3b) with both energies; write the paths
    and pictures into `out/unfolding/`; return summary lines."""
    from .. import vertex
    from ..plotting.vertex import save_unfolding_pictures

    folder = Path(out) / "unfolding"
    folder.mkdir(parents=True, exist_ok=True)
    lines = []
    for name, make in (("corner_cube", vertex.corner_cube), ("waterbomb", vertex.waterbomb_base)):
        for energy in ("separable", "nonseparable"):
            result = vertex.unfold(make(), energy=energy)
            stem = f"{name}_{energy}"
            write_path(result, folder, stem=f"{stem}_path")
            if energy == "separable":  # the figure: one set of pictures per example
                save_unfolding_pictures(result, folder, stem=stem)
            cert = result.certificate
            lines.append(
                f"Fig. 3 {name} ({energy}, p = {result.p:g}): {result.verdict.value} in "
                f"{result.accepted_steps} steps, certificate {'OK' if cert and cert.ok else 'FAILED'}, "
                f"{result.crease_report.summary()}; run {result.timings['run'] * 1e3:.0f} ms"
            )
    lines.append(f"pictures and paths in {folder}")
    return lines
