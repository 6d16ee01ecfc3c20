"""Timing helpers shared by every benchmark.

The rules (see STYLE.md, MJX): compile time is measured apart from run time by lowering and compiling
explicitly; every timed call waits on its *result* with ``jax.block_until_ready``; run times are the median
over repeats with min and max; the peer runs in the same process; answers are compared before timing.
"""

import functools
import json
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import jax


@dataclass
class Timing:
    """Seconds per call: median, min, max over ``repeats`` calls."""

    median: float
    minimum: float
    maximum: float
    repeats: int

    @classmethod
    def once(cls, seconds: float) -> "Timing":
        """A single measurement (median, min and max all `seconds`)."""
        return cls(seconds, seconds, seconds, 1)

    @classmethod
    def of(cls, samples) -> "Timing":
        """Median, min and max of several measurements (seconds)."""
        samples = sorted(float(x) for x in samples)
        n = len(samples)
        median = samples[n // 2] if n % 2 else 0.5 * (samples[n // 2 - 1] + samples[n // 2])
        return cls(median, samples[0], samples[-1], n)


@dataclass
class Result:
    """One benchmark row: ours against a peer, same inputs, answers compared first."""

    name: str
    ours: Timing
    peer_name: str | None = None
    peer: Timing | None = None
    compile_s: float | None = None
    max_abs_difference: float | None = None
    flops: float | None = None
    per_item: int = 1
    notes: str = ""
    extra: dict[str, Any] = field(default_factory=dict)

    @property
    def ratio(self) -> float | None:
        """Peer time over our time (> 1: we are faster)."""
        if self.peer is None:
            return None
        return self.peer.median / self.ours.median

    @property
    def peak_fraction(self) -> float | None:
        """Achieved FLOP/s of our kernel (XLA's count over the median time) over the machine's measured
        dense float64 matmul rate: how far the kernel is from the physical limit."""
        if not self.flops:
            return None
        return self.flops / self.ours.median / machine_peak_flops()

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["ratio_peer_over_ours"] = self.ratio
        data["peak_fraction"] = self.peak_fraction
        return data

    def line(self) -> str:
        parts = [f"{self.name}: ours {_fmt(self.ours.median / self.per_item)}/item"]
        if self.compile_s is not None:
            parts.append(f"compile {self.compile_s:.2f} s")
        if self.peer is not None:
            parts.append(f"{self.peer_name} {_fmt(self.peer.median / self.per_item)}/item")
            parts.append(f"ratio {self.ratio:.2f}x")
        if self.max_abs_difference is not None:
            parts.append(f"max |diff| {self.max_abs_difference:.2e}")
        if self.flops:
            parts.append(f"{self.flops:.3g} FLOP/call ({100 * self.peak_fraction:.2g} % of peak)")
        return ", ".join(parts)


def _fmt(seconds: float) -> str:
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)):
        if seconds >= scale:
            return f"{seconds / scale:.3g} {unit}"
    return f"{seconds / 1e-9:.3g} ns"


def time_calls(fn: Callable[[], Any], *, repeats: int, warmup: int = 1) -> Timing:
    """Time ``fn()`` (which must return its result) ``repeats`` times, blocking on JAX results."""
    for _ in range(warmup):
        jax.block_until_ready(fn())
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        jax.block_until_ready(fn())
        samples.append(time.perf_counter() - start)
    return Timing(statistics.median(samples), min(samples), max(samples), repeats)


def compile_jitted(fn: Callable, *args: Any, **kwargs: Any) -> tuple[Callable, float, float | None]:
    """Lower and compile ``jax.jit(fn)`` for these arguments.

    **Returns:** ``(compiled, compile_seconds, flops)`` where ``flops`` is XLA's cost-analysis estimate
    of floating-point operations per call (``None`` where the backend gives none).
    """
    start = time.perf_counter()
    compiled = jax.jit(fn).lower(*args, **kwargs).compile()
    seconds = time.perf_counter() - start
    flops = None
    try:
        analysis = compiled.cost_analysis()
        if isinstance(analysis, list):
            analysis = analysis[0] if analysis else {}
        flops = float(analysis.get("flops", 0.0)) or None
    except Exception:  # cost analysis is best effort and backend dependent
        flops = None
    return compiled, seconds, flops


def loop_flops(body: Callable, *args: Any, evaluations: float) -> float | None:
    """FLOP estimate of a while-loop kernel: XLA's count for one loop-free `body` × `evaluations`.

    XLA's cost analysis counts a while loop's body once, whatever the trip count, so for ODE solves and
    iterative solvers the count of the whole kernel is meaningless. This counts the dominant loop-free
    piece (e.g. the right-hand side) and multiplies by how often it ran (e.g. 6 per Tsit5 step × steps):
    a lower bound, since the solver's own arithmetic (stage sums, error norms, step control) is left
    out. Rows that use it say so in their notes.
    """
    _, _, flops = compile_jitted(body, *args)
    return None if flops is None else flops * float(evaluations)


@functools.cache
def machine_peak_flops() -> float:
    """The machine's practical peak, FLOP/s: a jitted 1024² float64 matmul (the dtype our kernels run in),
    best of 5, on the default device. Measured once per process."""
    import jax.numpy as jnp

    n = 1024
    a = jnp.ones((n, n), dtype=jnp.float64 if jax.config.jax_enable_x64 else jnp.float32)
    matmul = jax.jit(lambda x: x @ x)
    timing = time_calls(lambda: matmul(a), repeats=5)
    return 2.0 * n**3 / timing.minimum


def machine_description() -> dict[str, str]:
    """Facts about the machine and versions, recorded next to every figure."""
    import os

    info = {
        "date": time.strftime("%Y-%m-%d"),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": str(os.cpu_count()),
        "jax": jax.__version__,
        "jax_backend": jax.default_backend(),
        "devices": ", ".join(str(d) for d in jax.devices()),
        "device_kind": jax.devices()[0].device_kind,  # e.g. "NVIDIA H200"
        "peak_gflops_matmul": f"{machine_peak_flops() / 1e9:.1f}",
    }
    for module in ("equinox", "diffrax", "optimistix", "pinocchio", "mujoco", "scipy"):
        try:
            info[module] = __import__(module).__version__
        except Exception:
            pass
    return info


def dump_json(path, results: list[Result]) -> None:
    payload = {"machine": machine_description(), "results": [r.to_dict() for r in results]}
    with open(path, "w") as file:
        json.dump(payload, file, indent=2, default=str)
