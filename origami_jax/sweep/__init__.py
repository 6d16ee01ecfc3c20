"""Batch sweeps over designs: one compiled, vmapped, device-sharded call per chunk, resumable.

```python
import origami_jax.sweep as ojs

space = ojs.Grid({"hinge_width": [5e-6, 1e-5, 2e-5], "fluid": ["air", "koh"]},
                 units={"hinge_width": "m"})
ds = ojs.sweep(kernel, space, out="sweep_out", resume=True)   # xarray.Dataset
```

- Design spaces: `Grid` (full factorial), `Samples` (seeded Latin hypercube or uniform, linear or
  log `Range`s), `Table` (explicit designs), `Product` (`a * b`).
- `sweep(fn, space, ...)`: `fn` is a `Kernel` or a plain function of one design's parameters.
- Models the command line knows (`origami-jax sweep CONFIG.toml`): `available_models()`,
  `get_model(name, **options)`: `"accordion-step"` (step-response metrics of the n-flap accordion,
  the accordion's own kernel `origami_jax.chain.accordion_step`), `"vertex-unfold"` (unfolding
  verdicts of random single vertices) and `"net-fold"` (a net's or loop pattern's fold kernel,
  `origami_jax.net.fold_kernel`). `load_config(path)` reads a sweep TOML file.

**Several devices, several hosts.** On one host the batch axis is sharded over
`jax.local_devices()` (on CPU, `XLA_FLAGS=--xla_force_host_platform_device_count=N` set before
JAX starts splits the cores into `N` devices). Across hosts, call `jax.distributed.initialize()` in
each process first, point every process at the same `out` folder on a shared file system and run
the same program everywhere; each process computes every `jax.process_count()`-th chunk on its local
devices and process 0 gathers the dataset (see `sweep`'s module for details).
"""

from .._kernel import Kernel as Kernel
from ._config import SweepConfig as SweepConfig
from ._config import load_config as load_config
from ._engine import AXIS as AXIS
from ._engine import TRACES as TRACES
from ._engine import TraceCache as TraceCache
from ._engine import sweep as sweep
from ._kernels import available_models as available_models
from ._kernels import get_model as get_model
from ._space import AbstractDesignSpace as AbstractDesignSpace
from ._space import Grid as Grid
from ._space import Product as Product
from ._space import Range as Range
from ._space import Samples as Samples
from ._space import Table as Table
from ._store import SweepBusyError as SweepBusyError
from ._store import store_result as store_result
