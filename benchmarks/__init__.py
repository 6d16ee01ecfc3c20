"""origami_jax benchmarks: our kernels side by side with the peers a user would otherwise pick.

Run ``python -m benchmarks --quick`` (smoke run, seconds) or ``python -m benchmarks`` (full). Each module
``benchmarks/bench_<name>.py`` defines ``run(quick: bool) -> list[dict]`` and is discovered by the runner.
"""
