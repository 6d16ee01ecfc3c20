"""Regenerate the shipped catalogue of nets: `python -m origami_jax.fold.catalogue._generate`.

The nets are built by `origami_jax.fold._catalogue.build_catalogue` (the eleven cube nets are found
by enumerating the 35 hexominoes and keeping those that a rolled cube covers face by face).
"""

from origami_jax.fold._catalogue import write_catalogue

if __name__ == "__main__":
    for path in write_catalogue():
        print(f"wrote {path}")
