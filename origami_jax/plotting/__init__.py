"""Figures and animations (matplotlib, an optional part): import the submodules, e.g.
`from origami_jax.plotting import chain`."""
