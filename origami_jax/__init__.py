"""origami_jax: a differentiable JAX simulator for nanostructured origami.

Two halves, after Kinematics and Dynamics of Nanostructured Origami (see ``README.md``):

- single-vertex unfolding by charge-energy descent on the unit sphere;
- folding dynamics of hinged-flap chains driven by stressed bilayer hinges.

The library never changes JAX's global configuration on its own. Physical quantities are
float64-sensitive: call ``jax.config.update("jax_enable_x64", True)`` before using it (the CLI does
this for you); `enable_compilation_cache()` keeps compiled programs on disk between processes (the
CLI does this too).
"""

import importlib as _importlib
from typing import TYPE_CHECKING as _TYPE_CHECKING

from ._cache import enable_compilation_cache as enable_compilation_cache
from ._version import __version__ as __version__

__all__ = [  # noqa: RUF022  (listed literally so type checkers can read it)
    "__version__",
    "enable_compilation_cache",
    "chain",
    "cli",
    "contact",
    "design",
    "fab_yield",
    "fluid",
    "fold",
    "loops",
    "net",
    "plotting",
    "simulation",
    "sweep",
    "system",
    "vertex",
    "view",
]

# Subpackages load on first use so that `origami-jax --help` and `import origami_jax` stay fast;
# `origami_jax.chain`, `origami_jax.simulation`, ... behave as ordinary attributes.
# Every folder of the package is listed in `__all__` (a test checks it).
_SUBPACKAGES = frozenset(__all__) - {"__version__", "enable_compilation_cache"}


if _TYPE_CHECKING:
    from . import (  # noqa: F401
        chain,
        cli,
        contact,
        design,
        fab_yield,
        fluid,
        fold,
        loops,
        net,
        plotting,
        simulation,
        sweep,
        system,
        vertex,
        view,
    )


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        return _importlib.import_module(f"{__name__}.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_SUBPACKAGES})
