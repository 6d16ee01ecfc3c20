"""origami_jax: a differentiable JAX simulator for nanostructured origami.

Two halves, after Kinematics and Dynamics of Nanostructured Origami (see ``README.md``):

- single-vertex unfolding by charge-energy descent on the unit sphere;
- folding dynamics of hinged-flap chains driven by stressed bilayer hinges.

The library never changes JAX's global configuration. Physical quantities are float64-sensitive:
call ``jax.config.update("jax_enable_x64", True)`` before using it (the CLI does this for you).
"""

__version__ = "0.1.0"
