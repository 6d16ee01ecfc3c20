"""Paper part: unfoldings of the corner cube and the waterbomb base (paper Fig. 3)."""

from pathlib import Path


def run(out: Path) -> list[str]:
    raise NotImplementedError("single-vertex unfolding lands with issue #5")
