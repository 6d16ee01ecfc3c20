"""Write benchmark results as Markdown (``RESULTS.md``) and a throughput-vs-batch-size figure."""

from pathlib import Path

from ._harness import Result, _fmt, machine_description


def _cell(value, fmt="{:.3g}") -> str:
    return "–" if value is None else fmt.format(value)


def results_markdown(results: list[Result], *, title: str, quick: bool) -> str:
    """A Markdown section: the machine, then one table row per result."""
    machine = machine_description()
    lines = [
        f"## {title}",
        "",
        f"Recorded {machine['date']} with `python -m benchmarks{' --quick' if quick else ''}`.",
        "",
        "Machine: " + ", ".join(f"{k} {v}" for k, v in machine.items() if k != "date"),
        "",
        "| benchmark | ours per item | compile | peer | peer per item | peer / ours | max abs diff | FLOP per call | % of peak | notes |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in results:
        lines.append(
            "| "
            + " | ".join(
                [
                    r.name,
                    _fmt(r.ours.median / r.per_item)
                    + f" (min {_fmt(r.ours.minimum / r.per_item)}, max {_fmt(r.ours.maximum / r.per_item)})",
                    _cell(r.compile_s, "{:.2f} s"),
                    r.peer_name or "–",
                    "–" if r.peer is None else _fmt(r.peer.median / r.per_item),
                    _cell(r.ratio, "{:.2f}x"),
                    _cell(r.max_abs_difference, "{:.1e}"),
                    _cell(r.flops, "{:.3g}"),
                    _cell(None if r.peak_fraction is None else 100 * r.peak_fraction, "{:.2g}"),
                    r.notes.replace("|", "/"),
                ]
            )
            + " |"
        )
    return "\n".join(lines) + "\n"


def throughput_figure(results: list[Result], path: Path) -> Path | None:
    """Plot items/s against batch size for every result carrying ``extra['throughput']``.

    ``extra['throughput']`` maps batch size to items per second (ours); ``extra['peer_throughput']``
    optionally gives the peer's figure (a flat line: the peer does not batch).
    """
    series = [r for r in results if r.extra.get("throughput")]
    if not series:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4))
    for r in series:
        sizes = sorted(int(k) for k in r.extra["throughput"])
        rates = [
            r.extra["throughput"][k]
            if k in r.extra["throughput"]
            else r.extra["throughput"][str(k)]
            for k in sizes
        ]
        (line,) = ax.loglog(sizes, rates, "o-", label=f"{r.name} (ours)")
        peer_rate = r.extra.get("peer_throughput")
        if peer_rate:
            ax.axhline(peer_rate, color=line.get_color(), ls="--", label=f"{r.name}: {r.peer_name}")
    ax.set_xlabel("batch size")
    ax.set_ylabel("items per second")
    ax.set_title("Throughput of vmapped kernels")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
